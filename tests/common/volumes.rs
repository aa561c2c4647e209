//! Scenes of several volumes: a scratch folder, the slab fixture, running murk and reading
//! a channel of its EXR.

use exr::prelude::{FlatSamples, read_all_flat_layers_from_file};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub const MURK: &str = env!("CARGO_BIN_EXE_murk");

/// An empty folder of the tests' own, `volumes-<name>`.
pub fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("volumes-{name}"));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

/// `fixtures/slab.vdb`: density exactly 1 over x, y ∈ [−2, 2], z ∈ [0, 1] (∫ρ dz = 1).
pub fn slab() -> String {
    fixture("slab.vdb")
}

pub fn fixture(name: &str) -> String {
    format!("{}/fixtures/{name}", env!("CARGO_MANIFEST_DIR"))
}

pub fn murk(args: &[&str]) -> Output {
    Command::new(MURK)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot run {MURK}: {e}"))
}

/// Renders the scene file `text` (written as `<dir>/<name>.toml`) to `<dir>/<name>.exr`,
/// which it returns; the render must succeed.
pub fn render(dir: &Path, name: &str, text: &str) -> PathBuf {
    let scene = dir.join(format!("{name}.toml"));
    fs::write(&scene, text).unwrap();
    let out = dir.join(format!("{name}.exr"));
    let r = murk(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(
        r.status.success(),
        "{name}: {}",
        String::from_utf8_lossy(&r.stderr)
    );
    out
}

/// The channel names of a one-part EXR.
pub fn channel_names(path: &Path) -> Vec<String> {
    let image = read_all_flat_layers_from_file(path).unwrap();
    image.layer_data[0]
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect()
}

/// Every value of channel `name` of a one-part EXR.
pub fn channel(path: &Path, name: &str) -> Vec<f32> {
    channel_with_width(path, name).1
}

/// The image's width, and every value of its channel `name`, row-major, of a one-part EXR.
pub fn channel_with_width(path: &Path, name: &str) -> (usize, Vec<f32>) {
    let image = read_all_flat_layers_from_file(path).unwrap();
    let layer = &image.layer_data[0];
    let c = layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name.to_string() == name)
        .unwrap_or_else(|| panic!("{}: no channel {name}", path.display()));
    let values = match &c.sample_data {
        FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
        FlatSamples::F32(v) => v.clone(),
        FlatSamples::U32(_) => panic!("u32 channel"),
    };
    (layer.size.width(), values)
}
