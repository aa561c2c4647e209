//! `--deep`: the deep scanline EXR beside the flat one. OpenEXR's and OpenImageIO's
//! readers take it; flattened it is the flat render; its samples are tidy; a uniform slab
//! split at any depth gives its closed form. Bad input refused in one line.

mod common;
use common::deep::{Deep, SLAB_VIEW, fixture, flat_channels, flatten, read_deep, render_deep};
use common::frames::{MURK, every_fixture, refused, scratch};
use common::tools;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Renders `input` with `args` into `dir`: the flat EXR (float) and the deep one.
fn render(dir: &Path, input: &str, args: &[&str]) -> (PathBuf, PathBuf) {
    render_deep(dir, input, &["--float"], args)
}

/// Every pixel's samples sorted, `Z ≤ ZBack`, not overlapping, alpha in [0, 1].
fn assert_tidy(d: &Deep) {
    for i in 0..d.pixels.len() {
        let (z, zb, a) = (d.channel(i, "Z"), d.channel(i, "ZBack"), d.channel(i, "A"));
        for s in 0..z.len() {
            assert!(
                z[s] <= zb[s],
                "pixel {i} sample {s}: Z {} > ZBack {}",
                z[s],
                zb[s]
            );
            assert!((0.0..=1.0).contains(&a[s]), "pixel {i}: alpha {}", a[s]);
            if s > 0 {
                assert!(zb[s - 1] <= z[s], "pixel {i}: samples {s} overlap");
            }
        }
    }
}

/// The deep file flattened against the flat file's beauty and alpha: the largest
/// difference.
fn flat_difference(deep: &Deep, flat: &Path) -> f64 {
    let f = flat_channels(flat);
    let mut worst: f64 = 0.0;
    let flattened: Vec<[f64; 4]> = (0..deep.pixels.len()).map(|i| flatten(deep, i)).collect();
    for (c, name) in ["R", "G", "B", "A"].iter().enumerate() {
        for (got, want) in flattened.iter().zip(&f[*name]) {
            worst = worst.max((got[c] - *want as f64).abs());
        }
    }
    worst
}

#[test]
fn flattened_it_is_the_flat_render_on_every_fixture() {
    let cases: &[(&str, &[&str])] = &[
        ("cloud.vdb", &[]),
        ("cloud.vdb", &["--spp", "4", "--scattering", "single"]),
        ("cloud.vdb", &["--ground", "-1", "--ground-visible"]),
        ("sphere.vdb", &["--light", "point:2,2,2"]),
        ("slab.vdb", &[]),
        ("pyro.vdb", &[]),
        ("houdini_pyro.vdb", &[]),
        ("blender_smoke.vdb", &["--colorspace", "acescg"]),
        ("dense_plume.vdb", &[]),
        ("nonuniform.vdb", &[]),
        ("rotated.vdb", &[]),
        ("caches/mantaflow_fire.vdb", &[]),
    ];
    for (k, (input, extra)) in cases.iter().enumerate() {
        let dir = scratch(&format!("deep-fixture-{k}"));
        let mut args = vec!["--res", "64x36"];
        args.extend_from_slice(extra);
        let (flat, deep) = render(&dir, &fixture(input), &args);
        let d = read_deep(&deep);
        assert_eq!((d.width, d.height), (64, 36));
        assert_tidy(&d);
        let covered = d.pixels.iter().filter(|p| !p.is_empty()).count();
        assert!(covered > 0, "{input}: no deep samples");
        let worst = flat_difference(&d, &flat);
        assert!(
            worst < 1e-4,
            "{input} {extra:?}: flattened differs by {worst}"
        );
    }
}

