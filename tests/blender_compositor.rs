//! An EXR written with murk's defaults opens in the right place, with its passes, in
//! Blender's compositor: `scripts/blender_compositor.py` runs in `blender -b` (Debian's
//! `blender`, 3.4.1; `.ci/run` installs it), feeds the file's alpha through an Image
//! node to the Composite node and writes it out; the plane must equal the alpha murk
//! wrote, pixel for pixel. Where Blender is not installed the test is skipped.
//! A cropped dataWindow (`--crop-data-window`) is measured too and reported: Blender
//! 3.4 misplaces it, which is why it is not the default.

mod common;
use common::tools;

use exr::prelude::{FlatSamples, read_all_flat_layers_from_file};
use std::path::{Path, PathBuf};
use std::process::Command;

const MURK: &str = env!("CARGO_BIN_EXE_murk");
const W: usize = 96;
const H: usize = 54;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Channel `name` over the display window (0 outside the data window).
fn full_channel(path: &Path, name: &str) -> Vec<f32> {
    let image = read_all_flat_layers_from_file(path).unwrap();
    let layer = &image.layer_data[0];
    let (x0, y0) = (
        layer.attributes.layer_position.0 as usize,
        layer.attributes.layer_position.1 as usize,
    );
    let (w, h) = (layer.size.0, layer.size.1);
    let c = layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name.to_string() == name)
        .unwrap_or_else(|| panic!("{}: no channel {name}", path.display()));
    let v: Vec<f32> = match &c.sample_data {
        FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
        FlatSamples::F32(v) => v.clone(),
        FlatSamples::U32(_) => panic!("u32"),
    };
    let (dw, dh) = (
        image.attributes.display_window.size.0,
        image.attributes.display_window.size.1,
    );
    let mut out = vec![0.0; dw * dh];
    for y in 0..h {
        for x in 0..w {
            out[(y0 + y) * dw + x0 + x] = v[y * w + x];
        }
    }
    out
}

fn blender_sees(exr: &Path, dir: &Path, name: &str) -> (serde_json::Value, Vec<f32>) {
    let json = dir.join(format!("{name}.json"));
    let alpha = dir.join(format!("{name}_alpha.exr"));
    let out = tools::command(&tools::BLENDER)
        .args(["-b", "--factory-startup", "-noaudio", "--python"])
        .arg(root().join("scripts/blender_compositor.py"))
        .arg("--")
        .arg(exr)
        .args([W.to_string(), H.to_string()])
        .arg(&json)
        .arg(&alpha)
        .output()
        .unwrap();
    assert!(
        out.status.success() && alpha.exists(),
        "blender failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let v = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    (v, full_channel(&alpha, "R"))
}

fn render(dir: &Path, name: &str, extra: &[&str]) -> PathBuf {
    let exr = dir.join(format!("{name}.exr"));
    let out = Command::new(MURK)
        .arg("render")
        .arg(root().join("fixtures/pyro.vdb"))
        .arg("-o")
        .arg(&exr)
        .args(["--res", &format!("{W}x{H}"), "--quiet"])
        .args(extra)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    exr
}

#[test]
fn blenders_compositor_places_the_default_exr_and_sees_its_passes() {
    need!(tools::BLENDER);
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("blender_compositor");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let exr = render(&dir, "full", &[]);
    let (info, alpha) = blender_sees(&exr, &dir, "full");
    let sockets: Vec<&str> = info["sockets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s.as_str().unwrap())
        .collect();
    for want in ["Combined", "Alpha", "Depth", "emission", "scatter"] {
        assert!(
            sockets.contains(&want),
            "Blender's Image node has {sockets:?}"
        );
    }
    let mine = full_channel(&exr, "A");
    assert_eq!(alpha.len(), mine.len());
    let worst = alpha
        .iter()
        .zip(&mine)
        .map(|(a, b)| (a - b).abs())
        .fold(0f32, f32::max);
    assert!(
        mine.iter().any(|a| *a > 0.1),
        "the frame must show something"
    );
    assert!(
        worst < 1e-3,
        "Blender places the alpha off by up to {worst}"
    );

    // The cropped window, measured and reported.
    let crop = render(&dir, "crop", &["--crop-data-window"]);
    let (_, alpha) = blender_sees(&crop, &dir, "crop");
    let off = alpha
        .iter()
        .zip(&mine)
        .filter(|(a, b)| (*a - *b).abs() > 1e-3)
        .count();
    eprintln!(
        "--crop-data-window: Blender {} shows {off} of {} pixels' alpha elsewhere than murk wrote them",
        info["blender"],
        W * H
    );
}
