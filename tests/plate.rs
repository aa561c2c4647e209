//! The plate: `--overscan` renders pixels beyond the image with the EXR's displayWindow
//! still the image (as exrheader reads the windows), the image's own pixels unchanged,
//! the header's camera the image's, pieces stitched and holdouts placed over the
//! overscan; a film back's pixel aspect ratio in `pixelAspectRatio`.

mod common;
use common::camera::{fixture, samples, scratch, world_to_camera};
use common::frames::{ok, refused};
use common::tools;
use exr::prelude::*;
use std::fs;
use std::path::Path;
use std::process::Command;

/// The lines of `exrheader FILE` that name `attribute`.
fn exrheader(file: &Path, attribute: &str) -> String {
    let out = Command::new("exrheader").arg(file).output().unwrap();
    assert!(out.status.success());
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter(|l| l.trim_start().starts_with(attribute))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Channel `name` of the EXR: its data window's origin and size, and its values.
fn channel(file: &Path, name: &str) -> ((i32, i32), (usize, usize), Vec<f32>) {
    let img = read_all_flat_layers_from_file(file).unwrap();
    let layer = &img.layer_data[0];
    let c = layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name.to_string() == name)
        .unwrap_or_else(|| panic!("{}: no {name}", file.display()));
    let values = match &c.sample_data {
        FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
        FlatSamples::F32(v) => v.clone(),
        FlatSamples::U32(v) => v.iter().map(|u| *u as f32).collect(),
    };
    let p = layer.attributes.layer_position;
    ((p.0, p.1), (layer.size.0, layer.size.1), values)
}

const VIEW: [&str; 6] = [
    "--res",
    "48x32",
    "--float",
    "--no-lights",
    "--quiet",
    "--seed",
];

fn render(dir: &Path, out: &str, extra: &[&str]) {
    let cloud = fixture("cloud.vdb");
    let mut args = vec!["render", &cloud, "-o", out];
    args.extend(VIEW);
    args.push("7");
    args.extend(extra);
    ok(dir, &args);
}

#[test]
fn overscan_widens_the_data_window_around_the_same_image() {
    need!(tools::EXRHEADER);
    let dir = scratch("overscan");
    fs::write(dir.join("shot.chan"), common::camera::CHAN).unwrap();
    for (name, camera) in [
        ("persp", vec![]),
        ("ortho", vec!["--camera", "ortho"]),
        ("chan", vec!["--camera-file", "shot.chan", "--frames", "2"]),
    ] {
        let (plain, wide) = (format!("{name}.exr"), format!("{name}_wide.exr"));
        render(&dir, &plain, &camera);
        let mut extra = camera.clone();
        extra.extend(["--overscan", "6,4"]);
        render(&dir, &wide, &extra);
        let (plain, wide) = (dir.join(plain), dir.join(wide));
        // OpenEXR's own reader: the display window is the 48×32 image, the data window
        // 6 pixels beyond it left and right, 4 above and below.
        assert!(
            exrheader(&wide, "displayWindow").contains("(0 0) - (47 31)"),
            "{}",
            exrheader(&wide, "displayWindow")
        );
        assert!(
            exrheader(&wide, "dataWindow").contains("(-6 -4) - (53 35)"),
            "{}",
            exrheader(&wide, "dataWindow")
        );
        // The image's pixels are the plain render's (the rays differ in their last
        // bits only).
        for c in ["A", "R", "Z"] {
            let (origin, size, v) = channel(&wide, c);
            assert_eq!((origin, size), ((-6, -4), (60, 40)));
            let (_, _, p) = channel(&plain, c);
            for y in 0..32 {
                for x in 0..48 {
                    let (a, b) = (p[y * 48 + x], v[(y + 4) * 60 + x + 6]);
                    assert!(
                        (a - b).abs() <= 1e-4 * a.abs().max(1.0),
                        "{name} {c} ({x}, {y}): {a} vs {b}"
                    );
                }
            }
        }
        // The header's camera is the image's: a compositor's NDC is the display window.
        assert_eq!(world_to_camera(&plain), world_to_camera(&wide));
        assert_eq!(
            exrheader(&plain, "worldToNDC"),
            exrheader(&wide, "worldToNDC")
        );
    }
    // The shot camera cuts the cloud at the image's edge: the overscan shows more of it.
    let (_, _, a) = channel(&dir.join("chan_wide.exr"), "A");
    let ring: f32 = (0..40)
        .flat_map(|y| (0..60).map(move |x| (x, y)))
        .filter(|&(x, y)| !(6..54).contains(&x) || !(4..36).contains(&y))
        .map(|(x, y)| a[y * 60 + x])
        .sum();
    assert!(ring > 0.1, "alpha in the overscan: {ring}");
    let cloud = fixture("cloud.vdb");
    for (value, needle) in [
        ("abc", "--overscan \"abc\" is not X or X,Y"),
        ("100", "is more than the 48x32 image itself"),
        ("-1,2", "--overscan \"-1,2\" is not X or X,Y"),
    ] {
        refused(
            &dir,
            &[
                "render",
                &cloud,
                "-o",
                "bad.exr",
                "--res",
                "48x32",
                "--overscan",
                value,
            ],
            needle,
        );
    }
}

