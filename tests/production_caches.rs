//! Production caches render right by default: the fixtures made by
//! `scripts/production_fixtures.py` (pyopenvdb) in Blender's, Houdini's and a dense
//! exported domain's conventions, each rendered with no flag a new user would not think
//! to add, asserted from the EXR (read back by the exr crate, exrheader and OpenImageIO)
//! and the stats. The numbers the assertions start from (the temperature grids' maxima)
//! come from `fixtures/reference.json`, which OpenVDB computed.

mod common;
use common::tools;

use exr::prelude::{FlatSamples, read_all_flat_layers_from_file};
use serde_json::Value;
use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const MURK: &str = env!("CARGO_BIN_EXE_murk");
const W: usize = 96;
const H: usize = 54;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn fixture(name: &str) -> String {
    root().join("fixtures").join(name).display().to_string()
}

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("production-{name}"));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

fn murk(args: &[&str]) -> Output {
    Command::new(MURK)
        .args(args)
        .current_dir(root())
        .output()
        .unwrap_or_else(|e| panic!("cannot run {MURK}: {e}"))
}

/// Renders `input` at W×H into `dir/name.exr` with its stats; returns (exr, stats).
fn render(dir: &Path, input: &str, name: &str, extra: &[&str]) -> (PathBuf, Value) {
    let exr = dir.join(format!("{name}.exr"));
    let stats = dir.join(format!("{name}.json"));
    let (e, s, inp) = (
        exr.display().to_string(),
        stats.display().to_string(),
        fixture(input),
    );
    let res = format!("{W}x{H}");
    let mut a = vec![
        "render", &inp, "-o", &e, "--res", &res, "--stats", &s, "--quiet",
    ];
    a.extend_from_slice(extra);
    let out = murk(&a);
    assert!(
        out.status.success(),
        "murk {} failed:\n{}",
        a.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    let v: Value = serde_json::from_str(&fs::read_to_string(&stats).unwrap()).unwrap();
    (exr, v)
}

/// The channels of an EXR over its data window, and the data window.
struct Image {
    window: (usize, usize, usize, usize),
    channels: BTreeMap<String, Vec<f32>>,
}

fn read(path: &Path) -> Image {
    let image = read_all_flat_layers_from_file(path).unwrap();
    let layer = &image.layer_data[0];
    let pos = layer.attributes.layer_position;
    let mut channels = BTreeMap::new();
    for c in &layer.channel_data.list {
        let v: Vec<f32> = match &c.sample_data {
            FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
            FlatSamples::F32(v) => v.clone(),
            FlatSamples::U32(_) => panic!("u32 channel"),
        };
        channels.insert(c.name.to_string(), v);
    }
    Image {
        window: (pos.0 as usize, pos.1 as usize, layer.size.0, layer.size.1),
        channels,
    }
}

/// Width and height in pixels of the box of pixels with alpha above 0.02.
fn alpha_extent(img: &Image) -> (usize, usize) {
    let a = &img.channels["A"];
    let w = img.window.2;
    let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
    for (i, v) in a.iter().enumerate() {
        if *v > 0.02 {
            let (x, y) = (i % w, i / w);
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
        }
    }
    assert!(x0 <= x1, "nothing visible");
    (x1 - x0 + 1, y1 - y0 + 1)
}

fn reference_max(file: &str, grid: &str) -> f64 {
    let text = fs::read_to_string(root().join("fixtures/reference.json")).unwrap();
    let v: Value = serde_json::from_str(&text).unwrap();
    v["files"][file]["grids"][grid]["max"].as_f64().unwrap()
}

fn status<'a>(stats: &'a Value, stage: &str) -> &'a str {
    stats["stages"][stage]["status"].as_str().unwrap()
}

