//! A rainbow in the EXR: a thin slab of 500 µm water drops (`fixtures/slab.vdb`), the
//! sun straight behind a 120° camera, `--phase water-drop`. Every pixel's angle from
//! the antisolar point (the image centre) follows from the pinhole model; binned by
//! that angle, the beauty pass must show the primary bow's red at 41.5–42.6° with
//! blue inside, the secondary's at 50–54° with the colours reversed, and Alexander's
//! dark band between them darker than the sky inside the primary. Builds the 500 µm
//! tables (~30 s) and renders 360×180.

use exr::prelude::{FlatSamples, read_all_flat_layers_from_file};
use std::path::Path;
use std::process::Command;

const MURK: &str = env!("CARGO_BIN_EXE_murk");
const FOV_DEG: f64 = 120.0;
const W: usize = 360;
const H: usize = 180;

fn channel(image: &exr::image::FlatImage, name: &str) -> Vec<f32> {
    let layer = &image.layer_data[0];
    let c = layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name.to_string() == name)
        .unwrap_or_else(|| panic!("no channel {name}"));
    match &c.sample_data {
        FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
        FlatSamples::F32(v) => v.clone(),
        FlatSamples::U32(v) => v.iter().map(|u| *u as f32).collect(),
    }
}

#[test]
fn rainbow_bows_at_their_angles_in_the_exr() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("rainbow");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let exr = dir.join("rainbow.exr");
    let out = Command::new(MURK)
        // Hermetic: build the tables here rather than load a user's cached ones.
        .env("MURK_CACHE_DIR", dir.join("cache"))
        .args(["render", root.join("fixtures/slab.vdb").to_str().unwrap()])
        .args(["-o", exr.to_str().unwrap(), "--float", "--quiet"])
        .args(["--res", &format!("{W}x{H}"), "--fov", &FOV_DEG.to_string()])
        .args(["--eye", "0,0,1.2", "--look-at", "0,0,0", "--up", "0,1,0"])
        .args(["--sigma-a", "0,0,0", "--sigma-s", "0.2,0.2,0.2"])
        .args(["--light", "sun:0,0,1:1,1,1:1"])
        .args(["--phase", "water-drop", "--drop-radius", "500"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let image = read_all_flat_layers_from_file(&exr).unwrap();
    let rgb = ["R", "G", "B"].map(|c| channel(&image, c));
    // Bins of 0.1° in the angle from the antisolar point; each pixel's radiance times
    // cos α undoes the slab's 1/cos α path length.
    let bins = 700;
    let mut sum = vec![[0.0f64; 3]; bins];
    let mut count = vec![0usize; bins];
    let t = (FOV_DEG.to_radians() / 2.0).tan();
    let aspect = H as f64 / W as f64;
    for y in 0..H {
        for x in 0..W {
            let sx = (x as f64 + 0.5) / W as f64 * 2.0 - 1.0;
            let sy = 1.0 - (y as f64 + 0.5) / H as f64 * 2.0;
            let alpha = (t * (sx * sx + (sy * aspect).powi(2)).sqrt()).atan();
            let k = (alpha.to_degrees() / 0.1) as usize;
            if k < bins {
                for c in 0..3 {
                    let v = rgb[c][y * W + x] as f64;
                    assert!(v.is_finite() && v >= 0.0, "pixel {x},{y}: {v}");
                    sum[k][c] += v * alpha.cos();
                }
                count[k] += 1;
            }
        }
    }
    let profile = |c: usize, deg: f64| {
        let k = (deg / 0.1) as usize;
        if count[k] > 0 {
            sum[k][c] / count[k] as f64
        } else {
            f64::NAN
        }
    };
    let argmax = |c: usize, lo: f64, hi: f64| {
        let mut best = (lo, f64::NEG_INFINITY);
        let mut a = lo;
        while a <= hi {
            let v = profile(c, a + 0.05);
            if v > best.1 {
                best = (a + 0.05, v);
            }
            a += 0.1;
        }
        best.0
    };
    let mean = |c: usize, lo: f64, hi: f64| {
        let (mut s, mut n) = (0.0, 0);
        let mut a = lo;
        while a < hi {
            let v = profile(c, a + 0.05);
            if v.is_finite() {
                s += v;
                n += 1;
            }
            a += 0.1;
        }
        s / n as f64
    };
    let (r1, b1) = (argmax(0, 38.0, 45.0), argmax(2, 38.0, 45.0));
    assert!((41.5..=42.6).contains(&r1), "primary red at {r1}°");
    assert!(
        b1 < r1 - 0.4 && b1 > 39.5,
        "primary blue at {b1}°, red at {r1}°"
    );
    let (r2, b2) = (argmax(0, 48.0, 56.0), argmax(2, 48.0, 56.0));
    assert!(
        (50.0..=54.0).contains(&r2) && (50.0..=54.0).contains(&b2),
        "{r2}° {b2}°"
    );
    assert!(b2 > r2 + 0.5, "secondary: red at {r2}°, blue at {b2}°");
    for c in 0..3 {
        let (band, inside) = (mean(c, 44.0, 49.0), mean(c, 30.0, 38.0));
        assert!(
            band * 3.0 < inside,
            "channel {c}: band {band}, inside {inside}"
        );
        // The bows outshine the sky inside the primary.
        assert!(profile(c, argmax(c, 38.0, 45.0)) > 2.0 * inside);
    }
}
