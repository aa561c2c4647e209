//! A USD camera's image against Blender 3.4 Cycles' through the same camera, built in
//! Blender from what usd-core reports: alpha of the same VDB on every frame.

mod common;
use common::camera::{alpha_of, author_stages, fixture, render_frames, scratch};
use common::tools;
use glam::DVec3;
use std::path::Path;

/// Mean |ΔA| and the alpha centroid's shift between two alpha images (row-major).
fn compare_alpha(a: &[f32], b: &[f32], w: usize) -> (f64, f64) {
    let mean = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs() as f64)
        .sum::<f64>()
        / a.len() as f64;
    let centroid = |img: &[f32]| {
        let (mut s, mut x, mut y) = (0f64, 0f64, 0f64);
        for (i, v) in img.iter().enumerate() {
            let v = *v as f64;
            s += v;
            x += v * (i % w) as f64;
            y += v * (i / w) as f64;
        }
        DVec3::new(x / s, y / s, 0.0)
    };
    (mean, (centroid(a) - centroid(b)).length())
}

#[test]
fn a_usd_camera_sees_what_cycles_sees_through_it() {
    need!(tools::USD_CORE, tools::BLENDER);
    let dir = scratch("cycles");
    author_stages(&dir);
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/cycles_camera.py");
    let (w, h) = (48, 32);
    for (name, stage) in [("yup", "yup.usda"), ("zup", "zup.usdc")] {
        let ours = render_frames(
            &dir,
            &fixture("cloud.vdb"),
            &format!("{name}_murk"),
            &[
                "--camera-file",
                stage,
                "--sigma-a",
                "1,1,1",
                "--sigma-s",
                "0,0,0",
                "--no-lights",
                "--float",
            ],
        );
        let out = tools::command(&tools::BLENDER)
            .args(["-b", "--factory-startup", "-noaudio", "--python"])
            .arg(&script)
            .arg("--")
            .arg(dir.join(format!("{name}.json")))
            .arg(fixture("cloud.vdb"))
            // cloud.vdb's voxel size (fixtures/README.md).
            .arg("0.05")
            .arg(dir.join(format!("{name}_cycles_")))
            .arg(format!("{w}x{h}"))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        for (i, ours) in ours.iter().enumerate() {
            let theirs = dir.join(format!("{name}_cycles_{}.exr", i + 1));
            let (mean, shift) = compare_alpha(&alpha_of(ours), &alpha_of(&theirs), w);
            eprintln!(
                "{name} frame {}: mean |dA| {mean:.4}, centroid shift {shift:.3} px",
                i + 1
            );
            assert!(mean <= 0.01, "{name} frame {}: mean |dA| {mean}", i + 1);
            assert!(
                shift <= 0.5,
                "{name} frame {}: centroid moved {shift} px",
                i + 1
            );
        }
    }
}
