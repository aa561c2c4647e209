//! `murk check-stability` and `murk converge` end to end: exit status, the files they
//! write, and that those parse and hold finite numbers that say what they should.

mod common;

use common::examples;
use serde_json::Value;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const MURK: &str = env!("CARGO_BIN_EXE_murk");

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("report-{name}"));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

fn murk(args: &[&str]) -> Output {
    Command::new(MURK).args(args).output().unwrap()
}

fn cloud() -> String {
    format!("{}/fixtures/cloud.vdb", env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn check_stability_passes_and_writes_its_table_as_json() {
    let dir = scratch("stability");
    let out = dir.join("out");
    let o = murk(&["check-stability", "--out", out.to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        stdout.contains("| case | result |") && stdout.contains("10/10 cases pass"),
        "{stdout}"
    );
    let json: Value =
        serde_json::from_str(&fs::read_to_string(out.join("stability.json")).unwrap()).unwrap();
    assert_eq!(json["pass"], true);
    let cases = json["cases"].as_array().unwrap();
    let names: Vec<&str> = cases.iter().map(|c| c["name"].as_str().unwrap()).collect();
    assert_eq!(
        names,
        [
            "stiff_slab",
            "thin_media",
            "bad_voxels",
            "sheet_30deg",
            "parallel_grazing",
            "camera_inside",
            "translated",
            "empty_grid",
            "single_voxel",
            "hot_temperature"
        ]
    );
    for c in cases {
        let name = c["name"].as_str().unwrap();
        assert_eq!(c["pass"], true, "{name}: {c}");
        assert_eq!(c["nan_inf"], 0, "{name}");
        let num = |k: &str| {
            c[k].as_f64()
                .unwrap_or_else(|| panic!("{name}: {k} is {}", c[k]))
        };
        assert!(num("alpha_min") >= 0.0 && num("alpha_max") <= 1.0, "{name}");
        assert!(num("radiance_max") <= num("radiance_bound"), "{name}");
        assert!(num("max_error") <= num("tolerance"), "{name}");
        assert!(num("samples") > 0.0, "{name}");
    }
    // --json prints the same document.
    let o = murk(&["check-stability", "--out", out.to_str().unwrap(), "--json"]);
    let printed: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(printed["cases"].as_array().unwrap().len(), 10);
}

#[test]
fn converge_writes_csv_markdown_and_png() {
    let dir = scratch("converge");
    let out = dir.join("conv");
    let o = murk(&[
        "converge",
        &cloud(),
        "--res",
        "32x18",
        "--runs",
        "1",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(stdout.contains("fitted order"), "{stdout}");

    let csv = fs::read_to_string(out.join("converge.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(
        header,
        [
            "sweep",
            "value",
            "step",
            "dsm_tolerance",
            "termination",
            "shadows",
            "bake_seconds",
            "render_seconds",
            "total_seconds",
            "runs",
            "rel_rmse",
            "max_alpha_error",
            "nan_inf",
            "bound_violations"
        ]
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    // The reference, three sweeps, --max-error's, the default; then the path tracer's
    // reference and its spp sweep, and the fast approximation's bounces sweep against it.
    assert_eq!(rows.len(), 1 + 7 + 5 + 6 + 4 + 1 + 1 + 6 + 6, "{csv}");
    assert_eq!(
        rows.iter().filter(|r| r[0] == "fast_bounces").count(),
        6,
        "{csv}"
    );
    assert_eq!(rows[0][0], "reference");
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let num = |r: &[&str], name: &str| -> f64 { r[col(name)].parse().unwrap() };
    for r in &rows {
        assert_eq!(r.len(), header.len());
        for name in ["total_seconds", "rel_rmse", "max_alpha_error"] {
            let v = num(r, name);
            assert!(v.is_finite() && v >= 0.0, "{name} {v} in {r:?}");
        }
        assert_eq!(num(r, "nan_inf"), 0.0, "{r:?}");
        assert_eq!(num(r, "bound_violations"), 0.0, "{r:?}");
    }
    // The step sweep converges: each halving of the step cuts the error.
    let step: Vec<f64> = rows
        .iter()
        .filter(|r| r[0] == "step")
        .map(|r| num(r, "rel_rmse"))
        .collect();
    assert!(step.windows(2).all(|w| w[1] < w[0]), "{step:?}");
    // The path tracer's error falls as 1/√spp: the fitted slope of log error against
    // log spp is near −½ (six points, 1 → 32 spp, against a 256-spp reference).
    let path: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r[0] == "path_spp")
        .map(|r| (num(r, "value").ln(), num(r, "rel_rmse").ln()))
        .collect();
    assert_eq!(path.len(), 6, "{csv}");
    let slope = murk::report::fit_slope(&path);
    assert!(
        (-0.65..=-0.35).contains(&slope),
        "path_spp slope {slope}: {path:?}"
    );
    // The termination sweep: α error stays below the threshold (a ray dropped at T < t
    // loses at most t of opacity).
    for r in rows.iter().filter(|r| r[0] == "termination") {
        assert!(
            num(r, "max_alpha_error") <= num(r, "termination") * 1.01 + 1e-6,
            "{r:?}"
        );
    }

    // --max-error meets what it is asked for, and spends less where it may err more.
    let budget: Vec<(f64, f64, f64)> = rows
        .iter()
        .filter(|r| r[0] == "max_error")
        .map(|r| (num(r, "value"), num(r, "rel_rmse"), num(r, "step")))
        .collect();
    assert_eq!(budget.len(), 4, "{csv}");
    for w in budget.windows(2) {
        assert!(w[0].0 > w[1].0 && w[0].2 >= w[1].2, "{budget:?}");
    }
    for (asked, got, _) in &budget {
        assert!(got <= asked, "--max-error {asked}: {got}");
    }

    let md = fs::read_to_string(out.join("converge.md")).unwrap();
    assert!(
        md.contains("| sweep | fitted order |") && md.contains("converge.png"),
        "{md}"
    );
    let png = fs::read(out.join("converge.png")).unwrap();
    assert!(png.starts_with(b"\x89PNG\r\n\x1a\n") && png.len() > 1000);
}

#[test]
fn converge_refuses_bad_input_in_one_line() {
    let dir = scratch("converge-bad");
    let missing = dir.join("nope.vdb");
    let o = murk(&[
        "converge",
        missing.to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("nope.vdb"), "{err}");
    let o = murk(&[
        "converge",
        &cloud(),
        "--runs",
        "0",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(!dir.join("converge.csv").exists());
}

/// Every example under `--help` runs (from a scratch directory, fixtures by absolute
/// path) and writes what it says.
#[test]
fn help_examples_run() {
    for (sub, files) in [
        ("check-stability", &["stability.json"][..]),
        ("converge", &["converge.csv", "converge.md", "converge.png"]),
    ] {
        let help = murk(&[sub, "--help"]);
        assert!(help.status.success());
        let dir = scratch(&format!("examples-{sub}"));
        for example in examples(&String::from_utf8_lossy(&help.stdout)) {
            assert_eq!(example[0], sub);
            let args: Vec<String> = example
                .iter()
                .map(|a| match a.strip_prefix("fixtures/") {
                    Some(_) => format!("{}/{a}", env!("CARGO_MANIFEST_DIR")),
                    None => a.clone(),
                })
                .collect();
            let o = Command::new(MURK)
                .args(&args)
                .current_dir(&dir)
                .output()
                .unwrap();
            assert!(
                o.status.success(),
                "murk {}: {}",
                example.join(" "),
                String::from_utf8_lossy(&o.stderr)
            );
            let out = example
                .iter()
                .position(|a| a == "--out")
                .map_or(dir.clone(), |i| dir.join(&example[i + 1]));
            for f in files {
                assert!(out.join(f).is_file(), "murk {}: no {f}", example.join(" "));
            }
        }
    }
}
