//! `--holdout-deep`: a deep image from the render's camera as the holdout, as
//! OpenImageIO (through OpenEXR) writes it. Where its accumulated alpha turns opaque the
//! volume is cut as `--holdout-depth` cuts it; partly transparent samples do not cut.
//! Bad input refused in one line.

mod common;
use common::deep::{SLAB_VIEW, flat_channels};
use common::frames::{MURK, refused, scratch};
use common::tools;
use std::path::Path;
use std::process::Command;

/// A flat card of `w`×`h`: per pixel alpha and depth (`Z`, `ZBack` the same).
fn card(path: &Path, w: usize, h: usize, px: impl Fn(usize, usize) -> (f32, f32) + Sync) {
    use exr::prelude::*;
    let channels = SpecificChannels::build()
        .with_channel("A")
        .with_channel("B")
        .with_channel("G")
        .with_channel("R")
        .with_channel("Z")
        .with_channel("ZBack")
        .with_pixel_fn(|p: Vec2<usize>| {
            let (a, z) = px(p.x(), p.y());
            (a, 0.8 * a, 0.5 * a, 0.2 * a, z, z)
        });
    Image::from_channels((w, h), channels)
        .write()
        .to_file(path)
        .unwrap();
}

/// `oiiotool FLAT --deepen --scanline --compression C -o DEEP`: a deep scanline file
/// OpenEXR wrote (OpenImageIO keeps a tiled input's tiles, and the `exr` crate writes
/// small images tiled).
fn deepen(flat: &Path, deep: &Path, compression: &str) {
    common::tool(
        "oiiotool",
        &[
            flat.to_str().unwrap(),
            "--deepen",
            "--scanline",
            "--compression",
            compression,
            "-o",
            deep.to_str().unwrap(),
        ],
        "openimageio-tools",
    );
}

#[test]
fn a_deep_holdout_cuts_where_it_turns_opaque() {
    need!(tools::OIIOTOOL);
    // The slab seen from above: α(d) = 1 − e^{−3 (d − 4.025)} inside it. The card: an
    // opaque left half at depth 4.4 in the top rows, half transparent (alpha 0.5) in the
    // bottom rows, nothing on the right. Only the opaque part cuts.
    let dir = scratch("holdout-deep-slab");
    let flat = dir.join("card.exr");
    card(&flat, 16, 16, |x, y| match (x < 8, y < 8) {
        (true, true) => (1.0, 4.4),
        (true, false) => (0.5, 4.4),
        _ => (0.0, 4.4),
    });
    let cut = 1.0 - (-3.0f64 * (4.4 - 4.025)).exp();
    let whole = 1.0 - (-3.0f64).exp();
    for compression in ["zips", "none"] {
        let deep = dir.join(format!("card_{compression}.exr"));
        deepen(&flat, &deep, compression);
        let out = dir.join(format!("cut_{compression}.exr"));
        let mut args = vec!["render", "fixtures/slab.vdb"];
        args.extend_from_slice(&SLAB_VIEW);
        args.extend([
            "--float",
            "-o",
            out.to_str().unwrap(),
            "--quiet",
            "--holdout-deep",
        ]);
        args.push(deep.to_str().unwrap());
        let o = Command::new(MURK)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .args(&args)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let a = &flat_channels(&out)["A"];
        for y in 0..16 {
            for x in [3, 12] {
                let want = if x < 8 && y < 8 { cut } else { whole };
                let got = a[y * 16 + x] as f64;
                assert!(
                    (got - want).abs() < 1e-4,
                    "{compression}: pixel {x},{y}: {got} against {want}"
                );
            }
        }
    }
}