#[test]
fn overscanned_pieces_stitch_to_the_whole_frame() {
    let dir = scratch("overscan-pieces");
    let wide = ["--overscan", "5,3"];
    render(&dir, "whole.exr", &wide);
    for piece in ["1/3", "2/3", "3/3"] {
        let mut extra = wide.to_vec();
        let out = format!("piece{}.exr", &piece[..1]);
        extra.extend(["--tile", piece]);
        render(&dir, &out, &extra);
    }
    ok(
        &dir,
        &[
            "stitch",
            "piece1.exr",
            "piece2.exr",
            "piece3.exr",
            "-o",
            "stitched.exr",
        ],
    );
    let (whole, stitched) = (dir.join("whole.exr"), dir.join("stitched.exr"));
    assert!(samples(&whole) == samples(&stitched));
    assert_eq!(
        channel(&stitched, "A").0,
        (-5, -3),
        "the stitched data window"
    );
}

#[test]
fn a_holdout_with_the_same_overscan_cuts_the_overscan_too() {
    // A CG render with the same overscan: its display window the image, its data window
    // the frame. Depth 0 everywhere holds the whole frame out, overscan included.
    let dir = scratch("overscan-holdout");
    let holdout = dir.join("cg.exr");
    let channels = SpecificChannels::build()
        .with_channel("Z")
        .with_pixel_fn(|_: Vec2<usize>| (0f32,));
    let layer = Layer::new(
        (58, 38),
        LayerAttributes {
            layer_position: Vec2(-5, -3),
            ..LayerAttributes::default()
        },
        Encoding::FAST_LOSSLESS,
        channels,
    );
    Image::new(
        ImageAttributes::new(IntegerBounds::from_dimensions((48, 32))),
        layer,
    )
    .write()
    .to_file(&holdout)
    .unwrap();
    render(
        &dir,
        "cut.exr",
        &[
            "--overscan",
            "5,3",
            "--holdout-depth",
            holdout.to_str().unwrap(),
        ],
    );
    let (_, size, a) = channel(&dir.join("cut.exr"), "A");
    assert_eq!(size, (58, 38));
    assert!(a.iter().all(|v| *v == 0.0), "held out everywhere");
    // Without the overscan the same holdout is another size: refused in one line.
    let cloud = fixture("cloud.vdb");
    let mut args = vec!["render", &cloud, "-o", "bad.exr", "--res", "40x30"];
    args.extend(["--holdout-depth", holdout.to_str().unwrap()]);
    refused(&dir, &args, "its image is 48x32, the render 40x30");
}

#[test]
fn a_film_backs_pixel_aspect_is_in_the_header() {
    need!(tools::EXRHEADER);
    let dir = scratch("pixel-aspect");
    fs::write(
        dir.join("anamorphic.toml"),
        format!(
            "input = {:?}\nres = \"32x24\"\nquiet = true\n[camera]\nfocal_length = 35.0\n\
             horizontal_aperture = 36.0\nvertical_aperture = 24.0\npixel_aspect = 2.0\n\
             translate = [0.0, 0.0, 6.0]\nrotate = [0.0, 0.0, 0.0]\n",
            fixture("cloud.vdb")
        ),
    )
    .unwrap();
    ok(&dir, &["render", "anamorphic.toml", "-o", "a.exr"]);
    render(&dir, "square.exr", &[]);
    let anamorphic = exrheader(&dir.join("a.exr"), "pixelAspectRatio");
    assert!(anamorphic.contains(" 2"), "{anamorphic}");
    let square = exrheader(&dir.join("square.exr"), "pixelAspectRatio");
    assert!(square.contains(" 1"), "{square}");
}