#[test]
fn the_default_file_flattens_to_the_default_flat_file_on_every_fixture() {
    // Without --float both files hold colour and opacity as half floats. Each deep
    // sample's half values are chosen against what the samples in front of it already
    // flatten to (no drift along the ray), then a few are moved (each change moving the
    // opacity in front of a depth by at most a quarter of the tolerance) so the pixel
    // lands on the flat file's stored value: flattened, the deep pixel is the flat file's
    // within 1e-4 on every fixture (within 1e-6 on most pixels), not within a half-float
    // rounding (2.4e-4 at 0.5) of each. A pixel of a few large samples (a mesh's cells)
    // whose opacity lands with colour a step further off is kept: the mixed-cell and
    // graded meshes were 1.2e-4 to 1.7e-4 off when such landings were undone.
    let fixtures = every_fixture();
    assert!(fixtures.len() >= 25, "{fixtures:?}");
    let mut report: Vec<(String, f64)> = Vec::new();
    for (k, input) in fixtures.iter().enumerate() {
        let dir = scratch(&format!("deep-default-{k}"));
        let (flat, deep) = (dir.join("flat.exr"), dir.join("deep.exr"));
        let o = Command::new(MURK)
            .args(["render", &fixture(input), "-o"])
            .arg(&flat)
            .arg("--deep")
            .arg(&deep)
            .args(["--quiet", "--res", "32x18"])
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{input}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let d = read_deep(&deep);
        // The channel list: name, then the pixel type (1 half, 2 float). Colour beyond
        // the half floats' range is 32-bit in both files (tiles.vdb reaches 2.3e7).
        let wide = flat_channels(&flat)["R"].iter().any(|v| v.abs() > 65504.0);
        let colour = if wide { 2 } else { 1 };
        let list = &d.attributes["channels"].1;
        for (name, kind) in [("R", colour), ("A", colour), ("Z", 2), ("ZBack", 2)] {
            let at = list
                .windows(name.len() + 1)
                .position(|w| w == [name.as_bytes(), &[0]].concat())
                .unwrap();
            assert_eq!(list[at + name.len() + 1], kind, "{input}: channel {name}");
        }
        assert_tidy(&d);
        // In units of 1e-4, and of 32-bit float's own precision where colour is beyond
        // the half range (tiles.vdb: 2.3e7, stored as float in both files).
        let f = flat_channels(&flat);
        let mut worst: f64 = 0.0;
        let flattened: Vec<[f64; 4]> = (0..d.pixels.len()).map(|i| flatten(&d, i)).collect();
        for (c, name) in ["R", "G", "B", "A"].iter().enumerate() {
            for (got, want) in flattened.iter().zip(&f[*name]) {
                let want = *want as f64;
                worst = worst.max((got[c] - want).abs() / (1e-4 + 1e-6 * want.abs()));
            }
        }
        report.push((input.to_string(), worst));
    }
    let text: Vec<String> = report.iter().map(|(f, w)| format!("{f} {w:.1e}")).collect();
    eprintln!(
        "largest differences, in 1e-4 + 1e-6 |value|: {}",
        text.join(", ")
    );
    assert!(
        report.iter().all(|(_, w)| *w <= 1.0),
        "flattened differs from the flat file by (in 1e-4 + 1e-6 |value|): {}",
        text.join(", ")
    );
}

#[test]
fn the_default_file_is_smaller_than_the_float_one() {
    for input in ["cloud.vdb", "dense_plume.vdb"] {
        let dir = scratch(&format!("deep-sizes-{input}"));
        let (_, float) = render(&dir, &fixture(input), &["--res", "64x36"]);
        let half = dir.join("half_deep.exr");
        let o = Command::new(MURK)
            .args(["render", &fixture(input), "-o"])
            .arg(dir.join("half.exr"))
            .arg("--deep")
            .arg(&half)
            .args(["--quiet", "--res", "64x36"])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (hb, fb) = (file_len(&half), file_len(&float));
        assert!(hb < fb * 3 / 4, "{input}: {hb} bytes against {fb}");
    }
}

fn file_len(p: &Path) -> u64 {
    std::fs::metadata(p).unwrap().len()
}

