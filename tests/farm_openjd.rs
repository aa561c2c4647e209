//! `murk farm openjd` end to end: the job template checked and run by `openjd`
//! (openjd-cli from PyPI, in /opt/murk-venv as .ci/run installs it, or MURK_OPENJD), its
//! frames compared exactly with direct renders; and what the farm command refuses.

mod common;
use common::frames::*;
use common::tools;

use std::fs;

#[test]
fn the_openjd_job_runs_and_its_frames_equal_direct_renders() {
    need!(tools::IDIFF, tools::OPENJD);
    for tiles in ["1", "3"] {
        let dir = scratch(&format!("openjd-{tiles}"));
        // The job lives at the project's root, above the cache and the renders.
        std::os::unix::fs::symlink(seq(""), dir.join("cache")).unwrap();
        fs::create_dir(dir.join("render")).unwrap();
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
            "--job",
            "job.yaml",
        ];
        args.extend(LOOK);
        ok(&dir, &args);
        let job: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(dir.join("job.yaml")).unwrap()).unwrap();
        assert_eq!(job["specificationVersion"], "jobtemplate-2023-09");
        let steps = job["steps"].as_array().unwrap();
        assert_eq!(steps[0]["name"], "Render");
        assert_eq!(steps[1]["name"], "Stitch");
        assert_eq!(steps[1]["dependencies"][0]["dependsOn"], "Render");
        let run = |args: &[&str]| {
            // From elsewhere: the defaults are relative to the template's folder.
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
        };
        let job_path = dir.join("job.yaml");
        let j = job_path.to_str().unwrap();
        run(&["check", j]);
        run(&["run", j, "--step", "Stitch", "--run-dependencies"]);
        for f in 2..=4 {
            same_image(
                &direct(&dir, f),
                &dir.join(format!("render/fluid_{f:04}.exr")),
            );
        }
        assert!(!dir.join("render/fluid_0001.exr").exists());
    }
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
    let cases: [(&[&str], &str); 4] = [
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
    ];
    for (extra, needle) in cases {
        let args: Vec<&str> = base.iter().chain(extra).copied().collect();
        refused(&dir, &args, needle);
    }
    assert!(!dir.join("job.yaml").exists());
}
