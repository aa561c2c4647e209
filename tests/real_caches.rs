//! Real caches render right by default: the fixtures of `scripts/cache_fixtures.py`
//! (pyopenvdb), laid out as Blender's Mantaflow writes its caches — a shadow grid, a
//! staggered velocity, no creator metadata, empty colour grids, smoke-only temperature —
//! plus a plume no tool marked, a level set and a short smoke sequence. Each rendered
//! with no flag a new user would not think to add, asserted from the EXR and the stats.

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

fn cache(name: &str) -> String {
    fixture(&format!("caches/{name}"))
}

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("real-caches-{name}"));
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

/// Renders `input` at W×H into `dir/name.exr` with its stats and no `--quiet`; returns
/// (exr, stats, stderr).
fn render(dir: &Path, input: &str, name: &str, extra: &[&str]) -> (PathBuf, Value, String) {
    let exr = dir.join(format!("{name}.exr"));
    let stats = dir.join(format!("{name}.json"));
    let (e, s) = (exr.display().to_string(), stats.display().to_string());
    let res = format!("{W}x{H}");
    let mut a = vec!["render", input, "-o", &e, "--res", &res, "--stats", &s];
    a.extend_from_slice(extra);
    let out = murk(&a);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "murk {} failed:\n{err}", a.join(" "));
    let v: Value = serde_json::from_str(&fs::read_to_string(&stats).unwrap()).unwrap();
    (exr, v, err)
}

struct Image {
    width: usize,
    channels: BTreeMap<String, Vec<f32>>,
}

fn read(path: &Path) -> Image {
    let image = read_all_flat_layers_from_file(path).unwrap();
    let layer = &image.layer_data[0];
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
        width: layer.size.0,
        channels,
    }
}

impl Image {
    fn sum(&self, channel: &str) -> f64 {
        self.channels
            .get(channel)
            .map_or(0.0, |v| v.iter().map(|x| *x as f64).sum())
    }

    /// The box (x0, y0, x1, y1) of pixels with alpha above 0.02.
    fn alpha_box(&self) -> (usize, usize, usize, usize) {
        let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
        for (i, v) in self.channels["A"].iter().enumerate() {
            if *v > 0.02 {
                let (x, y) = (i % self.width, i / self.width);
                (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
            }
        }
        assert!(x0 <= x1, "nothing visible");
        (x0, y0, x1, y1)
    }

    fn alpha_extent(&self) -> (usize, usize) {
        let (x0, y0, x1, y1) = self.alpha_box();
        (x1 - x0 + 1, y1 - y0 + 1)
    }
}

fn text<'a>(v: &'a Value, key: &str) -> &'a str {
    v[key]
        .as_str()
        .unwrap_or_else(|| panic!("no {key} in {v:#}"))
}