#[test]
fn openexr_and_openimageio_read_it_and_flatten_it_to_the_flat_render() {
    need!(tools::EXRHEADER, tools::OIIOTOOL);
    let dir = scratch("deep-peers");
    let (flat, deep) = render(&dir, &fixture("cloud.vdb"), &["--res", "160x90"]);
    let header = common::exrheader(&deep);
    assert!(header.contains("\"deepscanline\""), "{header}");
    assert!(header.contains("deepImageState"), "{header}");
    assert!(header.contains("ZBack, 32-bit floating-point"), "{header}");
    let info = common::oiio_info(&deep);
    assert!(info.contains("deep float openexr"), "{info}");
    // OpenImageIO's own flattening of the deep samples.
    let peer = dir.join("oiio_flat.exr");
    common::tool(
        "oiiotool",
        &[
            deep.to_str().unwrap(),
            "--flatten",
            "-d",
            "float",
            "-o",
            peer.to_str().unwrap(),
        ],
        "openimageio-tools",
    );
    let (p, f) = (flat_channels(&peer), flat_channels(&flat));
    let mut worst: f64 = 0.0;
    for c in ["R", "G", "B", "A"] {
        for (a, b) in p[c].iter().zip(&f[c]) {
            worst = worst.max((a - b).abs() as f64);
        }
    }
    assert!(worst < 1e-4, "OpenImageIO's flattening differs by {worst}");
    // And it holds what murk wrote: samples in the covered pixels.
    let d = read_deep(&deep);
    assert!(d.pixels.iter().any(|p| p.len() > 1));
}

/// Opacity of a pixel's samples in front of depth `depth`, each split there by
/// OpenEXR's rule α(d) = 1 − (1 − A)^((d − Z)/(ZBack − Z)).
fn alpha_before(d: &Deep, i: usize, depth: f64) -> f64 {
    let (z, zb, a) = (d.channel(i, "Z"), d.channel(i, "ZBack"), d.channel(i, "A"));
    let mut t = 1.0;
    for s in 0..z.len() {
        let (z, zb, a) = (z[s] as f64, zb[s] as f64, a[s] as f64);
        if depth <= z {
            break;
        }
        let f = if zb > z {
            ((depth - z) / (zb - z)).min(1.0)
        } else {
            1.0
        };
        t *= (1.0 - a).powf(f);
    }
    1.0 - t
}

#[test]
fn a_uniform_slab_split_at_any_depth_is_its_closed_form() {
    // The slab fixture: density 1 on voxels k = 0..19 (0.05 apart), trilinear: 1 from
    // z = 0 to 0.95, ramps of half a voxel on either side, 1.0 in all. Seen straight
    // down from z = 5 (depth = 5 − z), a pure absorber of σt = 3: its front is at depth
    // 5 − 0.975 (the ramp's integral), and inside α(d) = 1 − e^{−σt (d − 4.025)}.
    let sigma_t = 3.0;
    for tol in ["0.01", "0.002"] {
        let dir = scratch(&format!("deep-slab-{tol}"));
        let (_, deep) = render(
            &dir,
            &fixture("slab.vdb"),
            &[&SLAB_VIEW[..], &["--deep-tolerance", tol]].concat(),
        );
        let d = read_deep(&deep);
        let tol: f64 = tol.parse().unwrap();
        let i = 8 * 16 + 8;
        assert!(!d.pixels[i].is_empty());
        // From one march step (half a voxel) past the ramp: the march takes density as
        // constant over a step, which the ramp is not.
        for k in 0..=87 {
            let depth = 4.08 + 0.01 * k as f64;
            let want = 1.0 - (-sigma_t * (depth - 4.025)).exp();
            let got = alpha_before(&d, i, depth);
            assert!(
                (got - want).abs() <= tol,
                "tolerance {tol}, depth {depth}: {got} against {want}"
            );
        }
        let total = alpha_before(&d, i, 100.0);
        let want = 1.0 - (-sigma_t * 1.0f64).exp();
        assert!((total - want).abs() < 1e-4, "{total} against {want}");
    }
}

