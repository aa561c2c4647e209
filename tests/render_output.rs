//! End-to-end checks of what `murk render` writes: the EXR read back by tools
//! nobody here wrote (`exrheader` from OpenEXR, `oiiotool` from OpenImageIO)
//! and by the `exr` crate, the stats JSON, the PNG preview, the example scene
//! file `fixtures/scene.toml`, and determinism.
//!
//! A test that runs a tool is skipped where it is missing (the Debian packages
//! `openexr` and `openimageio-tools`), and fails under `MURK_REQUIRE_TOOLS=1`.
//!
//! Renders are small (96×54 and less) so that every test is quick.

mod common;
use common::tools;
use common::{exrheader, exrheader_channels, oiio_info};

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use exr::prelude::{FlatSamples, read_all_flat_layers_from_file};
use serde_json::Value;

const MURK: &str = env!("CARGO_BIN_EXE_murk");
const W: usize = 96;
const H: usize = 54;
/// Half precision: 11 significant bits, so one rounding is at most 2^-11 relative.
const HALF_REL: f32 = 2e-3;
/// Below the smallest normal half (6.1e-5) the spacing is 6e-8.
const HALF_ABS: f32 = 1e-6;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn fixture(name: &str) -> PathBuf {
    root().join("fixtures").join(name)
}

/// A fresh, empty directory for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("render_output-{name}"));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

fn s(p: &Path) -> String {
    p.to_str().unwrap().to_owned()
}

/// Runs `murk` with these arguments in `cwd`.
fn murk_in(cwd: &Path, args: &[String]) -> Output {
    Command::new(MURK)
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap_or_else(|e| panic!("cannot run {MURK}: {e}"))
}

/// Runs `murk` (in the crate root) and requires success.
fn murk_ok(args: &[String]) -> Output {
    murk_ok_in(root(), args)
}

fn murk_ok_in(cwd: &Path, args: &[String]) -> Output {
    let out = murk_in(cwd, args);
    assert!(
        out.status.success(),
        "murk {} failed ({}):\n{}",
        args.join(" "),
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn args(list: &[&str]) -> Vec<String> {
    list.iter().map(|a| a.to_string()).collect()
}

/// Renders `input` at 96×54 into `dir/name.exr` (plus `extra` flags).
fn render(dir: &Path, input: &str, name: &str, extra: &[&str]) -> PathBuf {
    let exr = dir.join(format!("{name}.exr"));
    let mut a = vec![
        "render".to_owned(),
        s(&fixture(input)),
        "-o".to_owned(),
        s(&exr),
        "--res".to_owned(),
        format!("{W}x{H}"),
    ];
    a.extend(args(extra));
    murk_ok(&a);
    exr
}

/// A `box2i` line of exrheader, e.g. `dataWindow (type box2i): (30 17) - (63 41)`.
fn exrheader_box(header: &str, attr: &str) -> [i64; 4] {
    let prefix = format!("{attr} (type box2i): ");
    let line = header
        .lines()
        .find_map(|l| l.strip_prefix(prefix.as_str()))
        .unwrap_or_else(|| panic!("exrheader has no {attr}:\n{header}"));
    let n: Vec<i64> = line
        .replace(['(', ')', '-'], " ")
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect();
    [n[0], n[1], n[2], n[3]]
}

/// The OIIO channel list: `R (half)`, ... → name → type.
fn oiio_channels(info: &str) -> BTreeMap<String, String> {
    let list = info
        .lines()
        .find_map(|l| l.trim().strip_prefix("channel list: "))
        .unwrap_or_else(|| panic!("no channel list:\n{info}"));
    list.split(", ")
        .map(|c| {
            let (name, ty) = c.split_once(' ').unwrap_or((c, "(?)"));
            (name.to_owned(), ty.trim_matches(['(', ')']).to_owned())
        })
        .collect()
}

/// One EXR read back with the exr crate.
struct Exr {
    /// Display window size.
    width: usize,
    height: usize,
    /// Data window: origin and size.
    window: (usize, usize, usize, usize),
    /// Channel → (stored as half, samples over the data window, row-major).
    channels: BTreeMap<String, (bool, Vec<f32>)>,
    world_to_camera: Option<[f32; 16]>,
}

impl Exr {
    fn read(path: &Path) -> Exr {
        let image = read_all_flat_layers_from_file(path)
            .unwrap_or_else(|e| panic!("exr crate cannot read {}: {e}", path.display()));
        assert_eq!(image.layer_data.len(), 1, "{}: one part", path.display());
        let layer = &image.layer_data[0];
        let display = image.attributes.display_window;
        assert_eq!(display.position.0, 0);
        assert_eq!(display.position.1, 0);
        let pos = layer.attributes.layer_position;
        let window = (pos.0 as usize, pos.1 as usize, layer.size.0, layer.size.1);
        let mut channels = BTreeMap::new();
        for c in &layer.channel_data.list {
            let v = match &c.sample_data {
                FlatSamples::F16(v) => (true, v.iter().map(|h| h.to_f32()).collect()),
                FlatSamples::F32(v) => (false, v.clone()),
                FlatSamples::U32(_) => panic!("channel {} holds u32", c.name),
            };
            channels.insert(c.name.to_string(), v);
        }
        Exr {
            width: display.size.0,
            height: display.size.1,
            window,
            channels,
            world_to_camera: layer.attributes.world_to_camera,
        }
    }

    fn names(&self) -> BTreeSet<String> {
        self.channels.keys().cloned().collect()
    }

    fn get(&self, name: &str) -> &[f32] {
        &self
            .channels
            .get(name)
            .unwrap_or_else(|| panic!("no channel {name} in {:?}", self.names()))
            .1
    }

    /// The channel, or zeros where the file has none (an absent layer adds nothing).
    fn get_or_zero(&self, name: &str) -> Vec<f32> {
        match self.channels.get(name) {
            Some((_, v)) => v.clone(),
            None => vec![0.0; self.window.2 * self.window.3],
        }
    }

    /// (x, y) in the full frame of sample `i` of the data window.
    fn xy(&self, i: usize) -> (usize, usize) {
        (
            self.window.0 + i % self.window.2,
            self.window.1 + i / self.window.2,
        )
    }
}

fn set(names: &[&str]) -> BTreeSet<String> {
    names.iter().map(|n| n.to_string()).collect()
}

fn rgb(layer: &str) -> [String; 3] {
    ["R", "G", "B"].map(|c| format!("{layer}.{c}"))
}

fn read_json(path: &Path) -> Value {
    let text = fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("cannot read stats {}: {e}", path.display()));
    serde_json::from_str(&text)
        .unwrap_or_else(|e| panic!("{}: bad JSON: {e}\n{text}", path.display()))
}

fn status<'a>(stats: &'a Value, stage: &str) -> &'a str {
    stats["stages"][stage]["status"]
        .as_str()
        .unwrap_or_else(|| panic!("stats has no stages.{stage}.status:\n{stats:#}"))
}

