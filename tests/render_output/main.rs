//! End-to-end checks of what `murk render` writes: the EXR read back by tools
//! nobody here wrote (`exrheader` from OpenEXR, `oiiotool` from OpenImageIO)
//! and by the `exr` crate, the stats JSON, the PNG preview, the example scene
//! file `fixtures/scene.toml`, and determinism.
//!
//! A test that runs a tool is skipped where it is missing (the Debian packages
//! `openexr` and `openimageio-tools`), and fails under `MURK_REQUIRE_TOOLS=1`.
//!
//! Renders are small (96×54 and less) so that every test is quick.

#[path = "../common/mod.rs"]
mod common;
use common::tools;
use common::{COMPRESSIONS, assert_compression_named, exrheader, exrheader_channels, oiio_info};

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

mod determinism;
mod header;
mod preview;
mod scene_file;
mod stats;
mod values;