#[test]
fn deep_output_refuses_bad_input_in_one_line() {
    let dir = scratch("deep-refusals");
    let cloud = fixture("cloud.vdb");
    refused(
        &dir,
        &[
            "render",
            &cloud,
            "-o",
            "a.exr",
            "--deep",
            "d.exr",
            "--scattering",
            "path",
        ],
        "--deep",
    );
    refused(
        &dir,
        &[
            "render",
            &cloud,
            "-o",
            "a.exr",
            "--deep",
            "d.exr",
            "--deep-tolerance",
            "1.5",
        ],
        "--deep-tolerance",
    );
    refused(
        &dir,
        &["render", &cloud, "-o", "a.exr", "--deep", "a.exr"],
        "--deep",
    );
}

#[test]
fn a_deep_output_in_a_read_only_folder_fails_before_rendering() {
    use std::os::unix::fs::PermissionsExt;
    let dir = scratch("deep-read-only");
    let ro = dir.join("ro");
    std::fs::create_dir(&ro).unwrap();
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
    let deep = ro.join("deep.exr");
    let t = std::time::Instant::now();
    refused(
        &dir,
        &[
            "render",
            &fixture("cloud.vdb"),
            "-o",
            "flat.exr",
            "--deep",
            deep.to_str().unwrap(),
            "--res",
            "320x180",
        ],
        "deep.exr",
    );
    assert!(!dir.join("flat.exr").exists(), "the flat file was written");
    assert!(t.elapsed().as_secs_f64() < 5.0, "it rendered first");
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o755)).unwrap();
}

/// A one-channel float image `name` of `w`×`h` with `depth(x, y)`.
fn depth_image(
    path: &Path,
    w: usize,
    h: usize,
    name: &str,
    depth: impl Fn(usize, usize) -> f32 + Sync,
) {
    use exr::prelude::*;
    let channels = SpecificChannels::build()
        .with_channel(name)
        .with_pixel_fn(|p: Vec2<usize>| (depth(p.x(), p.y()),));
    Image::from_channels((w, h), channels)
        .write()
        .to_file(path)
        .unwrap();
}

#[test]
fn a_holdout_cuts_the_slab_where_its_closed_form_says() {
    // As above: inside the slab α(d) = 1 − e^{−3 (d − 4.025)}; the holdout's left half
    // at depth 4.4, its right half empty (+inf).
    let dir = scratch("holdout-slab");
    let z = dir.join("cg.exr");
    depth_image(&z, 16, 16, "depth.Z", |x, _| {
        if x < 8 { 4.4 } else { f32::INFINITY }
    });
    let out = dir.join("cut.exr");
    let mut args = vec!["render", "fixtures/slab.vdb", "-o", out.to_str().unwrap()];
    args.extend_from_slice(&SLAB_VIEW);
    args.extend(["--float", "--holdout-depth", z.to_str().unwrap(), "--quiet"]);
    let o = Command::new(MURK)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(&args)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let a = &flat_channels(&out)["A"];
    let cut = 1.0 - (-3.0f64 * (4.4 - 4.025)).exp();
    let whole = 1.0 - (-3.0f64).exp();
    for y in 0..16 {
        let (l, r) = (a[y * 16 + 3] as f64, a[y * 16 + 12] as f64);
        assert!((l - cut).abs() < 1e-4, "row {y}: {l} against {cut}");
        assert!((r - whole).abs() < 1e-4, "row {y}: {r} against {whole}");
    }
}