#[test]
fn blender_frame_is_z_up_with_normalised_temperature_and_its_zero_flame_skipped() {
    let dir = scratch("blender");
    let (exr, st) = render(&dir, "blender_smoke.vdb", "b", &[]);
    // The convention, told from the grid set (Blender writes color_r/g/b).
    let tc = &st["temperature_convention"];
    assert_eq!(tc["convention"], "blender-normalised", "{st:#}");
    assert_eq!(tc["scale"], 1000.0);
    let max = reference_max("blender_smoke.vdb", "temperature");
    assert!((tc["max_value"].as_f64().unwrap() - max).abs() < 1e-6);
    assert!((tc["max_kelvin"].as_f64().unwrap() - 1000.0 * max).abs() < 1e-3);
    assert!(
        st["up_axis"].as_str().unwrap().starts_with("z (auto"),
        "{st:#}"
    );
    assert!(st["source_tool"].as_str().unwrap().starts_with("blender"));
    // The all-zero flame grid adds nothing: named, and not in the render.
    assert!(
        st["skipped_grids"]["flame"]
            .as_str()
            .unwrap()
            .contains("zero everywhere"),
        "{st:#}"
    );
    // With no fire in the cache the temperature does not glow (Cycles' Principled
    // Volume shows no blackbody unless asked)…
    assert!(status(&st, "emission").starts_with("skipped"), "{st:#}");
    assert!(
        tc["emission"]
            .as_str()
            .unwrap()
            .starts_with("off: the cache has no fire")
    );
    let img = read(&exr);
    // …and asked for by name, fire at ≤ 1000 K glows, and red.
    let (glow, st_g) = render(
        &dir,
        "blender_smoke.vdb",
        "g",
        &["--temperature-grid", "temperature"],
    );
    assert_eq!(status(&st_g, "emission"), "ran");
    let glow = read(&glow);
    let (r, b) = (&glow.channels["emission.R"], &glow.channels["emission.B"]);
    let (rs, bs): (f64, f64) = (
        r.iter().map(|v| *v as f64).sum(),
        b.iter().map(|v| *v as f64).sum(),
    );
    assert!(rs > 0.0 && rs > 5.0 * bs, "emission R {rs} B {bs}");
    // Z up: the plume (taller along z than across) stands upright in the frame.
    let (w, h) = alpha_extent(&img);
    assert!(h as f64 > 1.3 * w as f64, "plume {w}x{h} px is not upright");
    // Read as Y-up it is seen from above: no taller than wide.
    let (exr_y, st_y) = render(&dir, "blender_smoke.vdb", "y", &["--up-axis", "y"]);
    assert_eq!(st_y["up_axis"], "y (--up-axis)");
    let (w, h) = alpha_extent(&read(&exr_y));
    assert!((h as f64) < 1.3 * w as f64, "from above: {w}x{h} px");
}

#[test]
fn temperature_read_as_kelvin_is_skipped_with_a_reason_and_explicit_flags_win() {
    let dir = scratch("kelvin");
    let (exr, st) = render(
        &dir,
        "blender_smoke.vdb",
        "k",
        &["--temperature-scale", "1", "--temperature-offset", "0"],
    );
    assert_eq!(st["temperature_convention"]["convention"], "explicit");
    let s = status(&st, "emission");
    assert!(
        s.starts_with("skipped: ") && s.contains("temperature") && s.contains("half float"),
        "{s}"
    );
    let notes = st["notes"].as_array().unwrap();
    assert!(
        notes
            .iter()
            .any(|n| n.as_str().unwrap().contains("emits nothing visible")),
        "{notes:?}"
    );
    assert!(!read(&exr).channels.contains_key("emission.R"));
}

#[test]
fn houdini_frame_is_told_by_its_creator_and_maps_temperature_as_pyro_does() {
    let dir = scratch("houdini");
    let (exr, st) = render(&dir, "houdini_pyro.vdb", "h", &[]);
    let tc = &st["temperature_convention"];
    assert_eq!(tc["convention"], "houdini-normalised", "{st:#}");
    assert_eq!(tc["scale"], 5000.0);
    let max = reference_max("houdini_pyro.vdb", "temperature");
    assert!((tc["max_kelvin"].as_f64().unwrap() - 5000.0 * max).abs() < 1e-2);
    assert!(
        st["source_tool"]
            .as_str()
            .unwrap()
            .contains("Houdini/SOP_OpenVDB_Write")
    );
    assert!(st["up_axis"].as_str().unwrap().starts_with("y"));
    assert_eq!(status(&st, "emission"), "ran");
    let img = read(&exr);
    assert!(img.channels["emission.G"].iter().any(|v| *v > 0.0));
    let (w, h) = alpha_extent(&img);
    assert!(h > w, "Y-up plume {w}x{h}");
}

#[test]
fn dense_all_active_grid_frames_its_plume_not_its_box() {
    let dir = scratch("dense");
    let (exr, _) = render(&dir, "dense_plume.vdb", "d", &[]);
    let (w, h) = alpha_extent(&read(&exr));
    // The plume is 11 voxels across in a 128-voxel box: framed whole it was a speck
    // (~6 px of 96, measured before this change); framed on its non-zero cells (8³
    // leaves, one more on the low side) it is three times that.
    assert!(w >= W / 6 && h >= H / 4, "plume {w}x{h} px of {W}x{H}");
}