#[test]
fn a_deep_holdout_is_the_depth_holdout_of_its_opaque_depths() {
    need!(tools::OIIOTOOL);
    // On the cloud, with depths that vary per pixel: the same image as --holdout-depth
    // given each opaque pixel's depth (+inf elsewhere), bit for bit.
    let dir = scratch("holdout-deep-cloud");
    let (w, h) = (48, 27);
    let px = |x: usize, y: usize| {
        let z = 9.0 + 0.05 * x as f32 + 0.05 * y as f32;
        (if (x + y).is_multiple_of(5) { 0.3 } else { 1.0 }, z)
    };
    let flat = dir.join("card.exr");
    card(&flat, w, h, px);
    let deep = dir.join("card_deep.exr");
    deepen(&flat, &deep, "zips");
    let depth = dir.join("depth.exr");
    {
        use exr::prelude::*;
        let channels =
            SpecificChannels::build()
                .with_channel("Z")
                .with_pixel_fn(|p: Vec2<usize>| {
                    let (a, z) = px(p.x(), p.y());
                    (if a == 1.0 { z } else { f32::INFINITY },)
                });
        Image::from_channels((w, h), channels)
            .write()
            .to_file(&depth)
            .unwrap();
    }
    let cloud = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/cloud.vdb");
    let run = |out: &str, flag: &str, file: &Path| {
        let o = Command::new(MURK)
            .arg("render")
            .arg(&cloud)
            .arg("-o")
            .arg(dir.join(out))
            .args(["--res", "48x27", "--float", "--quiet", flag])
            .arg(file)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        flat_channels(&dir.join(out))
    };
    let (by_deep, by_depth) = (
        run("by_deep.exr", "--holdout-deep", &deep),
        run("by_depth.exr", "--holdout-depth", &depth),
    );
    for c in ["R", "G", "B", "A", "Z"] {
        assert_eq!(by_deep[c], by_depth[c], "channel {c}");
    }
    // The card lies inside the cloud: it cuts.
    let whole = run("whole.exr", "--z-empty", Path::new("inf"));
    let cut = (0..w * h)
        .filter(|&i| whole["A"][i] - by_deep["A"][i] > 0.05)
        .count();
    assert!(cut > 100, "{cut} pixels cut");
}

#[test]
fn a_bad_deep_holdout_is_refused_in_one_line() {
    need!(tools::OIIOTOOL);
    let dir = scratch("holdout-deep-refusals");
    let cloud = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/cloud.vdb");
    let cloud = cloud.to_str().unwrap();
    card(&dir.join("flat16.exr"), 16, 16, |_, _| (1.0, 5.0));
    card(&dir.join("flat8.exr"), 8, 8, |_, _| (1.0, 5.0));
    card(&dir.join("nan.exr"), 16, 16, |x, y| {
        (1.0, if (x, y) == (3, 4) { f32::NAN } else { 5.0 })
    });
    deepen(&dir.join("flat16.exr"), &dir.join("deep16.exr"), "zips");
    deepen(&dir.join("flat8.exr"), &dir.join("deep8.exr"), "zips");
    deepen(&dir.join("nan.exr"), &dir.join("nan_deep.exr"), "none");
    // The same deep file, its compression byte changed to PIZ (4).
    let mut b = std::fs::read(dir.join("deep16.exr")).unwrap();
    let key = b"compression\0compression\0\x01\0\0\0";
    let at = b.windows(key.len()).position(|w| w == key).unwrap() + key.len();
    b[at] = 4;
    std::fs::write(dir.join("piz.exr"), &b).unwrap();
    let base = [
        "render",
        cloud,
        "-o",
        "a.exr",
        "--res",
        "16x16",
        "--holdout-deep",
    ];
    for (file, needle) in [
        ("flat16.exr", "not a deep image"),
        ("deep8.exr", "8x8"),
        ("nan_deep.exr", "NaN depths"),
        ("piz.exr", "PIZ compression"),
        ("missing.exr", "missing.exr"),
    ] {
        let mut args = base.to_vec();
        args.push(file);
        refused(&dir, &args, needle);
    }
    // A deep image given as a flat depth image: the line says which flag takes it.
    let mut deep_as_depth = base[..6].to_vec();
    deep_as_depth.extend(["--holdout-depth", "deep16.exr"]);
    refused(&dir, &deep_as_depth, "--holdout-deep");
    let mut both = base.to_vec();
    both.extend(["deep16.exr", "--holdout-depth", "flat16.exr"]);
    refused(&dir, &both, "one holdout at a time");
    assert!(!dir.join("a.exr").exists());
}