#[test]
fn deep_volume_merged_with_a_deep_card_is_the_holdout_render_over_the_card() {
    need!(tools::OIIOTOOL);
    // A card of colour (0.2, 0.5, 0.8) inside the cloud: OpenImageIO merges it with
    // murk's deep volume and flattens; murk renders the same cut with the card's depth
    // as the holdout, and the card goes under it. The card lies on a sample boundary of
    // each pixel (the middle sample's front) and comes first in the merge: OpenImageIO
    // orders samples of equal Z by the order they came in (its sort compares Z twice),
    // so a volume sample it split at the card's depth would go in front of the card.
    // Pixel centres only: the cut changes which pixels are silhouettes, and so which
    // are sampled again.
    let dir = scratch("holdout-card");
    let (w, h) = (96, 54);
    let (_, deep) = render(
        &dir,
        &fixture("cloud.vdb"),
        &[
            "--res",
            "96x54",
            "--deep-tolerance",
            "0.001",
            "--antialias",
            "1",
        ],
    );
    let flat = flat_channels(&dir.join("flat.exr"));
    let d = read_deep(&deep);
    let depths: Vec<f32> = (0..w * h)
        .map(|i| {
            let z = d.channel(i, "Z");
            if z.is_empty() { 10.7 } else { z[z.len() / 2] }
        })
        .collect();
    let card = dir.join("card.exr");
    {
        use exr::prelude::*;
        let channels = SpecificChannels::build()
            .with_channel("A")
            .with_channel("B")
            .with_channel("G")
            .with_channel("R")
            .with_channel("Z")
            .with_channel("ZBack")
            .with_pixel_fn(|p: Vec2<usize>| {
                let z = depths[p.y() * w + p.x()];
                (1.0f32, 0.8f32, 0.5f32, 0.2f32, z, z)
            });
        Image::from_channels((w, h), channels)
            .write()
            .to_file(&card)
            .unwrap();
    }
    let merged = dir.join("merged.exr");
    common::tool(
        "oiiotool",
        &[
            card.to_str().unwrap(),
            "--deepen",
            deep.to_str().unwrap(),
            "--deepmerge",
            "--flatten",
            "-d",
            "float",
            "-o",
            merged.to_str().unwrap(),
        ],
        "openimageio-tools",
    );
    let m = flat_channels(&merged);
    let cut = dir.join("cut.exr");
    let o = Command::new(MURK)
        .args(["render", &fixture("cloud.vdb"), "-o", cut.to_str().unwrap()])
        .args(["--res", "96x54", "--antialias", "1", "--float", "--quiet"])
        .arg("--holdout-depth")
        .arg(format!("{}:Z", card.display()))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let c = flat_channels(&cut);
    let card_rgb = [0.2, 0.5, 0.8];
    let mut worst: f64 = 0.0;
    for (k, ch) in ["R", "G", "B"].iter().enumerate() {
        for i in 0..w * h {
            let want = c[*ch][i] as f64 + (1.0 - c["A"][i] as f64) * card_rgb[k];
            worst = worst.max((m[*ch][i] as f64 - want).abs());
        }
    }
    // The cut makes a difference where the card is.
    let cut_pixels = (0..w * h)
        .filter(|&i| flat["A"][i] - c["A"][i] > 0.05)
        .count();
    assert!(cut_pixels > 100, "{cut_pixels} pixels cut");
    assert!(worst < 2e-3, "merged and flattened differs by {worst}");
}

#[test]
fn a_bad_holdout_is_refused_in_one_line() {
    let dir = scratch("holdout-refusals");
    let cloud = fixture("cloud.vdb");
    depth_image(&dir.join("small.exr"), 8, 8, "Z", |_, _| 5.0);
    depth_image(&dir.join("other.exr"), 16, 16, "Y", |_, _| 5.0);
    depth_image(&dir.join("nan.exr"), 16, 16, "Z", |x, y| {
        if (x, y) == (3, 4) { f32::NAN } else { 5.0 }
    });
    let base = [
        "render",
        &cloud,
        "-o",
        "a.exr",
        "--res",
        "16x16",
        "--holdout-depth",
    ];
    let with = |h: &str| {
        let mut v = base.to_vec();
        v.push(h);
        v.iter().map(|s| s.to_string()).collect::<Vec<_>>()
    };
    for (h, needle) in [
        ("small.exr", "8x8"),
        ("other.exr", "no depth channel"),
        ("other.exr:Q", "no channel `Q`"),
        ("nan.exr", "NaN depths (the first at pixel 3,4)"),
        ("missing.exr", "missing.exr"),
    ] {
        let args = with(h);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        refused(&dir, &args, needle);
    }
    assert!(!dir.join("a.exr").exists());
}
