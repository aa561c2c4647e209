//! Hostile inputs (found by fuzzing): each ends with exit 0 or 2 within seconds, and a
//! refusal is one line naming the file or flag and the problem.

mod common;
use common::tools;

use exr::prelude::{FlatSamples, read_all_flat_layers_from_file};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn scratch(test: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("hostile-{}-{test}", std::process::id()));
    let _ = fs::remove_dir_all(&d);
    fs::create_dir_all(&d).unwrap();
    d
}

fn fixture(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
        .display()
        .to_string()
}

/// Runs murk in `dir`, killed after `limit` seconds (the test fails then): exit code
/// and stderr.
fn murk(dir: &Path, args: &[&str], limit: u64) -> (i32, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_murk"))
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(limit) {
            child.kill().unwrap();
            panic!("murk {args:?} still running after {limit} s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(!err.contains("panicked"), "murk {args:?}: {err}");
    (o.status.code().unwrap_or(-1), err)
}

/// A refusal: exit 2 with one line that says `want`.
fn refused(dir: &Path, args: &[&str], want: &str) -> String {
    let (code, err) = murk(dir, args, 20);
    assert_eq!(code, 2, "murk {args:?}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains(want), "murk {args:?}: {err}");
    err
}

/// A legacy VTK file of tetrahedra with point density 1.
fn write_tets(path: &Path, points: &[[f64; 3]], tets: &[[usize; 4]]) {
    let mut s = format!(
        "# vtk DataFile Version 2.0\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS {} double\n",
        points.len()
    );
    for p in points {
        s += &format!("{:?} {:?} {:?}\n", p[0], p[1], p[2]);
    }
    s += &format!("CELLS {} {}\n", tets.len(), tets.len() * 5);
    for t in tets {
        s += &format!("4 {} {} {} {}\n", t[0], t[1], t[2], t[3]);
    }
    s += &format!("CELL_TYPES {}\n", tets.len());
    s += &"10\n".repeat(tets.len());
    s += &format!(
        "POINT_DATA {}\nSCALARS density double 1\nLOOKUP_TABLE default\n",
        points.len()
    );
    s += &"1\n".repeat(points.len());
    fs::write(path, s).unwrap();
}

/// The unit cube at `o` with edge `e`, cut into five tetrahedra.
fn cube(path: &Path, o: [f64; 3], e: f64) {
    let points: Vec<[f64; 3]> = (0..8)
        .map(|c| {
            [
                o[0] + e * (c & 1) as f64,
                o[1] + e * ((c >> 1) & 1) as f64,
                o[2] + e * ((c >> 2) & 1) as f64,
            ]
        })
        .collect();
    let tets = [
        [0, 1, 2, 4],
        [1, 3, 2, 7],
        [1, 4, 5, 7],
        [2, 4, 6, 7],
        [1, 2, 4, 7],
    ];
    write_tets(path, &points, &tets);
}

fn alpha(path: &Path) -> Vec<f32> {
    let image = read_all_flat_layers_from_file(path).unwrap();
    let c = image.layer_data[0]
        .channel_data
        .list
        .iter()
        .find(|c| c.name.to_string() == "A")
        .expect("an A channel");
    match &c.sample_data {
        FlatSamples::F32(v) => v.clone(),
        FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
        FlatSamples::U32(_) => panic!("u32 alpha"),
    }
}

#[test]
fn meshes_of_no_or_tiny_extent_are_refused_not_a_panic() {
    let dir = scratch("extent");
    let cases: [(&str, [f64; 3], f64, &str); 4] = [
        (
            "coincident.vtk",
            [0.5; 3],
            0.0,
            "all 8 points are the same point",
        ),
        // Below one ULP of 0.5: every point reads as 0.5.
        (
            "sub_ulp.vtk",
            [0.5; 3],
            1e-17,
            "all 8 points are the same point",
        ),
        (
            "subnormal.vtk",
            [0.0; 3],
            1e-310,
            "murk takes meshes at least 1e-80 across",
        ),
        (
            "denormal_square.vtk",
            [0.0; 3],
            1e-200,
            "murk takes meshes at least 1e-80 across",
        ),
    ];
    for (name, o, e, want) in cases {
        cube(&dir.join(name), o, e);
        let err = refused(&dir, &["info", name], want);
        assert!(err.contains(name), "{err}");
        refused(
            &dir,
            &["render", name, "-o", "o.exr", "--res", "32x18"],
            want,
        );
    }
    cube(&dir.join("huge.vtk"), [0.0; 3], 1e100);
    refused(
        &dir,
        &["info", "huge.vtk"],
        "murk takes coordinates up to 1e80",
    );
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn a_mesh_far_from_the_origin_renders_as_it_does_at_the_origin() {
    let dir = scratch("far");
    // Every coordinate a multiple of 1/8: exact at 1e15 (one ULP there).
    let x0 = 1e15;
    cube(&dir.join("near.vtk"), [0.0; 3], 1.0);
    cube(&dir.join("far.vtk"), [x0, 0.0, 0.0], 1.0);
    let view = |x: f64| {
        [
            "--eye".to_string(),
            format!("{:?},2.5,4", x + 3.5),
            "--look-at".to_string(),
            format!("{:?},0.5,0.5", x + 0.5),
        ]
    };
    let mut images = Vec::new();
    for (name, x) in [("near", 0.0), ("far", x0)] {
        let (input, out, v) = (format!("{name}.vtk"), format!("{name}.exr"), view(x));
        let mut args = vec!["render", &input, "-o", &out, "--res", "32x18", "--float"];
        args.extend(["--no-lights", "--quiet"]);
        args.extend(v.iter().map(String::as_str));
        let (code, err) = murk(&dir, &args, 20);
        assert_eq!(code, 0, "{err}");
        images.push(alpha(&dir.join(&out)));
    }
    let (near, far) = (&images[0], &images[1]);
    assert!(near.iter().any(|&a| a > 0.5), "the cube is in view");
    let worst = near
        .iter()
        .zip(far)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-4, "alpha differs by {worst} at 1e15");
    // Framed by default: a needle to 1e18 and a point at 3e38 render.
    for (name, z) in [("needle.vtk", 1e18), ("point_3e38.vtk", 3e38)] {
        let points = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, z],
        ];
        write_tets(&dir.join(name), &points, &[[0, 1, 2, 3]]);
        let (code, err) = murk(&dir, &["render", name, "-o", "n.exr", "--res", "32x18"], 20);
        assert_eq!(code, 0, "{name}: {err}");
    }
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn path_tracing_ends_at_huge_extinction() {
    let dir = scratch("dense");
    let cloud = fixture("cloud.vdb");
    for args in [
        &["--sigma-s", "1e12,1e12,1e12"][..],
        &["--sigma-s", "1e38,1e38,1e38"],
        &["--sigma-s", "1e12,1,0.5"],
        &["--density-scale", "3e38"],
    ] {
        let mut all = vec![
            "render",
            &cloud,
            "-o",
            "p.exr",
            "--float",
            "--scattering",
            "path",
            "--spp",
            "1",
            "--res",
            "8x4",
            "--bounces",
            "100",
        ];
        all.extend(args);
        let (code, err) = murk(&dir, &all, 30);
        assert_eq!(code, 0, "{args:?}: {err}");
        // No transmittance over 1: light scattered off an albedo-1 cloud under a sun
        // of irradiance 6 stays within that.
        let image = read_all_flat_layers_from_file(dir.join("p.exr")).unwrap();
        for c in &image.layer_data[0].channel_data.list {
            if c.name.to_string() == "Z" {
                continue;
            }
            if let FlatSamples::F32(v) = &c.sample_data {
                assert!(
                    v.iter().all(|x| x.is_finite() && x.abs() <= 100.0),
                    "{args:?}: channel {} reaches {:?}",
                    c.name,
                    v.iter().fold(0.0f32, |a, b| a.max(b.abs()))
                );
            }
        }
    }
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn frame_patterns_wider_than_twelve_digits_are_refused() {
    let dir = scratch("patterns");
    let cloud = fixture("cloud.vdb");
    for (out, pattern) in [
        ("o_%0999d.exr", "%0999d"),
        ("o.$F99.exr", "$F99"),
        ("o_################.exr", "################"),
    ] {
        let args = ["render", &cloud, "-o", out, "--frames", "1", "--res", "8x4"];
        refused(
            &dir,
            &args,
            &format!("-o {out}: the frame pattern {pattern} asks for more than 12 digits"),
        );
    }
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn double_braces_never_reach_an_openjd_template() {
    let dir = scratch("braces");
    std::os::unix::fs::symlink(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/seq"),
        dir.join("cache"),
    )
    .unwrap();
    let base = [
        "farm",
        "openjd",
        "cache/fluid_####.vdb",
        "--frames",
        "1-2",
        "--job",
        "job.yaml",
    ];
    for extra in [
        ["-o", "o_{{Param.Murk}}_####.exr"],
        ["--density-grid", "{{Task.Param.Frame}}"],
    ] {
        let mut args = base.to_vec();
        if extra[0] != "-o" {
            args.extend(["-o", "o_####.exr"]);
        }
        args.extend(extra);
        refused(
            &dir,
            &args,
            "would be read by Open Job Description as an expression",
        );
        assert!(!dir.join("job.yaml").exists());
    }
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn temperature_offset_must_be_finite() {
    let dir = scratch("offset");
    let pyro = fixture("pyro.vdb");
    for v in ["NaN", "inf", "-inf"] {
        let args = [
            "render",
            &pyro,
            "-o",
            "o.exr",
            "--res",
            "8x4",
            "--temperature-offset",
            v,
        ];
        let err = refused(&dir, &args, "must be a finite number");
        assert!(err.contains("--temperature-offset"), "{err}");
    }
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn a_vec3_density_is_named_as_such() {
    need!(tools::PYOPENVDB);
    let dir = scratch("vec3");
    let path = dir.join("vec3_density.vdb");
    let script = "import pyopenvdb as vdb, sys\ng = vdb.Vec3SGrid()\ng.name = 'density'\ng.copyFromArray(__import__('numpy').ones((4, 4, 4, 3), dtype='float32'))\nvdb.write(sys.argv[1], grids=[g])\n";
    let o = tools::command(&tools::PYOPENVDB)
        .args(["-c", script])
        .arg(&path)
        .output()
        .expect("/usr/bin/python3 with pyopenvdb (Debian package python3-openvdb) is required");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (code, _) = murk(&dir, &["info", "vec3_density.vdb"], 20);
    assert_eq!(code, 0);
    let err = refused(
        &dir,
        &["render", "vec3_density.vdb", "-o", "o.exr", "--res", "8x4"],
        "grid \"density\" holds vec3 values (vec3s), but a density must be a float grid",
    );
    assert!(err.contains("the file has no float grid"), "{err}");
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn failed_shadow_bakes_name_the_output_not_its_temporary_file() {
    let dir = scratch("bake");
    let (empty, cloud) = (fixture("empty.vdb"), fixture("cloud.vdb"));
    for args in [
        vec!["bake-shadows", &*empty, "-o", "sh.vdb"],
        vec![
            "bake-shadows",
            &*cloud,
            "-o",
            "sh.vdb",
            "--light",
            "point:1e308,0,0",
        ],
    ] {
        let (code, err) = murk(&dir, &args, 20);
        assert_eq!(code, 2, "{err}");
        assert!(err.starts_with("murk: error: sh.vdb: "), "{err}");
        assert!(!err.contains("tmp"), "{err}");
        assert!(!dir.join("sh.vdb").exists());
    }
    let _ = fs::remove_dir_all(&dir);
}
