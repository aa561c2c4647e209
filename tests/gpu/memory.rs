//! Memory: a scene whose grid does not fit the GPU's largest buffer (made so by lowering
//! the limit murk sees, MURK_GPU_MAX_BINDING) is never rendered wrong or refused
//! silently: under `--device auto` the CPU renders it with a note saying why, under
//! `gpu` one line refuses it.

use super::*;
use murk::render::gpu::MAX_BINDING_VAR;

/// murk's stderr, exit code and the stats' device for a 16x9 render of cloud.vdb with
/// `env` set.
fn render_with(device: &str, env: &[(&str, &str)]) -> (String, Option<i32>, String) {
    let dir = scratch(&format!("gpu-memory-{device}-{}", env.len()));
    let cloud = fixture("cloud.vdb");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_murk"))
        .current_dir(&dir)
        .args([
            "render",
            cloud.to_str().unwrap(),
            "-o",
            "m.exr",
            "--res",
            "16x9",
        ])
        .args([
            "--scattering",
            "single",
            "--device",
            device,
            "--stats",
            "m.json",
        ])
        .envs(env.iter().copied())
        .output()
        .unwrap();
    let used = std::fs::read_to_string(dir.join("m.json"))
        .ok()
        .and_then(|s| serde_json::from_str::<serde_json::Value>(&s).ok())
        .and_then(|v| v["device"].as_str().map(str::to_owned))
        .unwrap_or_default();
    (
        String::from_utf8_lossy(&out.stderr).into_owned(),
        out.status.code(),
        used,
    )
}

#[test]
fn a_grid_over_the_gpus_largest_buffer_falls_back_under_auto_and_is_refused_under_gpu() {
    need_gpu!();
    let gpu = test_gpu();
    // cloud.vdb's node tables are 1.1 MiB (eight upper nodes of 32768 words), its
    // values 1.5 MiB; 512 KiB holds neither.
    let small = [(MAX_BINDING_VAR, "524288")];
    let (err, code, _) = render_with("gpu", &small);
    assert_eq!(code, Some(2), "{err}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "{err}");
    assert!(
        lines[0].contains("--device gpu: the grids' node tables (1.1 MiB)")
            && lines[0].contains(&format!("exceed the largest buffer {}", gpu.name))
            && lines[0].contains("(512.0 KiB)"),
        "{err}"
    );
    // Under auto, with the adapter named (else auto does not take lavapipe, which runs
    // on the CPU): the CPU renders it, and one note says why.
    let name = gpu.name.split(" (").next().unwrap_or_default();
    let named = ("WGPU_ADAPTER_NAME", name);
    let (err, code, used) = render_with("auto", &[small[0], named]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(used, "cpu", "{err}");
    let notes: Vec<&str> = err
        .lines()
        .filter(|l| l.contains("--device auto"))
        .collect();
    assert_eq!(notes.len(), 1, "{err}");
    assert!(
        notes[0].contains("rendered on the CPU: the grids' node tables")
            && notes[0].contains("(512.0 KiB)"),
        "{err}"
    );
    // With the adapter's own limits the same scene renders on it under auto.
    let (err, code, used) = render_with("auto", &[named]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(used, gpu_device(), "{err}");
    assert!(!err.contains("--device auto"), "{err}");
}
