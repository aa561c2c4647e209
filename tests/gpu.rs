//! `--device gpu|auto`: the GPU backend against the CPU's image on fixtures (single
//! scattering, and fast with the CPU's lattice gathered on the GPU), a closed form,
//! determinism, and what it refuses. The GPU is Mesa's lavapipe (Vulkan on the
//! CPU), so these run on any machine that has it, and skip where it is missing. Images
//! are small: lavapipe is slow on two cores.

mod common;

use common::frames::{ok, refused, scratch};
use common::tools::{self, LAVAPIPE_ICD};
use murk::integrate::ScatteringMode;
use murk::render::{RenderOptions, RenderPlan, render_image};
use murk::scene::plan::Device;
use std::path::PathBuf;
use std::sync::Once;

/// The radiance tolerance: relative RMSE of the beauty against the CPU's.
const RADIANCE_RMSE: f64 = 2e-3;
/// The alpha tolerance: RMSE against the CPU's.
const ALPHA_RMSE: f64 = 1e-3;

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
}

/// lavapipe as the only Vulkan driver, and a runtime folder so that Mesa does not
/// warn; once per test binary, before any thread opens a GPU.
fn use_lavapipe() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let runtime = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("gpu-xdg-runtime");
        let _ = std::fs::create_dir_all(&runtime);
        // SAFETY: set once, before any test of this binary opens a GPU or reads these.
        unsafe {
            std::env::set_var("VK_DRIVER_FILES", LAVAPIPE_ICD);
            std::env::set_var("XDG_RUNTIME_DIR", &runtime);
            std::env::set_var("WGPU_BACKEND", "vulkan");
        }
    });
}

fn options(res: &str) -> RenderOptions {
    RenderOptions {
        res: Some(res.into()),
        quiet: true,
        output: Some(std::env::temp_dir().join("murk-gpu-unused.exr")),
        scattering: Some(ScatteringMode::Single),
        ..RenderOptions::default()
    }
}

fn render(input: &str, o: &RenderOptions, device: Device) -> murk::render::RenderedImage {
    let mut o = o.clone();
    o.device = Some(device);
    render_image(&RenderPlan::new(&o, fixture(input)).unwrap()).unwrap()
}

fn plane<'a>(image: &'a murk::render::RenderedImage, name: &str) -> &'a [f32] {
    image
        .frame
        .channel(name)
        .unwrap_or_else(|| panic!("no channel {name}"))
}

/// Relative RMSE of the channels `names` of `got` against `want`.
fn rel_rmse(
    got: &murk::render::RenderedImage,
    want: &murk::render::RenderedImage,
    names: &[&str],
) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for n in names {
        for (a, b) in plane(got, n).iter().zip(plane(want, n)) {
            num += (*a as f64 - *b as f64).powi(2);
            den += (*b as f64).powi(2);
        }
    }
    (num / den.max(1e-300)).sqrt()
}

fn rmse(a: &[f32], b: &[f32]) -> f64 {
    let sum: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| (*x as f64 - *y as f64).powi(2))
        .sum();
    (sum / a.len() as f64).sqrt()
}