#[test]
fn exr_defaults_place_right_and_z_survives_a_filtered_resize() {
    need!(tools::EXRHEADER, tools::OIIOTOOL);
    let dir = scratch("exr");
    let (exr, _) = render(&dir, "cloud.vdb", "c", &[]);
    let header = common::exrheader(&exr);
    let line = |attr: &str| {
        header
            .lines()
            .find(|l| l.starts_with(attr))
            .unwrap_or_else(|| panic!("no {attr}"))
            .split_once("): ")
            .unwrap()
            .1
            .to_owned()
    };
    assert_eq!(line("dataWindow"), line("displayWindow"));
    assert_eq!(
        line("displayWindow"),
        format!("(0 0) - ({} {})", W - 1, H - 1)
    );
    let img = read(&exr);
    let z = &img.channels["Z"];
    assert!(z.contains(&1e10), "empty pixels hold 1e10");
    assert!(z.iter().all(|v| v.is_finite()));
    assert!(header.contains("1e10 where it never does"), "{header}");
    // OpenImageIO's filtered resize: no NaN with 1e10, NaN with +inf (the old default).
    let nan_in_resized_z = |exr: &Path| {
        let small = exr.with_extension("small_z.exr");
        common::tool(
            "oiiotool",
            &[
                exr.to_str().unwrap(),
                "--resize",
                "48x27",
                "--ch",
                "Z",
                "-o",
                small.to_str().unwrap(),
            ],
            "openimageio-tools",
        );
        let stats = common::tool(
            "oiiotool",
            &["--stats", small.to_str().unwrap()],
            "openimageio-tools",
        );
        let line = stats
            .lines()
            .find(|l| l.contains("NanCount"))
            .unwrap()
            .to_owned();
        line.split_whitespace()
            .last()
            .unwrap()
            .parse::<u64>()
            .unwrap()
    };
    assert_eq!(nan_in_resized_z(&exr), 0);
    let (inf, _) = render(&dir, "cloud.vdb", "inf", &["--z-empty", "inf"]);
    assert!(read(&inf).channels["Z"].contains(&f32::INFINITY));
    assert!(nan_in_resized_z(&inf) > 0, "+inf resizes to NaN");
    // --crop-data-window: the smaller file, inside the display window.
    let (crop, _) = render(&dir, "cloud.vdb", "crop", &["--crop-data-window"]);
    let w = read(&crop).window;
    assert!(
        w.2 * w.3 < W * H && w.0 + w.2 <= W && w.1 + w.3 <= H,
        "{w:?}"
    );
    // OpenImageIO sees the same: it names a full/display window only where it differs
    // from the data window.
    let info = common::oiio_info(&exr);
    assert!(
        !info.contains("full/display size"),
        "OIIO reports a crop:\n{info}"
    );
    assert!(common::oiio_info(&crop).contains("full/display size: 96 x 54"));
}

