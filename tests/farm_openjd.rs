//! `murk farm openjd` end to end: the job template checked and run by `openjd`
//! (openjd-cli from PyPI, in /opt/murk-venv as .ci/run installs it, or MURK_OPENJD), its
//! frames compared exactly with direct renders; and what the farm command refuses.

mod common;
use common::frames::*;
use common::tools;

use std::fs;
use std::path::Path;

/// Runs `openjd` from elsewhere (the defaults are relative to the template's folder);
/// fails the test when it fails.
fn run_openjd(args: &[&str]) {
    let out = tools::command(&tools::OPENJD)
        .current_dir(std::env::temp_dir())
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "openjd {}: {}{}",
        args.join(" "),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The largest difference of two PNGs' 8-bit codes (same size required).
fn png_difference(a: &Path, b: &Path) -> u8 {
    let (a, b) = (
        image::open(a).unwrap().to_rgba8(),
        image::open(b).unwrap().to_rgba8(),
    );
    assert_eq!(a.dimensions(), b.dimensions());
    a.as_raw()
        .iter()
        .zip(b.as_raw())
        .map(|(x, y)| x.abs_diff(*y))
        .max()
        .unwrap_or(0)
}

#[test]
fn the_openjd_job_runs_and_its_frames_equal_direct_renders() {
    need!(tools::IDIFF, tools::OPENJD);
    for tiles in ["1", "3"] {
        let dir = scratch(&format!("openjd-{tiles}"));
        // The job lives at the project's root, above the cache and the renders; the
        // renders' folder does not exist yet: the tasks make it.
        std::os::unix::fs::symlink(seq(""), dir.join("cache")).unwrap();
        let mut args = vec![
            "farm",
            "openjd",
            "cache/fluid_####.vdb",
            "--frames",
            "2-4",
            "--tiles",
            tiles,
            "-o",
            "render/fluid_####.exr",
            "--preview",
            "render/fluid_####.png",
            "--job",
            "job.yaml",
            // The template says --quiet itself: given again it must not be twice.
            "--quiet",
        ];
        args.extend(LOOK);
        ok(&dir, &args);
        let job: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(dir.join("job.yaml")).unwrap()).unwrap();
        assert_eq!(job["specificationVersion"], "jobtemplate-2023-09");
        let steps: Vec<&str> = job["steps"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s["name"].as_str().unwrap())
            .collect();
        let last = if tiles == "1" {
            // Whole frames: the render writes each frame; nothing to stitch.
            assert_eq!(steps, ["Render"]);
            "Render"
        } else {
            // One shadow bake a frame, shared by its pieces, then the pieces, then the
            // stitch with the preview.
            assert_eq!(steps, ["Bake", "Render", "Stitch"]);
            assert_eq!(job["steps"][1]["dependencies"][0]["dependsOn"], "Bake");
            assert_eq!(job["steps"][2]["dependencies"][0]["dependsOn"], "Render");
            "Stitch"
        };
        assert_eq!(
            job["steps"][0]["parameterSpace"]["taskParameterDefinitions"][0]["range"],
            "2-4"
        );
        let job_path = dir.join("job.yaml");
        let j = job_path.to_str().unwrap();
        run_openjd(&["check", j]);
        run_openjd(&["run", j, "--step", last, "--run-dependencies"]);
        for f in 2..=4 {
            same_image(
                &direct(&dir, f),
                &dir.join(format!("render/fluid_{f:04}.exr")),
            );
            // The preview of the stitched frame is the whole render's (up to the
            // rounding of half-float storage).
            let png = dir.join(format!("direct_{f}.png"));
            let input = seq(&format!("fluid_{f:04}.vdb"));
            let mut direct_args = vec![
                "render",
                input.to_str().unwrap(),
                "-o",
                "scratch.exr",
                "--preview",
                png.to_str().unwrap(),
                "--quiet",
            ];
            direct_args.extend(LOOK);
            ok(&dir, &direct_args);
            let got = dir.join(format!("render/fluid_{f:04}.png"));
            assert!(png_difference(&png, &got) <= 1, "{}", got.display());
        }
        assert!(!dir.join("render/fluid_0001.exr").exists());
        // Nothing but the frames and their previews is left beside them.
        let mut left: Vec<String> = fs::read_dir(dir.join("render"))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        let want: Vec<String> = (2..=4)
            .flat_map(|f| [format!("fluid_{f:04}.exr"), format!("fluid_{f:04}.png")])
            .collect();
        assert_eq!(left, want);
    }
}