/// The GPU's image of `input` against the CPU's: beauty, every scatter layer, alpha and
/// Z within the tolerances. Returns the beauty's relative RMSE and, under fast, the
/// CPU's `indirect` layer over its beauty (R): how much of the image the lattice's
/// multiple scattering is (0 without it).
fn gpu_matches_cpu(input: &str, o: &RenderOptions) -> (f64, f64) {
    let cpu = render(input, o, Device::Cpu);
    let gpu = render(input, o, Device::Gpu);
    assert_eq!(cpu.stats.device, "cpu");
    assert!(
        gpu.stats.device.starts_with("gpu: llvmpipe"),
        "{}",
        gpu.stats.device
    );
    assert_eq!(cpu.frame.channel_names(), gpu.frame.channel_names());
    // The GPU's stages are parts of its render: the layout of the upload, and the
    // upload, rays, march and record of the render stage, each one timed.
    let stage = |name: &str| gpu.stats.scene.stages.get(name).map(|s| s.seconds);
    let parts = ["gpu_upload", "gpu_rays", "gpu_march", "gpu_record"].map(stage);
    // The shadow bake's light columns ran on the GPU too, inside the shadows stage.
    let bake = ["gpu_bake_upload", "gpu_bake"].map(stage);
    assert!(
        bake.iter().all(|s| s.is_some_and(|s| s > 0.0))
            && bake.iter().flatten().sum::<f64>() <= stage("shadows").unwrap_or(0.0),
        "{bake:?} in {:?}",
        stage("shadows")
    );
    assert!(
        parts.iter().all(|s| s.is_some_and(|s| s > 0.0)),
        "{parts:?}"
    );
    let (layout, render) = (stage("gpu_layout"), stage("render"));
    assert!(layout.is_some_and(|l| l > 0.0 && l <= parts[0].unwrap_or(0.0)));
    let sum: f64 = parts.iter().flatten().sum();
    assert!(render.is_some_and(|r| sum <= r), "{parts:?} in {render:?}");
    let beauty = rel_rmse(&gpu, &cpu, &["R", "G", "B"]);
    assert!(
        beauty <= RADIANCE_RMSE,
        "{input}: radiance rel. RMSE {beauty:e}"
    );
    for name in cpu.frame.channel_names() {
        if let Some(layer) = name.strip_suffix(".R").filter(|l| !l.is_empty()) {
            let e = rel_rmse(
                &gpu,
                &cpu,
                &[name, &format!("{layer}.G"), &format!("{layer}.B")],
            );
            assert!(e <= RADIANCE_RMSE, "{input}: {layer} rel. RMSE {e:e}");
        }
    }
    let alpha = rmse(plane(&gpu, "A"), plane(&cpu, "A"));
    assert!(alpha <= ALPHA_RMSE, "{input}: alpha RMSE {alpha:e}");
    // Z: the same pixels are finite, and there agree to a thousandth of the depth.
    let (zg, zc) = (plane(&gpu, "Z"), plane(&cpu, "Z"));
    let mut differ = 0;
    for (g, c) in zg.iter().zip(zc) {
        if g.is_finite() != c.is_finite() || (c.is_finite() && (g - c).abs() > 1e-3 * c.abs()) {
            differ += 1;
        }
    }
    // A pixel whose alpha is within rounding of 0.5 may fall either side.
    assert!(
        differ * 200 <= zg.len(),
        "{input}: Z differs at {differ} pixels"
    );
    let mean: f64 = plane(&cpu, "R").iter().map(|v| *v as f64).sum::<f64>();
    assert!(mean > 0.0, "{input}: a black image proves nothing");
    let mut indirect = 0.0;
    if o.scattering == Some(ScatteringMode::Fast) {
        // The lattice was solved once per light, on the CPU, for both; its light is in
        // the `indirect` layer, compared above.
        assert!(stage("multiple_scattering").is_some_and(|s| s > 0.0));
        indirect = plane(&cpu, "indirect.R")
            .iter()
            .map(|v| *v as f64)
            .sum::<f64>()
            / mean;
    }
    (beauty, indirect)
}

/// [`gpu_matches_cpu`] under fast, where the lattice's light is more of the image than
/// the tolerance (so a march that dropped it would miss the beauty as well as the
/// `indirect` layer).
fn gpu_gathers_the_cpus_lattice(input: &str, o: &RenderOptions) -> f64 {
    let (beauty, indirect) = gpu_matches_cpu(input, &fast(o));
    assert!(
        indirect > 10.0 * RADIANCE_RMSE,
        "{input}: the lattice's light is {indirect:e} of the image"
    );
    eprintln!("{input}, fast: radiance rel. RMSE {beauty:e}, indirect {indirect:.3} of it");
    beauty
}

/// `o` with the fast multiple-scattering approximation (the default render's).
fn fast(o: &RenderOptions) -> RenderOptions {
    RenderOptions {
        scattering: Some(ScatteringMode::Fast),
        ..o.clone()
    }
}

#[test]
fn the_gpu_renders_the_cpus_image_of_the_demo_cloud() {
    need!(tools::LAVAPIPE);
    use_lavapipe();
    let (e, _) = gpu_matches_cpu("cloud.vdb", &options("40x24"));
    eprintln!("cloud: radiance rel. RMSE {e:e}");
}

#[test]
fn the_gpu_walks_tiles_at_every_level_and_rotated_grids() {
    need!(tools::LAVAPIPE);
    use_lavapipe();
    // Leaves and 8³, 128³ and 4096³ tiles; an affine transform.
    gpu_matches_cpu("tiles.vdb", &options("32x18"));
    gpu_matches_cpu("rotated.vdb", &options("32x18"));
}