fn notes(st: &Value) -> Vec<String> {
    st["notes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n.as_str().unwrap().to_owned())
        .collect()
}

#[test]
fn mantaflow_without_colour_grids_is_blender_and_rises_along_z() {
    let dir = scratch("mantaflow");
    let (exr, st, _) = render(&dir, &cache("mantaflow_fire.vdb"), "f", &[]);
    let tool = text(&st, "source_tool");
    assert!(
        tool.starts_with("blender") && tool.contains("Mantaflow"),
        "{tool}"
    );
    assert!(text(&st, "up_axis").starts_with("z (auto"), "{st:#}");
    // The plume (40 voxels tall, 24 across) stands upright in the frame.
    let (w, h) = read(&exr).alpha_extent();
    assert!(h as f64 > 1.3 * w as f64, "plume {w}x{h} px is not upright");
}

#[test]
fn with_no_tool_the_data_picks_the_up_axis_and_a_note_says_so() {
    let dir = scratch("notool");
    let (exr, st, err) = render(&dir, &cache("plume_zup.vdb"), "z", &[]);
    assert!(st["source_tool"].is_null(), "{st:#}");
    let up = text(&st, "up_axis");
    assert!(
        up.starts_with("z (auto: no tool recognised; the smoke lies above the heat along +z"),
        "{up}"
    );
    let n = notes(&st);
    assert_eq!(
        n.iter()
            .filter(|n| n.contains("no tool recognised"))
            .count(),
        1,
        "{n:?}"
    );
    assert!(err.contains("murk: note: no tool recognised"), "{err}");
    let (w, h) = read(&exr).alpha_extent();
    assert!(h as f64 > 1.3 * w as f64, "plume {w}x{h} px is not upright");
    // Without a temperature grid nothing tells: y, and why.
    let (_, st, _) = render(&dir, &fixture("cloud.vdb"), "c", &[]);
    let up = text(&st, "up_axis");
    assert!(
        up.starts_with("y (auto: no tool recognised and no temperature grid"),
        "{up}"
    );
    // A Y-up pyro cache with no tool's marks stays Y-up.
    let (_, st, _) = render(&dir, &fixture("pyro.vdb"), "p", &[]);
    assert!(text(&st, "up_axis").starts_with("y"), "{st:#}");
}

#[test]
fn default_sun_of_a_z_up_cache_is_turned_with_its_shadows() {
    let dir = scratch("sun");
    let input = cache("mantaflow_fire.vdb");
    let (d, _, _) = render(&dir, &input, "d", &[]);
    let (turned, _, _) = render(&dir, &input, "t", &["--light", "sun:0.6,-0.5,1:1,1,1:6"]);
    let (y_up, _, _) = render(&dir, &input, "y", &["--light", "sun:0.6,1,0.5:1,1,1:6"]);
    let (d, turned, y_up) = (read(&d), read(&turned), read(&y_up));
    for c in ["scatter.R", "scatter.G", "scatter.B"] {
        let (a, b, c_y) = (d.sum(c), turned.sum(c), y_up.sum(c));
        assert!(a > 0.0, "{c}: nothing scatters");
        assert!(
            (a - b).abs() <= 1e-6 * a,
            "{c}: default {a} differs from the turned sun {b}"
        );
        assert!(
            (a - c_y).abs() > 0.02 * a,
            "{c}: default {a} is the Y-up sun's {c_y}"
        );
    }
    // A shadow cache baked for the cache turns its default sun the same way: the render
    // that reads it (a farm's shared bake) finds its light and the same image.
    let baked = dir.join("sun.vdb").display().to_string();
    let o = murk(&["bake-shadows", &input, "-o", &baked, "--quiet"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (cached, st, _) = render(&dir, &input, "c", &["--shadow-cache", &baked]);
    assert!(
        st["shadow_maps"][0]["source"]
            .as_str()
            .unwrap()
            .starts_with("cache"),
        "{st:#}"
    );
    let cached = read(&cached);
    for c in ["scatter.R", "scatter.G", "scatter.B"] {
        let (a, b) = (d.sum(c), cached.sum(c));
        assert!(
            (a - b).abs() <= 1e-6 * a,
            "{c}: baked {a}, from the cache {b}"
        );
    }
    let help = String::from_utf8_lossy(&murk(&["render", "--help"]).stdout).into_owned();
    assert!(help.contains("0,0,1 for a Z-up cache"), "{help}");
}

#[test]
fn empty_colour_grids_are_left_out_and_the_smoke_stays_white() {
    let dir = scratch("colour");
    let (exr, st, _) = render(&dir, &cache("mantaflow_smoke.vdb"), "s", &[]);
    for c in ["color_r", "color_g", "color_b"] {
        assert!(
            text(&st["skipped_grids"], c).contains("empty or zero everywhere"),
            "{st:#}"
        );
    }
    assert!(st["grid_roles"].get("color_r").is_none(), "{st:#}");
    assert!(
        notes(&st).iter().any(|n| n.contains("colour grids")),
        "{st:#}"
    );
    let img = read(&exr);
    let (r, g, b) = (
        img.sum("scatter.R"),
        img.sum("scatter.G"),
        img.sum("scatter.B"),
    );
    assert!(r > 0.0, "black smoke: scatter {r} {g} {b}");
    assert!(
        (r - g).abs() < 0.01 * r && (g - b).abs() < 0.01 * r,
        "white light on plain smoke is grey: {r} {g} {b}"
    );
}

#[test]
fn temperature_glows_only_where_the_cache_has_fire() {
    let dir = scratch("fire");
    // Smoke only: flame empty, temperature 1..2 at the source.
    let (exr, st, _) = render(&dir, &cache("mantaflow_smoke.vdb"), "s", &[]);
    let e = text(&st["temperature_convention"], "emission");
    assert!(e.starts_with("off: the cache has no fire"), "{e}");
    assert!(
        text(&st["stages"]["emission"], "status").starts_with("skipped"),
        "{st:#}"
    );
    assert_eq!(read(&exr).sum("emission.R"), 0.0);
    // Asked for by name, it glows.
    let (exr, st, _) = render(
        &dir,
        &cache("mantaflow_smoke.vdb"),
        "n",
        &["--temperature-grid", "temperature"],
    );
    assert!(text(&st["temperature_convention"], "emission").starts_with("on:"));
    assert!(read(&exr).sum("emission.R") > 0.0);
    // Fire: flame 0..1 at the source.
    let (exr, st, _) = render(&dir, &cache("mantaflow_fire.vdb"), "f", &[]);
    let e = text(&st["temperature_convention"], "emission");
    assert!(e.starts_with("on: the cache has fire"), "{e}");
    assert!(read(&exr).sum("emission.R") > 0.0);
}

#[test]
fn a_level_set_is_refused_with_what_to_do_and_doing_it_works() {
    need!(tools::VDB_TOOL);
    let dir = scratch("levelset");
    let out = dir.join("l.exr").display().to_string();
    let input = cache("levelset_sphere.vdb");
    let o = murk(&["render", &input, "-o", &out, "--res", "32x18"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("level set") && err.contains("-ls2fog"),
        "{err}"
    );
    assert!(!Path::new(&out).exists());
    // The conversion it names, run as written, gives a file that renders: a sphere.
    let fog = dir.join("fog.vdb");
    let converted = tools::command(&tools::VDB_TOOL)
        .args(["-read", &input, "-ls2fog", "name=density", "-write"])
        .arg(&fog)
        .output()
        .expect("vdb_tool is required (Debian package libopenvdb-tools)");
    assert!(converted.status.success());
    let (exr, _, _) = render(&dir, fog.to_str().unwrap(), "fog", &[]);
    let (w, h) = read(&exr).alpha_extent();
    let ratio = w as f64 / h as f64;
    assert!((0.8..1.25).contains(&ratio), "a sphere: {w}x{h} px");
}

#[test]
fn defaults_warn_of_nothing_on_fixtures_and_real_like_caches() {
    let dir = scratch("warn");
    let inputs = [
        cache("mantaflow_fire.vdb"),
        cache("mantaflow_smoke.vdb"),
        cache("plume_zup.vdb"),
        fixture("blender_smoke.vdb"),
        fixture("houdini_pyro.vdb"),
        fixture("dense_plume.vdb"),
        fixture("pyro.vdb"),
        fixture("cloud.vdb"),
        fixture("sphere.vdb"),
        fixture("slab.vdb"),
        fixture("levelset_fog.vdb"),
    ];
    // Not tiles.vdb: an active root tile of 4096³ voxels (204 units of density 4) does
    // not fit the map's budget even coarsened 16×, which a warning rightly says.
    for (i, input) in inputs.iter().enumerate() {
        let (_, st, err) = render(&dir, input, &format!("i{i}"), &["--quiet"]);
        assert!(err.trim().is_empty(), "{input}: {err}");
        assert_eq!(st["warnings"], Value::Array(vec![]), "{input}");
    }
}

#[test]
fn a_chosen_shadow_tolerance_missed_says_what_holds_it_and_that_works() {
    let dir = scratch("tolerance");
    let input = fixture("cloud.vdb");
    let (_, st, err) = render(&dir, &input, "t", &["--dsm-tolerance", "1e-5", "--quiet"]);
    let w = st["warnings"].as_array().unwrap();
    assert!(!w.is_empty(), "1e-5 is past what a map holds on the cloud");
    assert!(err.contains("--shadows march"), "{err}");
    let (_, st, err) = render(&dir, &input, "m", &["--shadows", "march", "--quiet"]);
    assert!(err.trim().is_empty(), "{err}");
    assert_eq!(st["warnings"], Value::Array(vec![]));
}

#[test]
fn a_smoke_sequence_renders_framed_on_the_union_of_its_frames() {
    let dir = scratch("seq");
    let pattern = cache("smoke_seq/smoke_####.vdb");
    // Into a folder that does not exist yet, as a new user would.
    let dir = dir.join("new");
    let out = dir.join("smoke_####.exr").display().to_string();
    let preview = dir.join("smoke_####.png").display().to_string();
    let res = format!("{W}x{H}");
    let o = murk(&[
        "render",
        &pattern,
        "-o",
        &out,
        "--preview",
        &preview,
        "--res",
        &res,
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(!err.contains("warning"), "{err}");
    let boxes: Vec<_> = (1..=12)
        .map(|f| read(&dir.join(format!("smoke_{f:04}.exr"))).alpha_box())
        .collect();
    // The camera does not move: the plume's foot stays on one row while it grows.
    let foot = boxes[0].3;
    for (i, b) in boxes.iter().enumerate() {
        assert!(
            b.3.abs_diff(foot) <= 1,
            "frame {}: foot {} vs {foot}",
            i + 1,
            b.3
        );
    }
    assert!(boxes[0].1 > boxes[11].1 + H / 3, "{boxes:?}");
    // The whole plume at its tallest fills most of the frame's height, upright.
    let (x0, y0, x1, y1) = boxes[11];
    assert!(y1 - y0 + 1 >= 2 * H / 3, "last frame {:?}", boxes[11]);
    assert!(y1 - y0 > x1 - x0, "upright: {:?}", boxes[11]);
    // White smoke lit from the front: the lit side is grey, not black or tinted.
    let last = read(&dir.join("smoke_0012.exr"));
    let (r, g, b) = (
        last.sum("scatter.R"),
        last.sum("scatter.G"),
        last.sum("scatter.B"),
    );
    assert!(r > 0.0 && (r - b).abs() < 0.01 * r && (r - g).abs() < 0.01 * r);
    assert_eq!(last.sum("emission.R"), 0.0);
}