#[test]
fn bad_production_flags_are_one_line_and_exit_2() {
    let dir = scratch("bad");
    let out = dir.join("x.exr").display().to_string();
    let input = fixture("cloud.vdb");
    for (flag, value) in [
        ("--up-axis", "x"),
        ("--z-empty", "-1"),
        ("--z-empty", "nan"),
    ] {
        let o = murk(&["render", &input, "-o", &out, flag, value]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{flag} {value}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(err.contains(flag), "{err}");
    }
}

#[test]
fn blender_colour_channels_tint_scattering_as_one_colour() {
    let dir = scratch("colour");
    let (exr, st) = render(&dir, "blender_smoke.vdb", "c", &[]);
    // color_r/g/b are detected and decoded as the colour role.
    for c in ["color_r", "color_g", "color_b"] {
        assert_eq!(st["grid_roles"][c], c, "{st:#}");
    }
    // The fixture's colour is ~(0.9..1.0, 0.5..0.6, 0.2..0.3): scatter is reddest.
    let img = read(&exr);
    let sum = |n: &str| img.channels[n].iter().map(|v| *v as f64).sum::<f64>();
    let (r, g, b) = (sum("scatter.R"), sum("scatter.G"), sum("scatter.B"));
    assert!(r > g && g > b && b > 0.0, "scatter {r} {g} {b}");
    // Named as a list, or by its red channel, the same.
    let (_, st) = render(
        &dir,
        "blender_smoke.vdb",
        "l",
        &["--color-grid", "color_r,color_g,color_b"],
    );
    assert_eq!(st["grid_roles"]["color_g"], "color_g");
    let (_, st) = render(&dir, "blender_smoke.vdb", "n", &["--color-grid", "color_r"]);
    assert_eq!(st["grid_roles"]["color_b"], "color_b");
}

#[test]
fn small_habits_grey_scalars_stats_to_stdout_missing_arguments_named() {
    let dir = scratch("habits");
    let out = dir.join("g.exr").display().to_string();
    let input = fixture("cloud.vdb");
    let o = murk(&[
        "render",
        &input,
        "-o",
        &out,
        "--res",
        "32x18",
        "--quiet",
        "--sigma-a",
        "0.2",
        "--stats",
        "-",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let st: Value = serde_json::from_slice(&o.stdout).expect("stats JSON on stdout");
    assert_eq!(st["width"], 32);
    assert!(!dir.join("-").exists());
    let o = murk(&["render"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        err.contains("<INPUT>"),
        "the missing argument is named: {err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}

#[test]
fn light_names_become_safe_layer_names_and_collisions_are_refused() {
    let dir = scratch("lights");
    let scene = |lights: &[&str]| {
        let mut t = format!("input = \"{}\"\nres = \"32x18\"\n", fixture("cloud.vdb"));
        for (i, n) in lights.iter().enumerate() {
            t += &format!("[[lights]]\nname = \"{n}\"\nspec = \"sun:0.6,1,0.{i}:1,1,1:3\"\n");
        }
        let p = dir.join(format!("s{}.toml", lights.len()));
        fs::write(&p, t).unwrap();
        p.display().to_string()
    };
    let s = scene(&["key.rim", "fill light"]);
    let out = dir.join("l.exr").display().to_string();
    let o = murk(&["render", &s, "-o", &out, "--quiet"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let names: Vec<String> = read(Path::new(&out)).channels.keys().cloned().collect();
    for want in ["scatter_key_rim.R", "scatter_fill_light.B"] {
        assert!(names.iter().any(|n| n == want), "{names:?}");
    }
    let s = scene(&["key.rim", "key rim", "x"]);
    let o = murk(&["render", &s, "-o", &out, "--quiet"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("scatter_key_rim") && err.trim().lines().count() == 1,
        "{err}"
    );
}

#[test]
fn acescg_output_is_the_published_matrix_times_rec709_with_its_chromaticities() {
    need!(tools::EXRHEADER);
    let dir = scratch("aces");
    let (lin, _) = render(&dir, "pyro.vdb", "lin", &["--float"]);
    let (aces, _) = render(
        &dir,
        "pyro.vdb",
        "aces",
        &["--float", "--colorspace", "acescg"],
    );
    // Rec.709 → ACEScg (Bradford-adapted D65 → ACES white), as the ACES project
    // publishes it, to four places.
    let m = [
        [0.6131, 0.3395, 0.0474],
        [0.0702, 0.9164, 0.0134],
        [0.0206, 0.1096, 0.8698],
    ];
    let (a, b) = (read(&lin), read(&aces));
    let mut checked = 0;
    for layer in ["", "emission.", "scatter."] {
        let ch = |img: &Image, c: &str| img.channels[&format!("{layer}{c}")].clone();
        let (r, g, bl) = (ch(&a, "R"), ch(&a, "G"), ch(&a, "B"));
        let out = [ch(&b, "R"), ch(&b, "G"), ch(&b, "B")];
        for i in 0..r.len() {
            let x = [r[i] as f64, g[i] as f64, bl[i] as f64];
            for (row, o) in m.iter().zip(&out) {
                let want: f64 = row.iter().zip(&x).map(|(k, v)| k * v).sum();
                let scale = x.iter().fold(0.0f64, |s, v| s.max(v.abs()));
                assert!(
                    (o[i] as f64 - want).abs() <= 1e-3 * scale + 1e-7,
                    "{layer} pixel {i}: {} vs {want}",
                    o[i]
                );
            }
            checked += 1;
        }
    }
    assert!(checked > 0);
    // Alpha and depth are not colours.
    assert_eq!(a.channels["A"], b.channels["A"]);
    assert_eq!(a.channels["Z"], b.channels["Z"]);
    let h = common::exrheader(&aces);
    assert!(h.contains("red   (0.713 0.293)"), "{h}");
    // ACES' own white (S-2014-004), not the daylight locus' D60 (0.321626, 0.337736).
    assert!(h.contains("white (0.32168 0.33767)"), "{h}");
    assert!(common::exrheader(&lin).contains("red   (0.64 0.33)"));
}
