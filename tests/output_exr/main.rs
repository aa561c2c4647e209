//! Writes frames with known contents and checks the files with tools nobody
//! here wrote: `exrheader` (OpenEXR) and `oiiotool` (OpenImageIO), plus a
//! read-back with the `exr` crate. A test that runs a tool is skipped where it
//! is missing (Debian's `openexr` and `openimageio-tools`), and fails under
//! `MURK_REQUIRE_TOOLS=1`.

#[path = "../common/mod.rs"]
mod common;
use common::tools;
use common::{
    COMPRESSIONS, assert_compression_named, exrheader, exrheader_channels, oiio_info, tool,
};

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};

use exr::prelude::{FlatSamples, read_all_flat_layers_from_file};
use murk::files::FileError;
use murk::output::{
    Background, ExrCompression, ExrOptions, Frame, OutputError, PreviewOptions, write_atomically,
    write_exr, write_preview,
};

const W: usize = 64;
const H: usize = 48;
/// The non-empty square: x in 10..30, y in 5..20.
const SQ_X: std::ops::Range<usize> = 10..30;
const SQ_Y: std::ops::Range<usize> = 5..20;

const COLOUR: [&str; 16] = [
    "R",
    "G",
    "B",
    "A",
    "emission.R",
    "emission.G",
    "emission.B",
    "scatter.R",
    "scatter.G",
    "scatter.B",
    "scatter_sun0.R",
    "scatter_sun0.G",
    "scatter_sun0.B",
    "shadow.R",
    "shadow.G",
    "shadow.B",
];

const DEPTH_RULE: &str =
    "Z is the depth where accumulated alpha first crosses 0.5; +inf where it never does";

fn in_square(x: usize, y: usize) -> bool {
    SQ_X.contains(&x) && SQ_Y.contains(&y)
}

/// The value of channel `name` at (x, y) in the test frame.
fn expected(name: &str, x: usize, y: usize) -> f32 {
    if !in_square(x, y) {
        return if name == "Z" { f32::INFINITY } else { 0.0 };
    }
    let (fx, fy) = ((x - 10) as f32, (y - 5) as f32);
    let alpha = 0.4 + 0.02 * fx + 0.01 * fy; // 0.4 .. 0.92
    match name {
        "A" => alpha,
        "R" => alpha * 0.9,
        "G" => alpha * 0.5,
        "B" => alpha * 0.25,
        "Z" => 3.0 + 0.125 * fx + 0.0625 * fy + 1e-3,
        _ => {
            let k = COLOUR.iter().position(|c| *c == name).unwrap_or(0) as f32;
            0.05 * k + 0.003 * fx + 0.007 * fy + 0.01
        }
    }
}

fn test_frame() -> Frame {
    let mut f = Frame::new(W, H);
    for name in COLOUR.iter().copied().chain(["Z"]) {
        let data = (0..W * H).map(|i| expected(name, i % W, i / W)).collect();
        f.add_channel(name, data).unwrap();
    }
    f
}

fn test_options() -> ExrOptions {
    ExrOptions {
        world_to_camera: Some([
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
            [0.5, -2.0, 7.0, 1.0],
        ]),
        world_to_ndc: Some([
            [2.0, 0.0, 0.0, 0.0],
            [0.0, 2.5, 0.0, 0.0],
            [0.0, 0.0, 1.0, 1.0],
            [0.0, 0.0, -0.2, 0.0],
        ]),
        software: "murk test".to_owned(),
        render_time_seconds: Some(12.5),
        input_file: Some("fixtures/smoke.vdb".to_owned()),
        extra_strings: vec![("murk/depthRule".to_owned(), DEPTH_RULE.to_owned())],
        ..cropped()
    }
}

/// The writer's cropped window and `+inf` depth (`--crop-data-window --z-empty inf`),
/// which these tests were written for; the defaults (full window, 1e10) are tested in
/// `default_options_write_the_full_window_and_1e10_depth`.
fn cropped() -> ExrOptions {
    ExrOptions {
        crop_data_window: true,
        z_empty: f32::INFINITY,
        ..ExrOptions::default()
    }
}

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("output_exr-{name}"));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

/// Pixel values as read by OpenImageIO (`--dumpdata`): channel → (x, y) → value.
fn oiio_pixels(path: &Path) -> BTreeMap<String, BTreeMap<(usize, usize), f32>> {
    let info = oiio_info(path);
    let list = info
        .lines()
        .find_map(|l| l.trim().strip_prefix("channel list: "))
        .unwrap();
    let names: Vec<String> = list
        .split(", ")
        .map(|c| c.split(' ').next().unwrap().to_owned())
        .collect();
    // keep PNG colours as stored (OIIO would premultiply unassociated alpha)
    let args = [
        "--iconfig",
        "oiio:UnassociatedAlpha",
        "1",
        "--dumpdata",
        path.to_str().unwrap(),
    ];
    let dump = tool("oiiotool", &args, "openimageio-tools");
    let mut out: BTreeMap<String, BTreeMap<(usize, usize), f32>> = BTreeMap::new();
    for line in dump
        .lines()
        .filter_map(|l| l.trim().strip_prefix("Pixel ("))
    {
        let (xy, values) = line.split_once("):").unwrap();
        let (x, y) = xy.split_once(", ").unwrap();
        let (x, y) = (x.parse().unwrap(), y.parse().unwrap());
        // integer formats print raw codes, then normalised values in parentheses
        let values = match values.split_once('(') {
            Some((_, normalised)) => normalised.trim_end_matches(')'),
            None => values,
        };
        let values: Vec<f32> = values
            .split_whitespace()
            .map(|v| v.parse().unwrap())
            .collect();
        assert_eq!(values.len(), names.len(), "{line}");
        for (n, v) in names.iter().zip(values) {
            out.entry(n.clone()).or_default().insert((x, y), v);
        }
    }
    out
}

fn close(got: f32, want: f32, rel: f32) -> bool {
    got == want || (got - want).abs() <= rel * want.abs().max(1e-3)
}

fn no_temp_files(dir: &Path) {
    let left: Vec<_> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-"))
        .collect();
    assert!(left.is_empty(), "temporary files left behind: {left:?}");
}

mod files;
mod header;
mod previews;
mod values;
