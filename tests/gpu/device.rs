//! Choosing the device: determinism, `--device auto`'s fallback and note, `gpu`'s refusal;
//! shadow maps baked with the GPU's columns.

use super::*;

#[test]
fn the_gpu_renders_the_same_image_twice() {
    need_gpu!();
    let o = options("32x18");
    let (a, b) = (
        render("cloud.vdb", &o, Device::Gpu),
        render("cloud.vdb", &o, Device::Gpu),
    );
    for name in a.frame.channel_names() {
        let (x, y) = (plane(&a, name), plane(&b, name));
        assert!(
            x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits()),
            "{name} differs"
        );
    }
}

#[test]
fn auto_falls_back_to_the_cpu_with_a_note_and_gpu_refuses_in_one_line() {
    need_gpu!();
    let dir = scratch("gpu-device");
    let cloud = fixture("cloud.vdb");
    let cloud = cloud.to_str().unwrap();
    fn render_args<'a>(input: &'a str, device: &'a str, mode: &'a str) -> Vec<&'a str> {
        vec![
            "render",
            input,
            "-o",
            "out.exr",
            "--res",
            "16x9",
            "--device",
            device,
            "--scattering",
            mode,
        ]
    }
    let args = |device: &'static str, mode: &'static str| render_args(cloud, device, mode);
    // More lights than the march takes are refused too.
    let mut many = args("gpu", "single");
    for _ in 0..9 {
        many.extend(["--light", "sun:0,1,0:1,1,1:1"]);
    }
    refused(&dir, &many, "more than 8 lights");
    // Several volumes: named as such, not as "a density that is not a voxel grid".
    std::fs::write(
        dir.join("two.toml"),
        format!(
            "[[volume]]\nfile = {cloud:?}\n[[volume]]\nfile = {cloud:?}\ntranslate = [0.5, 0, 0]\n"
        ),
    )
    .unwrap();
    refused(
        &dir,
        &[
            "render",
            "two.toml",
            "-o",
            "two.exr",
            "--res",
            "8x8",
            "--device",
            "gpu",
            "--scattering",
            "single",
        ],
        "several volumes ([[volume]] tables)",
    );
    // Motion blur (pyro.vdb's velocity grid, the shutter open) runs on the CPU only.
    let pyro = fixture("pyro.vdb");
    let pyro = pyro.to_str().unwrap();
    let blur = |device: &'static str| {
        let mut a = render_args(pyro, device, "path");
        a.extend(["--shutter", "-0.25,0.25"]);
        a
    };
    refused(
        &dir,
        &blur("gpu"),
        "--device gpu: the GPU backend does not render motion blur from a velocity grid (--shutter)",
    );
    // Under auto a device that runs on the CPU, as lavapipe does, is not taken: murk's
    // own CPU path renders faster. One note says so, naming the adapter. A real GPU is
    // taken without a note.
    let notes = |err: &str| -> Vec<String> {
        err.lines()
            .filter(|l| l.contains("--device auto"))
            .map(str::to_owned)
            .collect()
    };
    let gpu = test_gpu();
    let err = ok(&dir, &args("auto", "single"));
    let lines = notes(&err);
    if gpu.on_cpu {
        assert_eq!(lines.len(), 1, "{err}");
        assert!(
            lines[0].contains(&gpu.name) && lines[0].contains("runs on the CPU"),
            "{err}"
        );
    } else {
        assert!(lines.is_empty(), "{err}");
    }
    // Motion blur runs on the CPU only: named before any adapter is looked at.
    let err = ok(&dir, &blur("auto"));
    let lines = notes(&err);
    assert_eq!(lines.len(), 1, "{err}");
    assert!(lines[0].contains("motion blur"), "{err}");
    // The default render (fast scattering) of a density-only grid runs on the GPU, and
    // under auto on the GPU unless the adapter runs on the CPU (the adapter, not a
    // feature, says why not).
    let on_auto = if gpu.on_cpu {
        "cpu".to_string()
    } else {
        gpu_device()
    };
    for (device, on) in [("gpu", gpu_device()), ("auto", on_auto)] {
        let err = ok(
            &dir,
            &[
                "render", cloud, "-o", "d.exr", "--res", "16x9", "--device", device, "--stats",
                "d.json",
            ],
        );
        assert!(!err.contains("does not render"), "{err}");
        let stats: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("d.json")).unwrap()).unwrap();
        let used = stats["device"].as_str().unwrap_or_default();
        assert_eq!(used, on, "--device {device}");
        // The process opened the GPU, whether it rendered on it or (under auto, an
        // adapter that runs on the CPU) declined it: that time is a stage of its own,
        // part of the render's total.
        let open = stats["stages"]["gpu_open"]["seconds"].as_f64();
        let total = stats["total_seconds"].as_f64().unwrap_or(0.0);
        assert!(
            open.is_some_and(|s| s > 0.0 && s < total),
            "--device {device}: gpu_open {open:?} of {total}"
        );
    }
    refused(
        &dir,
        &["render", cloud, "-o", "x.exr", "--device", "tpu"],
        "--device",
    );
    // No adapter at all (a Vulkan driver manifest that does not exist): gpu refuses in
    // one line, auto renders on the CPU and says why.
    let without = |device: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_murk"))
            .current_dir(&dir)
            .args(["render", cloud, "-o", "none.exr", "--res", "8x8"])
            .args(["--scattering", "single", "--device", device])
            .env("VK_DRIVER_FILES", dir.join("no-driver.json"))
            .env("WGPU_BACKEND", "vulkan")
            .output()
            .unwrap()
    };
    let out = without("gpu");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    let murk_lines: Vec<&str> = err.lines().filter(|l| l.starts_with("murk")).collect();
    assert_eq!(murk_lines.len(), 1, "{err}");
    assert!(
        murk_lines[0].contains("--device gpu: no GPU adapter found"),
        "{err}"
    );
    let out = without("auto");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("--device auto rendered on the CPU: no GPU adapter found"),
        "{err}"
    );
}