#[test]
fn the_gpu_looks_shadows_up_in_point_lights_cube_maps_and_anisotropic_media() {
    need!(tools::LAVAPIPE);
    use_lavapipe();
    // Two lights (a layer each), a point light's six charts, a coloured medium, and a
    // forward-peaked Henyey–Greenstein phase function from its table.
    let mut o = options("32x18");
    o.light = vec![
        "sun:0.3,1,0.2:1,0.9,0.8:4".into(),
        "point:2,2,3:0.6,0.8,1:30".into(),
    ];
    o.sigma_a = Some("0.1,0.2,0.4".into());
    o.sigma_s = Some("3,2.5,2".into());
    gpu_matches_cpu("cloud.vdb", &o);
    let mut o = options("32x18");
    o.g = Some(0.9);
    o.light = vec!["sun:-0.2,0.1,-1:1,1,1:6".into()];
    gpu_matches_cpu("sphere.vdb", &o);
}

#[test]
fn the_gpu_gathers_the_fast_lattice_as_the_cpu_does_on_the_demo_cloud() {
    need!(tools::LAVAPIPE);
    use_lavapipe();
    gpu_gathers_the_cpus_lattice("cloud.vdb", &options("40x24"));
}

#[test]
fn the_gpu_gathers_the_fast_lattice_on_tiles_rotated_grids_and_several_lights() {
    need!(tools::LAVAPIPE);
    use_lavapipe();
    // tiles.vdb's lattice spans its 4096³ tile: its cells are coarser than the leaves
    // that scatter, so little of its image is multiply scattered; equal all the same.
    gpu_matches_cpu("tiles.vdb", &fast(&options("32x18")));
    gpu_gathers_the_cpus_lattice("rotated.vdb", &options("32x18"));
    // Two lights (a lattice and a layer each), a point light's cube map, a coloured
    // medium; a forward-peaked phase function (the lattice's similarity and ḡ² lobe).
    let mut o = options("32x18");
    o.light = vec![
        "sun:0.3,1,0.2:1,0.9,0.8:4".into(),
        "point:2,2,3:0.6,0.8,1:30".into(),
    ];
    o.sigma_a = Some("0.1,0.2,0.4".into());
    o.sigma_s = Some("3,2.5,2".into());
    gpu_gathers_the_cpus_lattice("cloud.vdb", &o);
    let mut o = options("32x18");
    o.g = Some(0.9);
    o.light = vec!["sun:-0.2,0.1,-1:1,1,1:6".into()];
    gpu_gathers_the_cpus_lattice("sphere.vdb", &o);
}

#[test]
fn a_constant_slab_seen_straight_through_has_the_closed_form_alpha() {
    need!(tools::LAVAPIPE);
    use_lavapipe();
    // slab.vdb: density 1 for k = 0..19 at voxel size 0.05, so ∫ρ dz = 1 world unit
    // (trilinear ramps of half a voxel on each face); alpha = 1 − e^{−σt}.
    let mut o = options("8x8");
    o.camera = Some("ortho".into());
    o.eye = Some("0,0,5".into());
    o.look_at = Some("0,0,0".into());
    o.ortho_width = Some(0.5);
    o.sigma_a = Some("0.7,0.7,0.7".into());
    o.sigma_s = Some("0,0,0".into());
    let gpu = render("slab.vdb", &o, Device::Gpu);
    let want = 1.0 - (-0.7f64).exp();
    for a in plane(&gpu, "A") {
        assert!(
            (*a as f64 - want).abs() < 1e-5,
            "alpha {a}, closed form {want}"
        );
    }
}

/// The slab seen straight through by an orthographic camera at z = 5 (its front face
/// at depth 4.025), as the holdout tests of the CPU see it.
fn slab_view() -> RenderOptions {
    let mut o = options("16x16");
    o.camera = Some("ortho".into());
    o.eye = Some("0,0,5".into());
    o.look_at = Some("0,0,0".into());
    o.up = Some("0,1,0".into());
    o.ortho_width = Some(1.0);
    // σt = 3, two thirds of it scattering the default sun's light: the radiance is
    // compared with the CPU's too.
    o.sigma_a = Some("1,1,1".into());
    o.sigma_s = Some("2,2,2".into());
    o
}