/// Frames are a range expression: a list holds at most 1,024 values, and a job of
/// 1,100 frames was refused by `openjd check`.
#[test]
fn more_than_1024_frames_make_a_valid_job() {
    need!(tools::OPENJD);
    let dir = scratch("openjd-many");
    std::os::unix::fs::symlink(seq(""), dir.join("cache")).unwrap();
    ok(
        &dir,
        &[
            "farm",
            "openjd",
            "cache/fluid_####.vdb",
            "--frames",
            "1001-2100,2200-2300x10",
            "--tiles",
            "2",
            "-o",
            "render/fluid_####.exr",
            "--job",
            "job.yaml",
        ],
    );
    let job: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(dir.join("job.yaml")).unwrap()).unwrap();
    let frames = &job["steps"][0]["parameterSpace"]["taskParameterDefinitions"][0]["range"];
    assert_eq!(frames, "1001-2100,2200-2300:10");
    let job_path = dir.join("job.yaml");
    run_openjd(&["check", job_path.to_str().unwrap()]);
}

#[test]
fn farm_refuses_what_it_cannot_express() {
    let dir = scratch("farm-bad");
    let input = seq("fluid_####.vdb");
    let i = input.to_str().unwrap();
    refused(
        &dir,
        &[
            "farm",
            "openjd",
            i,
            "--frames",
            "1-2",
            "-o",
            "o_####.exr",
            "--job",
            "job.yaml",
        ],
        "outside",
    );
    std::os::unix::fs::symlink(seq(""), dir.join("cache")).unwrap();
    let base = [
        "farm",
        "openjd",
        "cache/fluid_####.vdb",
        "--job",
        "job.yaml",
    ];
    let cases: [(&[&str], &str); 6] = [
        (&["--frames", "1-2", "-o", "o.exr"], "put a frame pattern"),
        (&["--frames", "2-1", "-o", "o_####.exr"], "reversed"),
        (
            &["--frames", "1-2", "-o", "o_####.exr", "--tile", "1/2"],
            "--tiles",
        ),
        (
            &["--frames", "1-2", "-o", "o_####.exr", "--tiles", "0"],
            "--tiles 0",
        ),
        (
            &[
                "--frames",
                "1-2",
                "-o",
                "o_####.exr",
                "--tiles",
                "2",
                "--stats",
                "s_####.json",
            ],
            "--stats describes a whole render",
        ),
        (
            &["--frames", "1-2", "-o", "o_####.png"],
            "murk writes OpenEXR",
        ),
    ];
    for (extra, needle) in cases {
        let args: Vec<&str> = base.iter().chain(extra).copied().collect();
        refused(&dir, &args, needle);
    }
    assert!(!dir.join("job.yaml").exists());
}

/// The Bake step is there only when `murk bake-shadows` makes the map each piece would
/// bake: not for an environment light (bake-shadows refuses one), marched shadows or a
/// tolerance the render chooses.
#[test]
fn a_shared_bake_only_where_bake_shadows_makes_the_pieces_map() {
    let dir = scratch("farm-bake");
    std::os::unix::fs::symlink(seq(""), dir.join("cache")).unwrap();
    let cases: [(&[&str], bool); 5] = [
        (&[], true),
        (&["--light", "point:0.3,1.5,0.5"], true),
        (&["--light", "env:1,1,1", "--scattering", "path"], false),
        (&["--shadows", "march"], false),
        (&["--max-error", "1e-2"], false),
    ];
    for (extra, bake) in cases {
        let mut args = vec![
            "farm",
            "openjd",
            "cache/fluid_####.vdb",
            "--frames",
            "1-2",
            "--tiles",
            "2",
            "-o",
            "render/fluid_####.exr",
            "--job",
            "job.yaml",
        ];
        args.extend(extra);
        ok(&dir, &args);
        let job: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(dir.join("job.yaml")).unwrap()).unwrap();
        let first = job["steps"][0]["name"].as_str().unwrap().to_string();
        assert_eq!(first == "Bake", bake, "{extra:?}: {first}");
    }
}
