//! The shot's camera from files: USD stages read as Pixar's usd-core reads them, a Nuke
//! `.chan` of the same camera giving the same image bit for bit, the scene file's keyed
//! `[camera]` table, a moving camera over a static cache writing its camera into each
//! frame's header, pieces and farm jobs carrying it, and bad camera files refused in one
//! line. Cycles' image through the same camera: `camera_cycles.rs`.

mod common;
use common::camera::{
    CHAN, author_stages, fixture, render_frames, samples, scratch, world_to_camera,
};
use common::frames::{murk, ok, refused, same_image};
use common::tools;
use glam::{DMat4, DVec3};
use murk::scene::film::FilmBack;
use murk::scene::shot::{CameraTrack, FileRequest, RotationOrder};
use serde_json::Value;
use std::fs;
use std::path::Path;

fn open(path: &Path) -> CameraTrack {
    CameraTrack::open(&FileRequest {
        path: path.to_path_buf(),
        prim: None,
        rotation_order: RotationOrder::Zxy,
        film: FilmBack::default(),
    })
    .unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn usd_cameras_read_as_usd_core_reads_them() {
    need!(tools::USD_CORE);
    let dir = scratch("usd-core");
    author_stages(&dir);
    for (stage, json) in [
        ("yup.usda", "yup.json"),
        ("zup.usdc", "zup.json"),
        ("yup.usdz", "yup.json"),
    ] {
        let reference: Value =
            serde_json::from_str(&fs::read_to_string(dir.join(json)).unwrap()).unwrap();
        let track = open(&dir.join(stage));
        let CameraTrack::Usd(usd) = &track else {
            panic!("{stage} not read as USD")
        };
        assert_eq!(usd.up_z, reference["up_axis"] == "Z", "{stage}");
        assert_eq!(
            usd.meters_per_unit,
            reference["meters_per_unit"].as_f64().unwrap()
        );
        assert_eq!(track.span(), Some((1.0, 3.0)), "{stage}");
        for f in reference["frames"].as_array().unwrap() {
            let frame = f["frame"].as_f64().unwrap();
            let got = track.at(frame).unwrap();
            let num = |k: &str| f[k].as_f64().unwrap();
            let film = got.film;
            for (ours, theirs) in [
                (film.focal_length, num("focal_length")),
                (film.horizontal_aperture, num("horizontal_aperture")),
                (film.vertical_aperture, num("vertical_aperture")),
                (film.horizontal_offset, num("horizontal_offset")),
                (film.vertical_offset, num("vertical_offset")),
                (film.near, num("near")),
                (film.far, num("far")),
            ] {
                assert!(
                    (ours - theirs).abs() <= 1e-6 * theirs.abs().max(1.0),
                    "{stage} frame {frame}: {ours} vs {theirs}"
                );
            }
            assert_eq!(film.orthographic, f["orthographic"].as_bool().unwrap());
            // usd-core's matrix is row-vector, row by row: glam's columns.
            let rows: Vec<f64> = f["local_to_world"]
                .as_array()
                .unwrap()
                .iter()
                .flat_map(|r| r.as_array().unwrap().iter().map(|v| v.as_f64().unwrap()))
                .collect();
            let theirs = DMat4::from_cols_slice(&rows);
            let err = (got.camera_to_world - theirs)
                .to_cols_array()
                .iter()
                .fold(0f64, |m, v| m.max(v.abs()));
            assert!(
                err < 1e-9,
                "{stage} frame {frame}: {err}\n{:?}\n{theirs:?}",
                got.camera_to_world
            );
            assert_eq!(
                got.held,
                !(1.0..=3.0).contains(&frame),
                "{stage} frame {frame}"
            );
        }
    }
}

#[test]
fn a_chan_of_the_usd_camera_gives_the_same_images_bit_for_bit() {
    need!(tools::USD_CORE, tools::IDIFF);
    let dir = scratch("chan-usd");
    author_stages(&dir);
    for name in ["yup", "zup"] {
        let stage = dir.join(if name == "yup" {
            "yup.usda"
        } else {
            "zup.usdc"
        });
        let usd = render_frames(
            &dir,
            &fixture("cloud.vdb"),
            &format!("{name}_usd"),
            &["--camera-file", stage.to_str().unwrap()],
        );
        let scene = dir.join(format!("{name}_chan.toml"));
        let chan = render_frames(&dir, scene.to_str().unwrap(), &format!("{name}_chan"), &[]);
        for (a, b) in usd.iter().zip(&chan) {
            same_image(a, b);
            assert_eq!(world_to_camera(a), world_to_camera(b), "{}", a.display());
        }
        // The camera moves: each frame has its own.
        assert_ne!(world_to_camera(&usd[0]), world_to_camera(&usd[2]));
    }
}

#[test]
fn a_moving_camera_over_a_static_cache_writes_each_frame_with_its_camera() {
    let dir = scratch("moving");
    fs::write(dir.join("shot.chan"), CHAN).unwrap();
    let frames = render_frames(
        &dir,
        &fixture("cloud.vdb"),
        "m",
        &["--camera-file", "shot.chan"],
    );
    let rows: Vec<Vec<f64>> = CHAN
        .lines()
        .map(|l| l.split(' ').map(|v| v.parse().unwrap()).collect())
        .collect();
    for (exr, row) in frames.iter().zip(&rows) {
        // Closed form: world → camera is the inverse of translate · Ry·Rx·Rz.
        let r = glam::DMat3::from_rotation_y(row[5].to_radians())
            * glam::DMat3::from_rotation_x(row[4].to_radians())
            * glam::DMat3::from_rotation_z(row[6].to_radians());
        let c2w = DMat4::from_translation(DVec3::new(row[1], row[2], row[3])) * DMat4::from_mat3(r);
        let want = c2w.inverse().as_mat4().to_cols_array();
        let got = world_to_camera(exr);
        for (g, w) in got.iter().zip(want) {
            assert!(
                (g - w).abs() < 1e-5,
                "{}: {got:?} vs {want:?}",
                exr.display()
            );
        }
    }
    assert_ne!(samples(&frames[0]), samples(&frames[2]), "the camera moved");
    // A frame past the .chan's last holds it, with a note.
    let out = murk(
        &dir,
        &[
            "render",
            &fixture("cloud.vdb"),
            "-o",
            "held.exr",
            "--frames",
            "5",
            "--res",
            "48x32",
            "--camera-file",
            "shot.chan",
            "--stats",
            "held.json",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stats = fs::read_to_string(dir.join("held.json")).unwrap();
    assert!(
        stats.contains("outside the camera's frames 1 to 3"),
        "{stats}"
    );
    assert_eq!(
        world_to_camera(&dir.join("held.exr")),
        world_to_camera(&frames[2])
    );
}

#[test]
fn a_keyed_camera_table_is_the_same_camera_as_its_chan() {
    let dir = scratch("table");
    fs::write(dir.join("shot.chan"), CHAN).unwrap();
    let film = "horizontal_aperture = 24.0\nvertical_aperture = 16.0\nhorizontal_aperture_offset = 1.2\nclipping_range = [0.1, 1000.0]\n";
    let vdb = fixture("cloud.vdb");
    fs::write(
        dir.join("chan.toml"),
        format!("input = \"{vdb}\"\ncamera_file = \"shot.chan\"\nfilm_fit = \"horizontal\"\n[camera]\n{film}"),
    )
    .unwrap();
    // The same camera as keys: the focal length each vfov gives on a 16 mm gate.
    let mut keys = String::new();
    for l in CHAN.lines() {
        let v: Vec<f64> = l.split(' ').map(|x| x.parse().unwrap()).collect();
        let focal = 8.0 / (v[7].to_radians() / 2.0).tan();
        keys.push_str(&format!(
            "[[camera.keys]]\nframe = {}\ntranslate = [{:?}, {:?}, {:?}]\nrotate = [{:?}, {:?}, {:?}]\nfocal_length = {focal:?}\n",
            v[0], v[1], v[2], v[3], v[4], v[5], v[6]
        ));
    }
    fs::write(
        dir.join("keys.toml"),
        format!("input = \"{vdb}\"\n[camera]\n{film}{keys}"),
    )
    .unwrap();
    let a = render_frames(&dir, dir.join("chan.toml").to_str().unwrap(), "chan", &[]);
    let b = render_frames(&dir, dir.join("keys.toml").to_str().unwrap(), "keys", &[]);
    for (a, b) in a.iter().zip(&b) {
        assert_eq!(world_to_camera(a), world_to_camera(b));
        assert!(samples(a) == samples(b), "{} {}", a.display(), b.display());
    }
}

const STAGE: &str = r#"#usda 1.0
(
    upAxis = "Y"
)
def Xform "World"
{
    double3 xformOp:translate = (0, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def Camera "Cam"
    {
        float focalLength = 35
        float horizontalAperture = 24
        float verticalAperture = 16
        double3 xformOp:translate = (0, 0, 7)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
}
"#;

#[test]
fn bad_camera_files_are_refused_in_one_line() {
    let dir = scratch("bad");
    let vdb = fixture("cloud.vdb");
    let render = |file: &str, extra: &[&str], needle: &str| {
        let mut args = vec![
            "render",
            vdb.as_str(),
            "-o",
            "x.exr",
            "--res",
            "16x16",
            "--camera-file",
            file,
        ];
        args.extend(extra);
        refused(&dir, &args, needle);
    };
    fs::write(dir.join("good.usda"), STAGE).unwrap();
    ok(
        &dir,
        &[
            "render",
            &vdb,
            "-o",
            "good.exr",
            "--res",
            "16x16",
            "--camera-file",
            "good.usda",
        ],
    );
    fs::write(
        dir.join("garbage.usda"),
        "#usda 1.0\ndef Xform \"W\" {{{ nonsense\n",
    )
    .unwrap();
    render(
        "garbage.usda",
        &[],
        "garbage.usda: not a USD stage murk can read",
    );
    let two = STAGE.replace(
        "    def Camera \"Cam\"",
        "    def Camera \"Other\"\n    {\n    }\n    def Camera \"Cam\"",
    );
    fs::write(dir.join("two.usda"), two).unwrap();
    render(
        "two.usda",
        &[],
        "2 cameras; choose one with --camera-prim: /World/Other, /World/Cam",
    );
    ok(
        &dir,
        &[
            "render",
            &vdb,
            "-o",
            "two.exr",
            "--res",
            "16x16",
            "--camera-file",
            "two.usda",
            "--camera-prim",
            "/World/Cam",
        ],
    );
    render(
        "good.usda",
        &["--camera-prim", "/World"],
        "prim /World is not a camera (a Xform)",
    );
    render(
        "good.usda",
        &["--camera-prim", "/Nowhere"],
        "prim /Nowhere is not a camera",
    );
    fs::write(
        dir.join("zero.usda"),
        STAGE.replace("horizontalAperture = 24", "horizontalAperture = 0"),
    )
    .unwrap();
    render(
        "zero.usda",
        &[],
        "the horizontal aperture 0 must be a positive number",
    );
    fs::write(
        dir.join("neg.usda"),
        STAGE.replace("focalLength = 35", "focalLength = -35"),
    )
    .unwrap();
    render(
        "neg.usda",
        &[],
        "the focal length -35 must be a positive number",
    );
    fs::write(
        dir.join("flat.usda"),
        STAGE.replace(
            "double3 xformOp:translate = (0, 0, 0)\n    uniform token[] xformOpOrder = [\"xformOp:translate\"]",
            "float3 xformOp:scale = (1, 0, 1)\n    uniform token[] xformOpOrder = [\"xformOp:scale\"]",
        ),
    )
    .unwrap();
    render("flat.usda", &[], "singular");
    // A binary stage cut short and filled with nonsense after its magic.
    let mut usdc = b"PXR-USDC\x00\x08\x00\x00\x00\x00\x00\x00".to_vec();
    usdc.extend(std::iter::repeat_n(0xffu8, 200));
    fs::write(dir.join("broken.usdc"), usdc).unwrap();
    render("broken.usdc", &[], "broken.usdc: ");
    fs::write(dir.join("short.chan"), "1 0 0 5 0 0\n").unwrap();
    render("short.chan", &[], "short.chan: line 1: 6 columns");
    fs::write(dir.join("shot.fbx"), "").unwrap();
    render("shot.fbx", &[], "not a camera file murk reads");
    render("missing.usda", &[], "missing.usda");
    fs::write(dir.join("shot.chan"), CHAN).unwrap();
    render(
        "shot.chan",
        &["--camera-rotation-order", "zxz"],
        "--camera-rotation-order",
    );
    render("shot.chan", &["--eye", "0,0,5"], "--eye");
    refused(
        &dir,
        &["render", &vdb, "-o", "x.exr", "--camera-prim", "/World/Cam"],
        "--camera-prim needs a camera",
    );
}

#[test]
fn pieces_of_a_shot_camera_stitch_with_its_camera() {
    let dir = scratch("stitch");
    fs::write(dir.join("shot.chan"), CHAN).unwrap();
    let vdb = fixture("cloud.vdb");
    let base = [
        "render",
        &vdb,
        "--res",
        "48x32",
        "--camera-file",
        "shot.chan",
        "--frames",
        "2",
        "--quiet",
    ];
    let with = |extra: &[&str]| {
        let mut a = base.to_vec();
        a.extend(extra);
        ok(&dir, &a);
    };
    with(&["-o", "whole.exr"]);
    with(&["--tile", "1/2", "-o", "piece1.exr"]);
    with(&["--tile", "2/2", "-o", "piece2.exr"]);
    ok(
        &dir,
        &["stitch", "piece1.exr", "piece2.exr", "-o", "stitched.exr"],
    );
    let (whole, stitched) = (dir.join("whole.exr"), dir.join("stitched.exr"));
    assert_eq!(world_to_camera(&whole), world_to_camera(&stitched));
    assert!(samples(&whole) == samples(&stitched));
}

#[test]
fn a_farm_job_passes_the_camera_file_to_its_tasks() {
    need!(tools::OPENJD);
    let dir = scratch("farm");
    fs::create_dir_all(dir.join("cam")).unwrap();
    fs::write(dir.join("cam/shot.chan"), CHAN).unwrap();
    // The job lives above every path it names.
    std::os::unix::fs::symlink(fixture("cloud.vdb"), dir.join("cloud.vdb")).unwrap();
    let vdb = "cloud.vdb".to_string();
    let job_args = [
        "farm",
        "openjd",
        &vdb,
        "--frames",
        "1-2",
        "--tiles",
        "2",
        "--res",
        "48x32",
        "--camera-file",
        "cam/shot.chan",
        "-o",
        "render/f_####.exr",
        "--job",
        "job.yaml",
    ];
    ok(&dir, &job_args);
    let job = fs::read_to_string(dir.join("job.yaml")).unwrap();
    assert!(job.contains("CameraFile"), "{job}");
    let j = dir.join("job.yaml");
    let out = tools::command(&tools::OPENJD)
        .args([
            "run",
            j.to_str().unwrap(),
            "--step",
            "Stitch",
            "--run-dependencies",
        ])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let direct = render_frames(&dir, &vdb, "direct", &["--camera-file", "cam/shot.chan"]);
    for f in 1..=2 {
        let farm = dir.join(format!("render/f_{f:04}.exr"));
        assert_eq!(world_to_camera(&farm), world_to_camera(&direct[f - 1]));
        assert!(samples(&farm) == samples(&direct[f - 1]), "frame {f}");
    }
}

#[test]
fn a_stage_in_other_units_is_scaled_into_the_volumes_units() {
    need!(tools::USD_CORE);
    let dir = scratch("units");
    author_stages(&dir);
    // The stage is in centimetres (metersPerUnit 0.01), taken to be the cloud's units.
    let cloud = fixture("cloud.vdb");
    let render = |name: &str, extra: &[&str]| {
        let out = dir.join(format!("{name}.exr"));
        let mut args = vec![
            "render",
            &cloud,
            "-o",
            out.to_str().unwrap(),
            "--res",
            "16x12",
            "--frames",
            "2",
            "--camera-file",
            "yup.usda",
            "--quiet",
        ];
        args.extend(extra);
        ok(&dir, &args);
        out
    };
    let plain = render("plain", &[]);
    // The volumes in the stage's own units: nothing changes, bit for bit.
    let same = render("same", &["--scene-meters-per-unit", "0.01"]);
    assert!(samples(&plain) == samples(&same));
    // Volumes in tenths of a millimetre: the camera is 100 times as far in their units.
    let far = render("far", &["--scene-meters-per-unit", "0.0001"]);
    let (a, b) = (world_to_camera(&plain), world_to_camera(&far));
    // Row-vector m44f: rows 0–2 are the rotation (unchanged), row 3 the translation.
    for i in 0..12 {
        assert!((a[i] - b[i]).abs() < 1e-6, "rotation {i}: {a:?} vs {b:?}");
    }
    for i in 12..15 {
        assert!(
            (b[i] - 100.0 * a[i]).abs() <= 1e-5 * (100.0 * a[i]).abs().max(1.0),
            "translation {i}: {} vs 100 × {}",
            b[i],
            a[i]
        );
    }
    fs::write(dir.join("shot.chan"), CHAN).unwrap();
    for (args, needle) in [
        (
            vec!["--camera-file", "shot.chan", "--scene-meters-per-unit", "1"],
            "a .chan or a [camera] table has no units",
        ),
        (
            vec!["--camera-file", "yup.usda", "--scene-meters-per-unit", "-1"],
            "must be a positive number of metres",
        ),
        (
            vec!["--scene-meters-per-unit", "1"],
            "--scene-meters-per-unit needs a camera",
        ),
    ] {
        let mut all = vec!["render", &cloud, "-o", "bad.exr", "--res", "8x8"];
        all.extend(args);
        refused(&dir, &all, needle);
    }
}
