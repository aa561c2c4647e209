//! Writes frames with known contents and checks the files with tools nobody
//! here wrote: `exrheader` (OpenEXR) and `oiiotool` (OpenImageIO), plus a
//! read-back with the `exr` crate. A test that runs a tool is skipped where it
//! is missing (Debian's `openexr` and `openimageio-tools`), and fails under
//! `MURK_REQUIRE_TOOLS=1`.

mod common;
use common::tools;
use common::{exrheader, exrheader_channels, oiio_info, tool};

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

#[test]
fn default_options_write_the_full_window_and_1e10_depth() {
    need!(tools::EXRHEADER, tools::OIIOTOOL);
    let dir = scratch("defaults");
    let path = dir.join("defaults.exr");
    let summary = write_exr(&path, &test_frame(), &ExrOptions::default()).unwrap();
    assert_eq!((summary.data_window.x, summary.data_window.y), (0, 0));
    let h = exrheader(&path);
    assert!(
        h.contains("dataWindow (type box2i): (0 0) - (63 47)\n"),
        "{h}"
    );
    let pixels = oiio_pixels(&path);
    // Z: 1e10 where the frame had +inf, its values elsewhere.
    assert_eq!(pixels["Z"][&(0, 0)], 1e10);
    assert!(pixels["Z"].values().all(|z| z.is_finite()));
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

#[test]
fn half_exr_header_per_exrheader() {
    need!(tools::EXRHEADER);
    let dir = scratch("half-exrheader");
    let path = dir.join("frame.exr");
    let summary = write_exr(&path, &test_frame(), &test_options()).unwrap();
    assert_eq!((summary.data_window.x, summary.data_window.y), (10, 5));
    assert_eq!(summary.nan_count, 0);
    let h = exrheader(&path);

    // single-part scanline: no multi-part (0x1000), tiled (0x200) or deep (0x800) flag
    assert!(h.contains("file format version: 2, flags 0x0\n"), "{h}");
    assert!(
        !h.contains("tiles (type tiledesc)") && !h.contains("name (type string)"),
        "{h}"
    );
    assert!(!h.contains(" part "), "{h}");

    let channels = exrheader_channels(&h);
    let names: Vec<&str> = channels.iter().map(|(n, _)| n.as_str()).collect();
    let mut want: Vec<&str> = COLOUR.iter().copied().chain(["Z"]).collect();
    want.sort_unstable();
    assert_eq!(names, want, "channels must be all there, sorted");
    for (name, ty) in &channels {
        let want_ty = if name == "Z" {
            "32-bit floating-point"
        } else {
            "16-bit floating-point"
        };
        assert_eq!(ty, want_ty, "type of {name}");
    }
    for line in [
        "dataWindow (type box2i): (10 5) - (29 19)",
        "displayWindow (type box2i): (0 0) - (63 47)",
        "compression (type compression): zip, individual scanlines",
        "lineOrder (type lineOrder): increasing y",
        "chromaticities (type chromaticities):",
        "    red   (0.64 0.33)",
        "    green (0.3 0.6)",
        "    blue  (0.15 0.06)",
        "    white (0.3127 0.329)",
        "worldToCamera (type m44f):",
        "    0.5 -2 7 1)",
        "worldToNDC (type m44f):",
        "    0 0 -0.2 0)",
        "software (type string): \"murk test\"",
        "renderTime (type float): 12.5",
        "inputFile (type string): \"fixtures/smoke.vdb\"",
        &format!("murk/depthRule (type string): \"{DEPTH_RULE}\""),
    ] {
        assert!(
            h.lines().any(|l| l == line),
            "exrheader lacks `{line}`:\n{h}"
        );
    }
    assert!(!h.contains("murk/nanCount"), "{h}");
}

#[test]
fn half_exr_header_per_oiiotool() {
    need!(tools::OIIOTOOL);
    let dir = scratch("half-oiio");
    let path = dir.join("frame.exr");
    write_exr(&path, &test_frame(), &test_options()).unwrap();
    let info = oiio_info(&path);
    assert!(info.contains(":   20 x   15, 17 channel, "), "{info}");
    for line in [
        "pixel data origin: x=10, y=5",
        "full/display size: 64 x 48",
        "full/display origin: 0, 0",
        "compression: \"zips\"",
        "chromaticities: 0.64, 0.33, 0.3, 0.6, 0.15, 0.06, 0.3127, 0.329",
        "worldToCamera: 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0.5, -2, 7, 1",
        "worldToNDC: 2, 0, 0, 0, 0, 2.5, 0, 0, 0, 0, 1, 1, 0, 0, -0.2, 0",
        "renderTime: 12.5",
        "inputFile: \"fixtures/smoke.vdb\"",
        "software: \"murk test\"",
        "oiio:subimages: 1",
    ] {
        assert!(
            info.lines().any(|l| l.trim() == line),
            "oiiotool lacks `{line}`:\n{info}"
        );
    }
    assert!(!info.contains("tile size"), "must be scanline:\n{info}");
    let list = info
        .lines()
        .find_map(|l| l.trim().strip_prefix("channel list: "))
        .unwrap();
    for name in COLOUR {
        assert!(
            list.contains(&format!("{name} (half)")),
            "{name} not half: {list}"
        );
    }
    assert!(list.contains("Z (float)"), "Z not float: {list}");
}

#[test]
fn half_values_read_back_with_exr_crate_and_oiio() {
    need!(tools::OIIOTOOL);
    let dir = scratch("half-values");
    let path = dir.join("frame.exr");
    write_exr(&path, &test_frame(), &test_options()).unwrap();

    let image = read_all_flat_layers_from_file(&path).unwrap();
    assert_eq!(image.layer_data.len(), 1);
    let layer = &image.layer_data[0];
    assert_eq!(
        (
            layer.attributes.layer_position.0,
            layer.attributes.layer_position.1
        ),
        (10, 5)
    );
    assert_eq!((layer.size.0, layer.size.1), (20, 15));
    assert_eq!(layer.channel_data.list.len(), 17);
    for channel in &layer.channel_data.list {
        let name = channel.name.to_string();
        let (is_half, values): (bool, Vec<f32>) = match &channel.sample_data {
            FlatSamples::F16(v) => (true, v.iter().map(|h| h.to_f32()).collect()),
            FlatSamples::F32(v) => (false, v.clone()),
            FlatSamples::U32(_) => panic!("{name} is u32"),
        };
        assert_eq!(is_half, name != "Z", "{name} sample type");
        for (i, got) in values.into_iter().enumerate() {
            let (x, y) = (10 + i % 20, 5 + i / 20);
            let want = expected(&name, x, y);
            let ok = if is_half {
                close(got, want, 1e-3)
            } else {
                got == want
            };
            assert!(ok, "{name} at ({x},{y}): {got} != {want}");
        }
    }

    let pixels = oiio_pixels(&path);
    assert_eq!(pixels.len(), 17);
    for (name, values) in &pixels {
        assert_eq!(values.len(), 300, "{name}");
        for (&(x, y), &got) in values {
            let want = expected(name, x, y);
            let tol = if name == "Z" { 0.0 } else { 1e-3 };
            assert!(
                close(got, want, tol),
                "oiio {name} at ({x},{y}): {got} != {want}"
            );
        }
    }
}

#[test]
fn float_option_stores_colour_as_float() {
    need!(tools::EXRHEADER, tools::OIIOTOOL);
    let dir = scratch("float");
    let path = dir.join("frame.exr");
    let opts = ExrOptions {
        float: true,
        ..test_options()
    };
    write_exr(&path, &test_frame(), &opts).unwrap();
    let channels = exrheader_channels(&exrheader(&path));
    assert_eq!(channels.len(), 17);
    assert!(
        channels.iter().all(|(_, t)| t == "32-bit floating-point"),
        "{channels:?}"
    );
    let info = oiio_info(&path);
    assert!(
        !info.contains("(half)") && info.contains("17 channel, float openexr"),
        "{info}"
    );
    for (name, values) in oiio_pixels(&path) {
        for ((x, y), got) in values {
            assert_eq!(got, expected(&name, x, y), "{name} at ({x},{y})");
        }
    }
}

#[test]
fn every_compression_is_named_and_readable() {
    need!(tools::EXRHEADER, tools::OIIOTOOL);
    let dir = scratch("compression");
    let frame = test_frame();
    for (c, exrheader_name) in [
        (ExrCompression::None, "none"),
        (ExrCompression::Rle, "run-length encoding"),
        (ExrCompression::Zips, "zip, individual scanlines"),
        (ExrCompression::Zip, "zip, multi-scanline blocks"),
        (ExrCompression::Piz, "piz"),
        (ExrCompression::Dwaa, "dwa, small scanline blocks"),
    ] {
        let path = dir.join(format!("{c}.exr"));
        write_exr(
            &path,
            &frame,
            &ExrOptions {
                compression: c,
                ..test_options()
            },
        )
        .unwrap();
        let h = exrheader(&path);
        let line = format!("compression (type compression): {exrheader_name}");
        assert!(
            h.lines().any(|l| l == line),
            "{c}: exrheader lacks `{line}`:\n{h}"
        );
        let info = oiio_info(&path);
        assert!(
            info.contains(&format!("compression: \"{c}\"")),
            "{c}:\n{info}"
        );
        // lossless methods round-trip at half precision; DWAA is lossy on colour
        let tol = if c == ExrCompression::Dwaa {
            2e-2
        } else {
            1e-3
        };
        for (name, values) in oiio_pixels(&path) {
            for ((x, y), got) in values {
                let want = expected(&name, x, y);
                let ok = if name == "Z" {
                    got == want
                } else {
                    close(got, want, tol)
                };
                assert!(ok, "{c}: {name} at ({x},{y}): {got} != {want}");
            }
        }
    }
}

#[test]
fn empty_frame_gets_a_one_pixel_window_at_top_left() {
    need!(tools::EXRHEADER);
    let dir = scratch("empty");
    let path = dir.join("empty.exr");
    let mut frame = Frame::new(W, H);
    frame.add_channel("R", vec![0.0; W * H]).unwrap();
    frame.add_channel("Z", vec![f32::INFINITY; W * H]).unwrap();
    write_exr(&path, &frame, &cropped()).unwrap();
    let h = exrheader(&path);
    assert!(
        h.contains("dataWindow (type box2i): (0 0) - (0 0)\n"),
        "{h}"
    );
    assert!(
        h.contains("displayWindow (type box2i): (0 0) - (63 47)\n"),
        "{h}"
    );
}

#[test]
fn nans_are_written_as_zero_and_counted() {
    need!(tools::EXRHEADER, tools::OIIOTOOL);
    let dir = scratch("nan");
    let path = dir.join("nan.exr");
    let mut frame = test_frame();
    frame.channel_mut("G").unwrap()[7 * W + 12] = f32::NAN;
    frame.channel_mut("emission.B").unwrap()[40 * W + 50] = f32::NAN; // outside: stays empty
    frame.channel_mut("Z").unwrap()[8 * W + 13] = f32::NAN;
    let summary = write_exr(&path, &frame, &cropped()).unwrap();
    assert_eq!(summary.nan_count, 3);
    let h = exrheader(&path);
    assert!(h.contains("murk/nanCount (type int): 3\n"), "{h}");
    assert!(
        h.contains("dataWindow (type box2i): (10 5) - (29 19)\n"),
        "{h}"
    );
    let stats = tool(
        "oiiotool",
        &["--stats", path.to_str().unwrap()],
        "openimageio-tools",
    );
    let nan_line = stats.lines().find(|l| l.contains("NanCount")).unwrap();
    assert!(
        nan_line.split_whitespace().skip(2).all(|n| n == "0"),
        "{nan_line}"
    );
    let pixels = oiio_pixels(&path);
    assert_eq!(pixels["G"][&(12, 7)], 0.0);
    assert_eq!(pixels["Z"][&(13, 8)], f32::INFINITY);
}

#[test]
fn missing_folders_are_made_and_one_that_cannot_be_fails_naming_the_path() {
    let dir = scratch("missing-dir");
    let made = dir.join("no/such/dir/frame.exr");
    write_exr(&made, &test_frame(), &ExrOptions::default()).unwrap();
    assert!(made.is_file());
    // Under a regular file no folder can be made, even as root.
    fs::write(dir.join("file"), "x").unwrap();
    let path = dir.join("file/no/frame.exr");
    let err = write_exr(&path, &test_frame(), &ExrOptions::default()).unwrap_err();
    let msg = err.to_string();
    assert!(msg.contains(&path.display().to_string()), "{msg}");
    assert!(msg.contains("cannot create the folder"), "{msg}");
    let png = dir.join("file/preview.png");
    let msg = write_preview(&png, &test_frame(), &PreviewOptions::default())
        .unwrap_err()
        .to_string();
    assert!(msg.contains(&png.display().to_string()), "{msg}");
    assert_eq!(fs::read_to_string(dir.join("file")).unwrap(), "x");
}

#[test]
fn failed_writes_leave_the_existing_target_untouched() {
    need!(tools::EXRHEADER);
    let dir = scratch("untouched");
    let path = dir.join("frame.exr");
    write_exr(&path, &test_frame(), &test_options()).unwrap();
    let before = fs::read(&path).unwrap();

    // rejected before writing: a frame without channels, a reserved attribute name
    let e = write_exr(&path, &Frame::new(W, H), &test_options()).unwrap_err();
    assert!(e.to_string().contains(&path.display().to_string()), "{e}");
    let mut opts = test_options();
    opts.extra_strings
        .push(("dataWindow".to_owned(), "x".to_owned()));
    assert!(write_exr(&path, &test_frame(), &opts).is_err());

    // fails after the temporary file was written
    let e: Result<(), OutputError> = write_atomically(&path, |tmp| {
        fs::write(tmp, b"half a file").unwrap();
        Err(OutputError::File(FileError::Invalid {
            path: path.clone(),
            reason: "simulated failure".into(),
        }))
    });
    assert!(e.is_err());
    assert_eq!(fs::read(&path).unwrap(), before, "target changed");
    no_temp_files(&dir);

    // the target is a non-empty directory: refused by the output guard
    let blocker = dir.join("blocked.exr");
    fs::create_dir(&blocker).unwrap();
    fs::write(blocker.join("keep"), b"keep").unwrap();
    let e = write_exr(&blocker, &test_frame(), &test_options()).unwrap_err();
    assert!(
        matches!(e, OutputError::File(FileError::Refused { .. })),
        "{e:?}"
    );
    assert!(
        e.to_string().contains(&blocker.display().to_string()),
        "{e}"
    );
    assert_eq!(fs::read(blocker.join("keep")).unwrap(), b"keep");
    no_temp_files(&dir);
    exrheader(&path); // still a valid file
}

#[test]
fn previews_composite_expose_and_encode_srgb() {
    need!(tools::OIIOTOOL);
    let dir = scratch("preview");
    let frame = test_frame();
    let srgb = |l: f32| {
        let l = l.clamp(0.0, 1.0);
        if l <= 0.0031308 {
            l * 12.92
        } else {
            1.055 * l.powf(1.0 / 2.4) - 0.055
        }
    };
    let q = |v: f32| (v * 255.0).round() / 255.0;
    let (px, py) = (15, 9);
    let (r, a) = (expected("R", px, py), expected("A", px, py));

    let cases: [(&str, Background, f32, usize); 4] = [
        ("transparent", Background::Transparent, 0.0, 4),
        ("black", Background::Black, 1.0, 3),
        ("checker", Background::Checker, 0.0, 3),
        ("colour", Background::Color([0.2, 0.1, 0.05]), -1.0, 3),
    ];
    for (tag, background, exposure, nchannels) in cases {
        let path = dir.join(format!("{tag}.png"));
        write_preview(
            &path,
            &frame,
            &PreviewOptions {
                exposure,
                background,
            },
        )
        .unwrap();
        let info = oiio_info(&path);
        assert!(
            info.contains(&format!("64 x   48, {nchannels} channel, uint8 png")),
            "{info}"
        );
        let p = oiio_pixels(&path);
        let gain = exposure.exp2();
        let (want_in, want_out, want_alpha) = match background {
            Background::Transparent => (srgb(r / a), 0.0, Some((q(a), 0.0))),
            Background::Black => (srgb(r * gain), 0.0, None),
            Background::Checker => (srgb(r + (1.0 - a) * 0.132_868), 0.4, None),
            Background::Color(c) => (srgb((r + (1.0 - a) * c[0]) * gain), srgb(c[0] * gain), None),
        };
        assert!(
            (p["R"][&(px, py)] - q(want_in)).abs() < 1.5 / 255.0,
            "{tag} inside"
        );
        assert!(
            (p["R"][&(0, 0)] - q(want_out)).abs() < 1.5 / 255.0,
            "{tag} outside"
        );
        if let Some((inside, outside)) = want_alpha {
            assert_eq!(
                (p["A"][&(px, py)], p["A"][&(0, 0)]),
                (inside, outside),
                "{tag} alpha"
            );
        }
        if background == Background::Checker {
            assert!(
                (p["R"][&(16, 0)] - 0.6).abs() < 1.5 / 255.0,
                "second checker grey"
            );
        }
    }

    let mut no_alpha = Frame::new(4, 4);
    for c in ["R", "G", "B"] {
        no_alpha.add_channel(c, vec![0.5; 16]).unwrap();
    }
    let path = dir.join("no-alpha.png");
    let msg = write_preview(&path, &no_alpha, &PreviewOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains(&path.display().to_string()) && msg.contains('A'),
        "{msg}"
    );
    assert!(!path.exists());
    no_temp_files(&dir);
}