fn string_list(v: &Value) -> Vec<String> {
    v.as_array()
        .unwrap_or_else(|| panic!("not a list: {v}"))
        .iter()
        .map(|x| x.as_str().unwrap().to_owned())
        .collect()
}

/// `p` transformed by an EXR m44f (row vectors: p' = [p 1] · M).
fn transform(m: &[f32; 16], p: [f64; 3]) -> [f64; 3] {
    let mut out = [0.0; 3];
    for (c, o) in out.iter_mut().enumerate() {
        *o =
            p[0] * m[c] as f64 + p[1] * m[4 + c] as f64 + p[2] * m[8 + c] as f64 + m[12 + c] as f64;
    }
    out
}

// ------------------------------------------------------------------------------------
// 1. The example scene file.

#[test]
fn scene_file_renders_and_flags_override_it() {
    need!(tools::EXRHEADER);
    let dir = scratch("scene");
    let cwd = scratch("scene-cwd");
    let exr = dir.join("x.exr");
    let json = dir.join("x.json");
    let png = dir.join("x.png");
    // Absolute scene path, run elsewhere: `input` must resolve next to the scene file.
    let scene = fixture("scene.toml");
    murk_ok_in(
        &cwd,
        &[
            "render".into(),
            s(&scene),
            "-o".into(),
            s(&exr),
            "--res".into(),
            "64x36".into(),
            "--stats".into(),
            s(&json),
            "--preview".into(),
            s(&png),
        ],
    );
    assert_eq!(
        fs::read_dir(&cwd).unwrap().count(),
        0,
        "nothing written in the cwd"
    );

    // The scene says 160x90: --res wins.
    let e = Exr::read(&exr);
    assert_eq!((e.width, e.height), (64, 36));
    let h = exrheader(&exr);
    assert_eq!(exrheader_box(&h, "displayWindow"), [0, 0, 63, 35]);
    let stats = read_json(&json);
    assert_eq!(
        (stats["width"].as_u64(), stats["height"].as_u64()),
        (Some(64), Some(36))
    );
    assert!(
        stats["input"]
            .as_str()
            .unwrap()
            .ends_with("fixtures/cloud.vdb"),
        "input is relative to the scene file: {}",
        stats["input"]
    );
    assert_eq!(stats["output"].as_str(), Some(s(&exr).as_str()), "-o wins");
    assert!(png.is_file(), "--preview wins over the scene's preview");
    assert_eq!(string_list(&stats["lights"]), ["key", "fill"]);

    // Named lights give named layers; the default mode (fast) adds `indirect`.
    let mut want = set(&["R", "G", "B", "A", "Z"]);
    for layer in ["scatter", "indirect", "scatter_key", "scatter_fill"] {
        want.extend(rgb(layer));
    }
    assert_eq!(e.names(), want);
    let listed: BTreeSet<String> = string_list(&stats["channels"]).into_iter().collect();
    assert_eq!(listed, want, "stats.channels lists the EXR's channels");
    for layer in ["scatter_key", "scatter_fill"] {
        let sum: f32 = rgb(layer).iter().flat_map(|c| e.get(c)).sum();
        assert!(sum > 0.0, "{layer} is black");
    }

    // The scene's camera is used: eye → origin, look_at on the −z axis.
    let scene: toml::Table = toml::from_str(&fs::read_to_string(&scene).unwrap()).unwrap();
    let vec3 = |key: &str| -> [f64; 3] {
        let v: Vec<f64> = scene[key]
            .as_str()
            .unwrap()
            .split(',')
            .map(|c| c.trim().parse().unwrap())
            .collect();
        [v[0], v[1], v[2]]
    };
    let (eye_w, look_w) = (vec3("eye"), vec3("look_at"));
    let m = e.world_to_camera.expect("worldToCamera");
    let eye = transform(&m, eye_w);
    assert!(
        eye.iter().all(|v| v.abs() < 1e-3),
        "eye in camera space: {eye:?}"
    );
    let look = transform(&m, look_w);
    let dist = (0..3)
        .map(|k| (look_w[k] - eye_w[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(
        look[0].abs() < 1e-3 && look[1].abs() < 1e-3 && (look[2] + dist).abs() < 1e-3,
        "look_at in camera space: {look:?}"
    );
}

#[test]
fn scene_resolution_and_output_paths_are_used_without_flags() {
    // A copy of the scene next to a copy of the cloud, rendered from another
    // directory with no output flags: every output lands next to the scene.
    let dir = scratch("scene-copy");
    let cwd = scratch("scene-copy-cwd");
    fs::copy(fixture("scene.toml"), dir.join("scene.toml")).unwrap();
    fs::copy(fixture("cloud.vdb"), dir.join("cloud.vdb")).unwrap();
    let text = fs::read_to_string(dir.join("scene.toml")).unwrap();
    let scene: toml::Table = toml::from_str(&text).unwrap();
    let res = scene["res"].as_str().unwrap();
    let (w, h) = res.split_once('x').unwrap();
    let (w, h): (usize, usize) = (w.parse().unwrap(), h.parse().unwrap());
    // A cheap render at the scene's resolution: coarse steps, no shadows.
    murk_ok_in(
        &cwd,
        &args(&[
            "render",
            dir.join("scene.toml").to_str().unwrap(),
            "--step",
            "4",
            "--shadows",
            "none",
        ]),
    );
    assert_eq!(
        fs::read_dir(&cwd).unwrap().count(),
        0,
        "nothing written in the cwd"
    );
    for key in ["output", "preview", "stats"] {
        let name = scene[key]
            .as_str()
            .unwrap_or_else(|| panic!("scene has no {key}"));
        assert!(
            dir.join(name).is_file(),
            "{key} {name} not written next to the scene"
        );
    }
    let e = Exr::read(&dir.join(scene["output"].as_str().unwrap()));
    assert_eq!((e.width, e.height), (w, h));
    let png = image::open(dir.join(scene["preview"].as_str().unwrap())).unwrap();
    assert_eq!((png.width() as usize, png.height() as usize), (w, h));
}

#[test]
fn light_flag_replaces_the_scenes_lights() {
    let dir = scratch("scene-light");
    let exr = dir.join("x.exr");
    let json = dir.join("x.json");
    murk_ok(&args(&[
        "render",
        "fixtures/scene.toml",
        "-o",
        exr.to_str().unwrap(),
        "--res",
        "48x27",
        "--stats",
        json.to_str().unwrap(),
        "--preview",
        dir.join("x.png").to_str().unwrap(),
        "--light",
        "sun:0,1,0",
    ]));
    let stats = read_json(&json);
    assert_eq!(string_list(&stats["lights"]), ["sun0"]);
    let mut want = set(&["R", "G", "B", "A", "Z"]);
    want.extend(rgb("scatter"));
    want.extend(rgb("indirect")); // the default mode, fast
    assert_eq!(Exr::read(&exr).names(), want);
}

// ------------------------------------------------------------------------------------
// 2. The EXR header, per exrheader and oiiotool.

#[test]
fn exr_header_per_exrheader() {
    need!(tools::EXRHEADER);
    let dir = scratch("exrheader");
    let input = fixture("cloud.vdb");
    let exr = render(
        &dir,
        "cloud.vdb",
        "x",
        &[
            "--preview",
            dir.join("x.png").to_str().unwrap(),
            "--stats",
            dir.join("x.json").to_str().unwrap(),
        ],
    );
    let h = exrheader(&exr);
    // single-part scanline: no multi-part (0x1000), tiled (0x200) or deep (0x800) flag
    assert!(h.contains("file format version: 2, flags 0x0\n"), "{h}");
    assert!(h.contains("type (type string): \"scanlineimage\""), "{h}");
    assert!(!h.contains("tiles (type tiledesc)"), "{h}");
    assert!(!h.contains(" part "), "{h}");

    let channels = exrheader_channels(&h);
    let names: BTreeSet<String> = channels.iter().map(|(n, _)| n.clone()).collect();
    let mut want = set(&["R", "G", "B", "A", "Z"]);
    want.extend(rgb("scatter"));
    want.extend(rgb("indirect")); // the default mode, fast
    assert_eq!(
        names, want,
        "no emission layer (no emission grid), no per-light layer (one light)"
    );
    assert_eq!(channels.len(), want.len());
    for (name, ty) in &channels {
        let want_ty = if name == "Z" {
            "32-bit floating-point"
        } else {
            "16-bit floating-point"
        };
        assert_eq!(ty, want_ty, "type of {name}");
    }

    let display = exrheader_box(&h, "displayWindow");
    assert_eq!(display, [0, 0, W as i64 - 1, H as i64 - 1]);
    let [x0, y0, x1, y1] = exrheader_box(&h, "dataWindow");
    assert!(
        0 <= x0 && x0 <= x1 && x1 < W as i64 && 0 <= y0 && y0 <= y1 && y1 < H as i64,
        "dataWindow ({x0} {y0}) - ({x1} {y1}) outside the display window"
    );
    for line in [
        "compression (type compression): zip, individual scanlines",
        "lineOrder (type lineOrder): increasing y",
        "chromaticities (type chromaticities):",
        "    red   (0.64 0.33)",
        "    green (0.3 0.6)",
        "    blue  (0.15 0.06)",
        "    white (0.3127 0.329)",
        "worldToCamera (type m44f):",
        "worldToNDC (type m44f):",
        &format!("inputFile (type string): \"{}\"", input.display()),
    ] {
        assert!(
            h.lines().any(|l| l == line),
            "exrheader lacks `{line}`:\n{h}"
        );
    }
    let software = h
        .lines()
        .find_map(|l| l.strip_prefix("software (type string): "))
        .unwrap_or_else(|| panic!("no software:\n{h}"));
    assert!(software.starts_with("\"murk "), "{software}");
    let render_time: f64 = h
        .lines()
        .find_map(|l| l.strip_prefix("renderTime (type float): "))
        .unwrap_or_else(|| panic!("no renderTime:\n{h}"))
        .parse()
        .unwrap();
    assert!(
        render_time > 0.0 && render_time < 600.0,
        "renderTime {render_time}"
    );
    let rule = h
        .lines()
        .find_map(|l| l.strip_prefix("murk/depthRule (type string): "))
        .unwrap_or_else(|| panic!("no murk/depthRule:\n{h}"));
    assert!(rule.contains("0.5") && rule.contains("1e10"), "{rule}");
    assert!(!h.contains("murk/nanCount"), "a render has no NaNs:\n{h}");
}

#[test]
fn exr_header_per_oiiotool() {
    need!(tools::OIIOTOOL);
    let dir = scratch("oiiotool");
    // OpenImageIO prints the full/display window only where it differs from the data
    // window: with the default (dataWindow = displayWindow) it does not.
    let full = oiio_info(&render(&dir, "cloud.vdb", "full", &[]));
    assert!(!full.contains("full/display size"), "{full}");
    assert!(full.contains(":   96 x   54, "), "{full}");
    let exr = render(&dir, "cloud.vdb", "x", &["--crop-data-window"]);
    let info = oiio_info(&exr);
    for line in [
        "full/display size: 96 x 54",
        "full/display origin: 0, 0",
        "compression: \"zips\"",
        "chromaticities: 0.64, 0.33, 0.3, 0.6, 0.15, 0.06, 0.3127, 0.329",
        "oiio:subimages: 1",
    ] {
        assert!(
            info.lines().any(|l| l.trim() == line),
            "oiiotool lacks `{line}`:\n{info}"
        );
    }
    for key in [
        "worldToCamera: ",
        "worldToNDC: ",
        "renderTime: ",
        "inputFile: ",
        "software: \"murk ",
        "murk/depthRule: ",
    ] {
        assert!(
            info.lines().any(|l| l.trim().starts_with(key)),
            "oiiotool lacks `{key}`:\n{info}"
        );
    }
    assert!(!info.contains("tile size"), "must be scanline:\n{info}");
    let channels = oiio_channels(&info);
    let mut want: BTreeMap<String, String> = ["R", "G", "B", "A"]
        .iter()
        .map(|c| (c.to_string(), "half".to_owned()))
        .collect();
    want.insert("Z".into(), "float".into());
    for c in rgb("scatter").into_iter().chain(rgb("indirect")) {
        want.insert(c, "half".into());
    }
    assert_eq!(channels, want, "{info}");
}

#[test]
fn float_flag_stores_colour_as_float() {
    need!(tools::EXRHEADER, tools::OIIOTOOL);
    let dir = scratch("float");
    let exr = render(&dir, "cloud.vdb", "x", &["--float"]);
    let channels = exrheader_channels(&exrheader(&exr));
    assert_eq!(channels.len(), 11); // R G B A Z, scatter and indirect (fast, the default)
    assert!(
        channels.iter().all(|(_, t)| t == "32-bit floating-point"),
        "{channels:?}"
    );
    let info = oiio_info(&exr);
    // OIIO names a channel's type only when the channels' types differ.
    assert!(
        info.contains("11 channel, float openexr") && !info.contains("(half)"),
        "{info}"
    );
    let e = Exr::read(&exr);
    assert!(e.channels.values().all(|(half, _)| !half));

    // Float data: the data window is the tight bounding box of the non-empty pixels.
    let (wx, wy, ww, wh) = e.window;
    let occupied = |x: usize, y: usize| {
        let i = (y - wy) * ww + (x - wx);
        e.channels.iter().any(|(n, (_, v))| {
            if n == "Z" {
                v[i].is_finite()
            } else {
                v[i] != 0.0
            }
        })
    };
    let edges = [
        ("left", (wy..wy + wh).any(|y| occupied(wx, y))),
        ("right", (wy..wy + wh).any(|y| occupied(wx + ww - 1, y))),
        ("top", (wx..wx + ww).any(|x| occupied(x, wy))),
        ("bottom", (wx..wx + ww).any(|x| occupied(x, wy + wh - 1))),
    ];
    for (edge, any) in edges {
        assert!(
            any,
            "the data window {:?} has an empty {edge} edge",
            e.window
        );
    }
    // In float, beauty = emission + scatter (the cloud has no emission) exactly as summed.
    for (c, sc) in ["R", "G", "B"].iter().zip(rgb("scatter")) {
        assert_eq!(e.get(c), e.get(&sc), "{c} = scatter.{c}");
    }
}

#[test]
fn every_compression_shows_up_in_the_header() {
    need!(tools::EXRHEADER, tools::OIIOTOOL);
    let dir = scratch("compression");
    for (name, exrheader_name) in [
        ("none", "none"),
        ("rle", "run-length encoding"),
        ("zips", "zip, individual scanlines"),
        ("zip", "zip, multi-scanline blocks"),
        ("piz", "piz"),
        ("dwaa", "dwa, small scanline blocks"),
    ] {
        let exr = render(
            &dir,
            "cloud.vdb",
            name,
            &["--compression", name, "--step", "2"],
        );
        let h = exrheader(&exr);
        let line = format!("compression (type compression): {exrheader_name}");
        assert!(
            h.lines().any(|l| l == line),
            "--compression {name}: exrheader lacks `{line}`:\n{h}"
        );
        let info = oiio_info(&exr);
        assert!(
            info.contains(&format!("compression: \"{name}\"")),
            "--compression {name}:\n{info}"
        );
        // readable by the exr crate too
        // R G B A Z, scatter and indirect (fast, the default).
        assert_eq!(Exr::read(&exr).channels.len(), 11, "--compression {name}");
    }
}

#[test]
fn two_lights_get_their_own_layers() {
    need!(tools::EXRHEADER);
    let dir = scratch("two-suns");
    let exr = render(
        &dir,
        "cloud.vdb",
        "suns",
        &[
            "--light",
            "sun:1,1,0:1,0.9,0.8:4",
            "--light",
            "sun:-1,0.2,0:0.3,0.4,1:2",
        ],
    );
    let h = exrheader(&exr);
    let names: BTreeSet<String> = exrheader_channels(&h).into_iter().map(|(n, _)| n).collect();
    let mut want = set(&["R", "G", "B", "A", "Z"]);
    for layer in ["scatter", "indirect", "scatter_sun0", "scatter_sun1"] {
        want.extend(rgb(layer));
    }
    assert_eq!(names, want);

    let exr = render(
        &dir,
        "cloud.vdb",
        "sun-point",
        &["--light", "sun:1,1,0", "--light", "point:0,3,3:1,1,1:40"],
    );
    let names: BTreeSet<String> = exrheader_channels(&exrheader(&exr))
        .into_iter()
        .map(|(n, _)| n)
        .collect();
    let mut want = set(&["R", "G", "B", "A", "Z"]);
    for layer in ["scatter", "indirect", "scatter_sun0", "scatter_point0"] {
        want.extend(rgb(layer));
    }
    assert_eq!(names, want);
}

// ------------------------------------------------------------------------------------
// 3. Pixel values.

fn close(got: f32, want: f32, scale: f32) -> bool {
    (got - want).abs() <= HALF_REL * scale + HALF_ABS
}

/// Beauty = emission + scatter, scatter = Σ per-light scatter, 0 ≤ A ≤ 1, finite
/// non-negative colours, and Z consistent with A.
fn check_values(e: &Exr, lights: &[&str]) {
    let what = format!("{:?}", e.names());
    for (name, (_, v)) in &e.channels {
        for (i, x) in v.iter().enumerate() {
            let (px, py) = e.xy(i);
            if name == "Z" {
                assert!(!x.is_nan(), "Z is NaN at ({px},{py})");
                assert!(
                    *x > 0.0,
                    "Z {x} at ({px},{py}) is not in front of the camera"
                );
            } else {
                assert!(x.is_finite(), "{name} = {x} at ({px},{py})");
                assert!(*x >= 0.0, "{name} = {x} < 0 at ({px},{py})");
            }
        }
    }
    let a = e.get("A");
    assert!(
        a.iter().all(|a| (0.0..=1.0).contains(a)),
        "A outside [0, 1]"
    );
    assert!(
        a.iter().any(|a| *a > 0.5),
        "nothing opaque: a poor test image"
    );
    for (k, c) in ["R", "G", "B"].iter().enumerate() {
        let beauty = e.get(c);
        let em = e.get_or_zero(&rgb("emission")[k]);
        let sc = e.get_or_zero(&rgb("scatter")[k]);
        for i in 0..beauty.len() {
            let (x, y) = e.xy(i);
            assert!(
                close(beauty[i], em[i] + sc[i], beauty[i].max(em[i] + sc[i])),
                "{c} = {} but emission.{c} + scatter.{c} = {} + {} at ({x},{y}) [{what}]",
                beauty[i],
                em[i],
                sc[i]
            );
        }
        if lights.len() > 1 {
            let per: Vec<&[f32]> = lights
                .iter()
                .map(|l| e.get(&rgb(&format!("scatter_{l}"))[k]))
                .collect();
            for i in 0..sc.len() {
                let sum: f32 = per.iter().map(|p| p[i]).sum();
                let (x, y) = e.xy(i);
                assert!(
                    close(sc[i], sum, sc[i].max(sum)),
                    "scatter.{c} = {} but the lights' layers sum to {sum} at ({x},{y})",
                    sc[i]
                );
            }
        }
    }
    check_depth(e, 1e-3);
}

/// Z is a depth where A reached 0.5 and 1e10 (`--z-empty`'s default, as Cycles writes)
/// where it did not.
fn check_depth(e: &Exr, tol: f32) {
    let (a, z) = (e.get("A"), e.get("Z"));
    let mut finite = 0;
    for i in 0..a.len() {
        let (x, y) = e.xy(i);
        if z[i] < 1e10 {
            finite += 1;
            assert!(
                a[i] >= 0.5 - tol,
                "Z = {} at ({x},{y}) but A = {} < 0.5",
                z[i],
                a[i]
            );
        } else {
            assert_eq!(z[i], 1e10, "Z at ({x},{y})");
            assert!(
                a[i] <= 0.5 + tol,
                "Z = 1e10 (empty) at ({x},{y}) but A = {} > 0.5",
                a[i]
            );
        }
    }
    assert!(finite > 0, "no finite depth at all");
}

#[test]
fn cloud_values_are_consistent() {
    let dir = scratch("values-cloud");
    let e = Exr::read(&render(&dir, "cloud.vdb", "x", &[]));
    check_values(&e, &["sun0"]);
    assert!(!e.channels.contains_key("emission.R"));
}

#[test]
fn cloud_values_with_two_lights_are_consistent() {
    let dir = scratch("values-cloud-2");
    let e = Exr::read(&render(
        &dir,
        "cloud.vdb",
        "x",
        &[
            "--light",
            "sun:1,1,0:1,0.9,0.8:4",
            "--light",
            "point:0,3,3:0.3,0.4,1:40",
        ],
    ));
    check_values(&e, &["sun0", "point0"]);
}

#[test]
fn pyro_values_with_emission_and_scatter_are_consistent() {
    let dir = scratch("values-pyro");
    let e = Exr::read(&render(
        &dir,
        "pyro.vdb",
        "x",
        &[
            "--light",
            "sun:0.6,1,0.5:1,1,1:3",
            "--light",
            "sun:-1,0.2,0:0.3,0.4,1:2",
        ],
    ));
    for layer in ["emission", "scatter", "scatter_sun0", "scatter_sun1"] {
        for c in rgb(layer) {
            assert!(e.get(&c).iter().any(|v| *v > 0.0), "{c} is black");
        }
    }
    check_values(&e, &["sun0", "sun1"]);
}

#[test]
fn pyro_float_beauty_is_exactly_emission_plus_scatter() {
    let dir = scratch("values-pyro-float");
    let e = Exr::read(&render(
        &dir,
        "pyro.vdb",
        "x",
        &[
            "--float",
            "--light",
            "sun:0.6,1,0.5",
            "--light",
            "sun:-1,0,0",
        ],
    ));
    for (k, c) in ["R", "G", "B"].iter().enumerate() {
        let (b, em, sc) = (
            e.get(c),
            e.get(&rgb("emission")[k]),
            e.get(&rgb("scatter")[k]),
        );
        let (l0, l1) = (
            e.get(&rgb("scatter_sun0")[k]),
            e.get(&rgb("scatter_sun1")[k]),
        );
        for i in 0..b.len() {
            let (x, y) = e.xy(i);
            assert_eq!(b[i], em[i] + sc[i], "{c} at ({x},{y})");
            let sum = l0[i] + l1[i];
            assert!(
                (sc[i] - sum).abs() <= 1e-5 * sc[i].max(sum) + 1e-12,
                "scatter.{c} {} vs {sum} at ({x},{y})",
                sc[i]
            );
        }
    }
    check_depth(&e, 1e-6);
}

#[test]
fn depth_is_consistent_with_alpha_with_several_samples_per_pixel() {
    // With --spp 4 the pixel's alpha is the mean of the samples'; the depth rule
    // ("where accumulated alpha first reaches 0.5; 1e10 where it never does")
    // must still agree with the alpha that is written.
    let dir = scratch("values-spp");
    let e = Exr::read(&render(&dir, "cloud.vdb", "x", &["--spp", "4", "--float"]));
    check_depth(&e, 1e-6);
}

// ------------------------------------------------------------------------------------
// 4. Stats JSON.

#[test]
fn stats_of_an_emission_only_render() {
    let dir = scratch("stats-emission");
    let json = dir.join("x.json");
    let exr = render(
        &dir,
        "pyro.vdb",
        "x",
        &["--no-lights", "--stats", json.to_str().unwrap()],
    );
    let st = read_json(&json);
    for stage in ["scatter", "shadows"] {
        assert!(
            status(&st, stage).starts_with("skipped"),
            "{stage}: {}",
            status(&st, stage)
        );
    }
    assert_eq!(status(&st, "emission"), "ran");
    for stage in ["load", "build", "render", "write"] {
        assert_eq!(status(&st, stage), "ran", "{stage}");
    }
    let not_decoded = string_list(&st["grids_not_decoded"]);
    for g in ["vel", "Cd"] {
        assert!(
            not_decoded.contains(&g.to_string()),
            "{g} not in grids_not_decoded {not_decoded:?}"
        );
    }
    let roles = &st["grid_roles"];
    assert_eq!(roles["density"], "density");
    assert_eq!(roles["emission"], "flame");
    assert_eq!(roles["temperature"], "temperature");
    let decoded = string_list(&st["grids_decoded"]);
    assert!(
        !decoded.iter().any(|g| g == "vel" || g == "Cd"),
        "{decoded:?}"
    );
    assert_eq!(string_list(&st["lights"]), Vec::<String>::new());

    let e = Exr::read(&exr);
    let mut want = set(&["R", "G", "B", "A", "Z"]);
    want.extend(rgb("emission"));
    assert_eq!(e.names(), want, "emission layer, no scatter layer");
    let listed: BTreeSet<String> = string_list(&st["channels"]).into_iter().collect();
    assert_eq!(listed, want);
    check_values(&e, &[]);
}

#[test]
fn stats_of_a_scatter_only_render() {
    let dir = scratch("stats-scatter");
    let json = dir.join("x.json");
    let exr = render(&dir, "cloud.vdb", "x", &["--stats", json.to_str().unwrap()]);
    let st = read_json(&json);
    assert!(
        status(&st, "emission").starts_with("skipped"),
        "{}",
        status(&st, "emission")
    );
    assert!(
        status(&st, "scatter").starts_with("ran"),
        "{}",
        status(&st, "scatter")
    );
    assert!(
        status(&st, "shadows").starts_with("ran"),
        "{}",
        status(&st, "shadows")
    );
    assert_eq!(
        st["grid_roles"].as_object().unwrap().len(),
        1,
        "{}",
        st["grid_roles"]
    );
    assert_eq!(string_list(&st["lights"]), ["sun0"]);
    let names = Exr::read(&exr).names();
    assert!(
        !names.iter().any(|n| n.starts_with("emission")),
        "{names:?}"
    );
    assert!(names.contains("scatter.R"), "{names:?}");
}

#[test]
fn stats_with_sigma_s_zero_skip_scatter_and_shadows() {
    let dir = scratch("stats-no-scatter");
    let json = dir.join("x.json");
    let exr = render(
        &dir,
        "cloud.vdb",
        "x",
        &["--sigma-s", "0,0,0", "--stats", json.to_str().unwrap()],
    );
    let st = read_json(&json);
    for stage in ["scatter", "shadows", "emission"] {
        assert!(
            status(&st, stage).starts_with("skipped"),
            "{stage}: {}",
            status(&st, stage)
        );
    }
    let e = Exr::read(&exr);
    assert_eq!(e.names(), set(&["R", "G", "B", "A", "Z"]));
    assert!(
        e.get("A").iter().any(|a| *a > 0.05),
        "the cloud still absorbs"
    );
}

#[test]
fn stats_with_emission_and_temperature_turned_off() {
    let dir = scratch("stats-no-emission");
    let json = dir.join("x.json");
    let exr = render(
        &dir,
        "pyro.vdb",
        "x",
        &[
            "--emission-grid",
            "none",
            "--temperature-grid",
            "none",
            "--stats",
            json.to_str().unwrap(),
        ],
    );
    let st = read_json(&json);
    assert!(
        status(&st, "emission").starts_with("skipped"),
        "{}",
        status(&st, "emission")
    );
    assert_eq!(status(&st, "scatter"), "ran");
    let roles = st["grid_roles"].as_object().unwrap();
    assert_eq!(
        roles.get("density").and_then(|v| v.as_str()),
        Some("density")
    );
    for role in ["emission", "temperature"] {
        assert!(!roles.contains_key(role), "{role} role filled: {roles:?}");
    }
    let not_decoded = string_list(&st["grids_not_decoded"]);
    for g in ["temperature", "flame", "vel"] {
        assert!(
            not_decoded.contains(&g.to_string()),
            "{g} not in {not_decoded:?}"
        );
    }
    let names = Exr::read(&exr).names();
    assert!(
        !names.iter().any(|n| n.starts_with("emission")),
        "{names:?}"
    );
}

// ------------------------------------------------------------------------------------
// 7. The preview.

#[test]
fn preview_has_the_frame_size_and_shows_something() {
    let dir = scratch("preview");
    let png = dir.join("x.png");
    render(
        &dir,
        "cloud.vdb",
        "x",
        &["--preview", png.to_str().unwrap()],
    );
    let img = image::open(&png).unwrap_or_else(|e| panic!("{}: {e}", png.display()));
    assert_eq!((img.width() as usize, img.height() as usize), (W, H));
    let rgb = img.to_rgb8();
    let first = rgb.get_pixel(0, 0);
    assert!(
        rgb.pixels().any(|p| p != first),
        "the preview is all one colour"
    );
    // The cloud is lit: some pixel is brighter than either checker grey (0.6 ⇒ 153).
    assert!(
        rgb.pixels().any(|p| p.0.iter().any(|c| *c > 160)),
        "no bright pixel in the preview"
    );

    let png = dir.join("t.png");
    render(
        &dir,
        "cloud.vdb",
        "t",
        &[
            "--preview",
            png.to_str().unwrap(),
            "--background",
            "transparent",
        ],
    );
    let img = image::open(&png).unwrap().to_rgba8();
    assert_eq!((img.width() as usize, img.height() as usize), (W, H));
    assert!(
        img.pixels().any(|p| p.0[3] == 0),
        "transparent background: corners are clear"
    );
    assert!(
        img.pixels().any(|p| p.0[3] > 128),
        "the cloud is opaque somewhere"
    );
}

// ------------------------------------------------------------------------------------
// 8. Determinism.

#[test]
fn renders_are_deterministic_and_the_seed_matters() {
    let dir = scratch("determinism");
    let flags = ["--spp", "2", "--float"];
    let a = Exr::read(&render(&dir, "cloud.vdb", "a", &flags));
    let b = Exr::read(&render(&dir, "cloud.vdb", "b", &flags));
    let one_thread: Vec<&str> = flags.iter().copied().chain(["--threads", "1"]).collect();
    let c = Exr::read(&render(&dir, "cloud.vdb", "c", &one_thread));
    for other in [&b, &c] {
        assert_eq!(a.window, other.window);
        assert_eq!(a.names(), other.names());
        for (name, (_, v)) in &a.channels {
            let w = other.get(name);
            let same = v
                .iter()
                .zip(w)
                .all(|(x, y)| x == y || (x.is_nan() && y.is_nan()));
            assert!(same, "{name} differs between identical renders");
        }
    }

    // Another seed: at one sample per pixel only the march's step offsets move, so
    // the image changes slightly; at two, the pixel jitter moves too, and the
    // image as a whole stays the same.
    let full = |e: &Exr, name: &str| -> Vec<f32> {
        let mut out = vec![0.0; W * H];
        for (i, v) in e.get(name).iter().enumerate() {
            let (x, y) = e.xy(i);
            out[y * W + x] = *v;
        }
        out
    };
    let seeded: Vec<&str> = flags.iter().copied().chain(["--seed", "12345"]).collect();
    let d = Exr::read(&render(&dir, "cloud.vdb", "d", &seeded));
    let (ra, rd) = (full(&a, "R"), full(&d, "R"));
    assert!(
        ra.iter().zip(&rd).any(|(x, y)| x != y),
        "--seed changes nothing at --spp 2"
    );
    let (sa, sd) = (ra.iter().sum::<f32>(), rd.iter().sum::<f32>());
    assert!(
        (sa - sd).abs() < 0.02 * sa,
        "--seed changes the total of R from {sa} to {sd}"
    );

    // At one sample a pixel with pixel centres only (the silhouette's resampling jitters
    // its samples by the seed too), the seed moves the march's step offsets alone.
    let e = Exr::read(&render(
        &dir,
        "cloud.vdb",
        "e",
        &["--float", "--antialias", "1"],
    ));
    let f = Exr::read(&render(
        &dir,
        "cloud.vdb",
        "f",
        &["--float", "--antialias", "1", "--seed", "12345"],
    ));
    let (re, rf) = (full(&e, "R"), full(&f, "R"));
    let changed = re.iter().zip(&rf).filter(|(x, y)| x != y).count();
    assert!(changed > 0, "--seed changes nothing in R at --spp 1");
    let max = re
        .iter()
        .zip(&rf)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max);
    let peak = re.iter().copied().fold(0.0, f32::max);
    assert!(
        max < 0.02 * peak,
        "--seed changes R by up to {max} (peak {peak})"
    );
    // Opacity comes from the exact optical depth, whatever the step offsets: the seed
    // cannot move it (beyond the last bits of the sum).
    let (ae, af) = (full(&e, "A"), full(&f, "A"));
    let max = ae
        .iter()
        .zip(&af)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max);
    assert!(max <= 1e-6, "--seed changes A by up to {max}");
}