/// The deep shadow map baked with its light columns marched on the GPU (f32) is the
/// CPU's (f64): the same bricks at the same levels and forms, from the same number of
/// columns, all of them marched on the GPU; and ∫ρ ds looked up anywhere in the grid
/// equal to f32 rounding: within 1e-5 of 1 + ∫ρ ds, and 1e-5 in transmittance. Suns
/// (parallel charts: slopes across, no twist term from the fan) and a point light (six
/// perspective charts: every sideways term), on a cloud, a rotated grid and a grid a
/// million voxels from the origin. (On tiles.vdb's 4096³ root tile, with f32 positions
/// 2e-4 voxels apart, columns marched in f32 agreed to 1.3e-4 only: columns that far out
/// or that long are marched on the CPU.)
#[test]
fn shadow_maps_baked_with_gpu_columns_are_the_cpus() {
    use glam::DVec3;
    use murk::field::{Field, VoxelGrid};
    use murk::render::gpu::{Gpu, GpuColumns};
    use murk::shadow::{BakeSettings, LightGeometry, bake, bake_with};
    need_gpu!();
    let gpu = Gpu::shared().unwrap();
    let sun = |x: f64, y: f64, z: f64| LightGeometry::Sun {
        travel: -DVec3::new(x, y, z).normalize(),
    };
    let point = |x: f64, y: f64, z: f64| LightGeometry::Point {
        position: DVec3::new(x, y, z),
    };
    let cases = [
        ("cloud.vdb", sun(0.6, 1.0, 0.5)),
        ("rotated.vdb", point(1.5, 2.0, 1.0)),
        ("far.vdb", sun(-0.4, 1.0, 0.3)),
    ];
    for (name, light) in cases {
        let path = fixture(name);
        let g = VoxelGrid::load(&murk::vdb::VdbFile::open(&path).unwrap(), "density").unwrap();
        let settings = BakeSettings::new(1e-3, DVec3::splat(3.0));
        let t = std::time::Instant::now();
        let (cpu, cpu_report) = bake(&g, light, &settings);
        let cpu_seconds = t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        let columns = GpuColumns::new(gpu);
        let (on_gpu, gpu_report) = bake_with(&g, light, &settings, Some(&columns));
        eprintln!(
            "{name}: bake {cpu_seconds:.2} s on the CPU, {:.2} s with lavapipe's columns ({} columns)",
            t.elapsed().as_secs_f64(),
            gpu_report.columns
        );
        assert_eq!(columns.failure(), None, "{name}");
        let times = columns.times();
        assert!(
            cpu_report.columns > 0 && times.marched == gpu_report.columns,
            "{name}: {} of {} columns on the GPU",
            times.marched,
            gpu_report.columns
        );
        let shape = |r: &murk::shadow::BakeReport| {
            (
                r.bricks,
                r.points_per_level.clone(),
                r.linear_bricks,
                r.dark_bricks,
                r.columns,
                r.bricks_over_tolerance,
                r.memory_bytes,
            )
        };
        assert_eq!(shape(&cpu_report), shape(&gpu_report), "{name} {light:?}");
        // ∫ρ ds at points spread over the grid's active box (and a little beyond).
        let (lo, hi) = (
            g.active_bounds().min.as_dvec3(),
            g.active_bounds().max.as_dvec3(),
        );
        let mut rng = murk::field::random::SplitMix64(7);
        let (mut worst, mut deepest, mut light_error) = (0.0f64, 0.0f64, 0.0f64);
        for _ in 0..20_000 {
            let u = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 1.2 - 0.1;
            let p = g.transform().index_to_world(lo + (hi - lo) * u);
            let (a, b) = (cpu.density_integral(p), on_gpu.density_integral(p));
            worst = worst.max((a - b).abs() / (1.0 + a.abs()));
            let lit = |tau: f64| (-settings.sigma_t.x * tau.max(0.0)).exp();
            light_error = light_error.max((lit(a) - lit(b)).abs());
            deepest = deepest.max(a);
        }
        eprintln!(
            "{name}: ∫ρ ds up to {deepest:.3}, largest difference {worst:.1e} (relative to 1 + ∫ρ ds), in transmittance {light_error:.1e}"
        );
        assert!(deepest > 0.1, "{name}: a map without shadow proves nothing");
        assert!(worst <= 1e-5, "{name} {light:?}: {worst:e}");
        assert!(light_error <= 1e-5, "{name} {light:?}: {light_error:e}");
    }
}
