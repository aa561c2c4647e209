//! Helpers of the camera tests (`camera_files.rs`, `camera_cycles.rs`): the stages
//! usd-core authors, frames rendered through a camera file, and what an EXR holds.

use super::frames::ok;
use super::tools;
use std::fs;
use std::path::{Path, PathBuf};

/// A Nuke .chan of three frames: frame tx ty tz rx ry rz vfov.
pub const CHAN: &str =
    "1 0.2 0.3 6.5 -3 5 0 30\n2 0.5 0.4 6.2 -4 9 2 32\n3 0.8 0.5 5.9 -5 13 4 34\n";

pub fn fixture(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
        .display()
        .to_string()
}

pub fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("camera-{name}"));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

/// The stages of scripts/usd_camera.py, authored by usd-core in `dir`.
pub fn author_stages(dir: &Path) {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/usd_camera.py");
    let out = tools::command(&tools::USD_CORE)
        .arg(&script)
        .arg(dir)
        .arg(fixture("cloud.vdb"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// `murk render` of `input` (a .vdb or a scene) at frames 1 to 3 into `name.####.exr`.
pub fn render_frames(dir: &Path, input: &str, name: &str, extra: &[&str]) -> Vec<PathBuf> {
    let out = dir.join(format!("{name}.####.exr"));
    let mut args = vec![
        "render",
        input,
        "-o",
        out.to_str().unwrap(),
        "--frames",
        "1-3",
        "--res",
        "48x32",
        "--quiet",
    ];
    args.extend(extra);
    ok(dir, &args);
    (1..=3)
        .map(|f| dir.join(format!("{name}.{f:04}.exr")))
        .collect()
}

/// The header's worldToCamera (as stored: m44f, row by row).
pub fn world_to_camera(exr: &Path) -> [f32; 16] {
    let meta = exr::meta::MetaData::read_from_file(exr, false).unwrap();
    let m = meta.headers[0]
        .own_attributes
        .world_to_camera
        .unwrap_or_else(|| panic!("{}: no worldToCamera", exr.display()));
    let mut out = [0f32; 16];
    out.copy_from_slice(&m[..]);
    out
}

/// The exact samples of the EXR's channels, for comparing two images without a tool.
pub fn samples(exr: &Path) -> Vec<(String, Vec<u32>)> {
    use exr::prelude::{FlatSamples, read_all_flat_layers_from_file};
    let img = read_all_flat_layers_from_file(exr).unwrap();
    img.layer_data[0]
        .channel_data
        .list
        .iter()
        .map(|c| {
            let bits = match &c.sample_data {
                FlatSamples::F16(v) => v.iter().map(|h| h.to_bits() as u32).collect(),
                FlatSamples::F32(v) => v.iter().map(|f| f.to_bits()).collect(),
                FlatSamples::U32(v) => v.clone(),
            };
            (c.name.to_string(), bits)
        })
        .collect()
}

/// The alpha channel of a one-part EXR.
pub fn alpha_of(exr: &Path) -> Vec<f32> {
    super::volumes::channel(exr, "A")
}
