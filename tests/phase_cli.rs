//! `murk phase water-drop`: the CSV and the plot it writes, and its refusals.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const MURK: &str = env!("CARGO_BIN_EXE_murk");

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("phase-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn murk(dir: &Path, args: &[&str]) -> Output {
    Command::new(MURK)
        .env("MURK_CACHE_DIR", dir.join("cache"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn water_drop_table_and_plot() {
    let dir = scratch("fog");
    let (csv, png) = (dir.join("fog.csv"), dir.join("fog.png"));
    let out = murk(
        &dir,
        &[
            "phase",
            "water-drop",
            "--drop-radius",
            "10",
            "--csv",
            csv.to_str().unwrap(),
            "--spectral",
            "--plot",
            png.to_str().unwrap(),
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("primary R") && stdout.contains("secondary"),
        "{stdout}"
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(
        header[..5],
        ["scattering_angle_deg", "from_antisolar_deg", "r", "g", "b"]
    );
    assert_eq!(header.len(), 5 + 17);
    assert_eq!((header[5], header[21]), ("p_380nm", "p_780nm"));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse::<f64>().unwrap()).collect())
        .collect();
    assert!(rows.len() > 1000);
    assert_eq!((rows[0][0], rows.last().unwrap()[0]), (0.0, 180.0));
    for r in &rows {
        assert_eq!(r.len(), header.len());
        assert!(r.iter().all(|v| v.is_finite()) && r[2..].iter().all(|v| *v >= 0.0));
        assert!((r[0] + r[1] - 180.0).abs() < 1e-9);
    }
    // Each column integrates to 1 over the sphere (trapezoid in θ, 2π sinθ dθ; the
    // CSV's 9 significant digits and the rule's error stay well under 1e-3).
    for c in 2..header.len() {
        let mut total = 0.0;
        for w in rows.windows(2) {
            let (a, b) = (w[0][0].to_radians(), w[1][0].to_radians());
            total += 0.5 * (w[0][c] * a.sin() + w[1][c] * b.sin()) * (b - a);
        }
        total *= 2.0 * std::f64::consts::PI;
        assert!((total - 1.0).abs() < 1e-3, "{}: {total}", header[c]);
    }
    let image = image::open(&png).unwrap();
    assert_eq!((image.width(), image.height()), (1200, 500));
}

#[test]
fn bad_radius_is_one_line_and_exit_2() {
    let dir = scratch("bad");
    for r in ["0", "-5", "2000", "nan"] {
        let out = murk(&dir, &["phase", "water-drop", "--drop-radius", r]);
        assert_eq!(out.status.code(), Some(2), "{r}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.contains("radius"), "{err}");
    }
}
