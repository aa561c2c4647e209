//! `--scattering`, `--bounces` and `--light env:…` as a user meets them: each mode
//! accepts only what it can do, and refuses the rest in one line with exit code 2
//! before anything is written; the scene file's `scattering`, `bounces` and `env:`
//! lights are read as the flags are.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

const MURK: &str = env!("CARGO_BIN_EXE_murk");

fn fixture(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
        .to_str()
        .unwrap()
        .to_owned()
}

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("scattering-cli-{name}"));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs `murk render INPUT -o DIR/x.exr --res 32x18 FLAGS`, expects exit code 2 and one
/// stderr line containing every needle, and nothing written. Returns the line.
fn refused(name: &str, input: &str, flags: &[&str], needles: &[&str]) -> String {
    let dir = scratch(name);
    let out = dir.join("x.exr");
    let o = Command::new(MURK)
        .args([
            "render",
            input,
            "-o",
            out.to_str().unwrap(),
            "--res",
            "32x18",
        ])
        .args(flags)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    let shown = format!("murk render {input} {}", flags.join(" "));
    assert_eq!(o.status.code(), Some(2), "`{shown}`: {err}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "`{shown}`: stderr is not one line: {err}");
    assert!(lines[0].starts_with("murk: error: "), "`{shown}`: {err}");
    for n in needles {
        assert!(
            lines[0].to_lowercase().contains(&n.to_lowercase()),
            "`{shown}`: no `{n}` in: {err}"
        );
    }
    assert!(
        !out.exists(),
        "`{shown}` failed but wrote {}",
        out.display()
    );
    lines[0].to_owned()
}

#[test]
fn single_scattering_refuses_an_environment_light() {
    refused(
        "env-single",
        &fixture("cloud.vdb"),
        &["--scattering", "single", "--light", "env:1,1,1:1"],
        &["env", "--scattering path"],
    );
}

#[test]
fn bounces_out_of_range_or_beyond_single_scattering_are_refused() {
    let cloud = fixture("cloud.vdb");
    refused("bounces-0", &cloud, &["--bounces", "0"], &["--bounces 0"]);
    refused(
        "bounces-huge",
        &cloud,
        &["--bounces", "1000001"],
        &["--bounces 1000001"],
    );
    refused(
        "bounces-single",
        &cloud,
        &["--scattering", "single", "--bounces", "2"],
        &["--bounces 2", "single"],
    );
}

#[test]
fn malformed_environment_lights_are_refused() {
    let cloud = fixture("cloud.vdb");
    for (i, bad) in ["env:1,1", "env:1,1,1:-2", "env:1,1,1:x", "env:-1,0,0"]
        .into_iter()
        .enumerate()
    {
        refused(&format!("env-bad-{i}"), &cloud, &["--light", bad], &[bad]);
    }
    refused(
        "env-twice",
        &cloud,
        &["--light", "env:1,1,1", "--light", "env:0,0,1"],
        &["one environment light"],
    );
}

#[test]
fn unknown_scattering_mode_is_refused() {
    refused(
        "mode-bogus",
        &fixture("cloud.vdb"),
        &["--scattering", "double"],
        &["double", "--scattering"],
    );
}

/// The scene file's keys reach the plan: `bounces = 2` with `scattering = "single"` is
/// the same contradiction as on the command line, and an `env:` light there is refused
/// by single scattering as `--light env:` is.
#[test]
fn scene_file_keys_are_read() {
    let dir = scratch("scene-src");
    let scene = dir.join("scene.toml");
    fs::write(
        &scene,
        format!(
            "input = \"{}\"\nscattering = \"single\"\nbounces = 2\n",
            fixture("cloud.vdb")
        ),
    )
    .unwrap();
    refused(
        "scene-bounces",
        scene.to_str().unwrap(),
        &[],
        &["scene.toml", "`bounces` 2"],
    );
    fs::write(
        &scene,
        format!(
            "input = \"{}\"\n[[lights]]\nname = \"sky\"\nspec = \"env:0.5,0.6,1:2\"\n",
            fixture("cloud.vdb")
        ),
    )
    .unwrap();
    refused(
        "scene-env",
        scene.to_str().unwrap(),
        &[],
        &["scene.toml", "sky", "`scattering` path"],
    );
}

/// The fast approximation's lattice has no environment light: one line, not a silent
/// render without it (the default mode, so no flag needed).
#[test]
fn fast_refuses_an_environment_light() {
    refused(
        "fast-env",
        &fixture("cloud.vdb"),
        &["--light", "env:1,1,1:1"],
        &["env", "fast", "--scattering path"],
    );
}

/// The path tracer has no ground plane: asking for one is refused, not ignored.
#[test]
fn path_refuses_a_ground_plane() {
    refused(
        "path-ground",
        &fixture("cloud.vdb"),
        &["--scattering", "path", "--ground", "-1"],
        &["--ground", "path tracer"],
    );
}