#[test]
fn the_gpu_cuts_rays_at_a_holdout_as_its_closed_form_says() {
    need!(tools::LAVAPIPE);
    use_lavapipe();
    use exr::prelude::*;
    // The holdout's left half at depth 4.4, its right half empty: inside the slab
    // α(d) = 1 − e^{−3 (d − 4.025)}.
    let z = scratch("gpu-holdout").join("cg.exr");
    let channels = SpecificChannels::build()
        .with_channel("Z")
        .with_pixel_fn(|p: Vec2<usize>| (if p.x() < 8 { 4.4f32 } else { f32::INFINITY },));
    Image::from_channels((16, 16), channels)
        .write()
        .to_file(&z)
        .unwrap();
    let mut o = slab_view();
    o.holdout_depth = Some(z.to_str().unwrap().into());
    let gpu = render("slab.vdb", &o, Device::Gpu);
    assert!(gpu.stats.device.starts_with("gpu"), "{}", gpu.stats.device);
    let a = plane(&gpu, "A");
    let cut = 1.0 - (-3.0f64 * (4.4 - 4.025)).exp();
    let whole = 1.0 - (-3.0f64).exp();
    for y in 0..16 {
        let (l, r) = (a[y * 16 + 3] as f64, a[y * 16 + 12] as f64);
        assert!((l - cut).abs() < 1e-4, "row {y}: {l} against {cut}");
        assert!((r - whole).abs() < 1e-4, "row {y}: {r} against {whole}");
    }
    gpu_matches_cpu("slab.vdb", &o);
    gpu_gathers_the_cpus_lattice("slab.vdb", &o);
}

#[test]
fn the_gpu_cuts_rays_at_the_cameras_clipping_planes() {
    need!(tools::LAVAPIPE);
    use_lavapipe();
    // A [camera] table: orthographic at z = 5 looking down −z, 1 unit wide (apertures
    // in tenths of a unit), clipping from 4.2 to 4.7 — inside the slab, which spans
    // depths 4.025 to 5.025: alpha is 1 − e^{−3 × 0.5}.
    let table: murk::scene::shot::table::CameraTable = toml::from_str(
        "projection = \"orthographic\"\nhorizontal_aperture = 10.0\nvertical_aperture = 10.0\n\
         clipping_range = [4.2, 4.7]\ntranslate = [0.0, 0.0, 5.0]\nrotate = [0.0, 0.0, 0.0]\n",
    )
    .unwrap();
    let mut o = options("8x8");
    o.camera = Some(murk::scene::options::CameraSetting::Table(Box::new(table)));
    o.sigma_a = Some("1,1,1".into());
    o.sigma_s = Some("2,2,2".into());
    let gpu = render("slab.vdb", &o, Device::Gpu);
    let want = 1.0 - (-1.5f64).exp();
    for a in plane(&gpu, "A") {
        assert!(
            (*a as f64 - want).abs() < 1e-4,
            "alpha {a}, closed form {want}"
        );
    }
    gpu_matches_cpu("slab.vdb", &o);
}

#[test]
fn the_gpu_renders_the_same_image_twice() {
    need!(tools::LAVAPIPE);
    use_lavapipe();
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
    need!(tools::LAVAPIPE);
    use_lavapipe();
    let dir = scratch("gpu-device");
    let cloud = fixture("cloud.vdb");
    let cloud = cloud.to_str().unwrap();
    let args = |device: &'static str, mode: &'static str| {
        vec![
            "render",
            cloud,
            "-o",
            "out.exr",
            "--res",
            "16x9",
            "--device",
            device,
            "--scattering",
            mode,
        ]
    };
    // Water drops' coloured phase function is refused too.
    let mut drops = args("gpu", "single");
    drops.extend(["--phase", "water-drop"]);
    refused(&dir, &drops, "--phase water-drop");
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
    // Path tracing runs on the CPU only.
    refused(
        &dir,
        &args("gpu", "path"),
        "--device gpu: the GPU backend does not render --scattering path",
    );
    // Under auto a device that runs on the CPU, as lavapipe does, is not taken: murk's
    // own CPU path renders faster. One note says so, naming the adapter.
    let notes = |err: &str| -> Vec<String> {
        err.lines()
            .filter(|l| l.contains("--device auto"))
            .map(str::to_owned)
            .collect()
    };
    let err = ok(&dir, &args("auto", "single"));
    let lines = notes(&err);
    assert_eq!(lines.len(), 1, "{err}");
    assert!(
        lines[0].contains("llvmpipe") && lines[0].contains("runs on the CPU"),
        "{err}"
    );
    // Path tracing runs on the CPU only: named before any adapter is looked at.
    let err = ok(&dir, &args("auto", "path"));
    let lines = notes(&err);
    assert_eq!(lines.len(), 1, "{err}");
    assert!(lines[0].contains("--scattering path"), "{err}");
    // The default render (fast scattering) of a density-only grid runs on the GPU, and
    // under auto it says why not (the adapter, not a feature).
    for (device, on) in [("gpu", "gpu: llvmpipe"), ("auto", "cpu")] {
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
        assert!(used.starts_with(on), "--device {device}: {used}");
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
    need!(tools::LAVAPIPE);
    use_lavapipe();
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
