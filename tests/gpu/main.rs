//! `--device gpu|auto`: the GPU backend against the CPU's image on fixtures (single
//! scattering, and fast with the CPU's lattice gathered on the GPU), a closed form,
//! determinism, and what it refuses. The GPU is Mesa's lavapipe (Vulkan on the
//! CPU), so these run on any machine that has it, and skip where it is missing. Images
//! are small: lavapipe is slow on two cores. With `MURK_TEST_GPU=system` they run on
//! the adapter the machine's own drivers give instead (a real GPU), and do not skip.

#[path = "../common/mod.rs"]
mod common;

use common::frames::{ok, refused, scratch};
use common::tools::{self, LAVAPIPE_ICD};
use murk::integrate::ScatteringMode;
use murk::render::gpu::Gpu;
use murk::render::{RenderOptions, RenderPlan, bake_shadow_file, render_image};
use murk::scene::plan::Device;
use murk::scene::progress::Silent;
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

/// The environment variable that picks the GPU these tests run on: unset (or
/// `lavapipe`), Mesa's lavapipe alone; `system`, the adapter wgpu picks from the
/// machine's own drivers (as murk does for a user).
const TEST_GPU_VAR: &str = "MURK_TEST_GPU";

/// Whether the tests run on the machine's own GPU rather than lavapipe.
fn on_system_gpu() -> bool {
    std::env::var(TEST_GPU_VAR).is_ok_and(|v| v.trim() == "system")
}

/// Skips the test (with its line) where lavapipe is missing, unless the tests run on
/// the machine's own GPU; then sets the GPU up ([`use_test_gpu`]).
macro_rules! need_gpu {
    () => {
        if !on_system_gpu() {
            need!(tools::LAVAPIPE);
        }
        use_test_gpu();
    };
}

/// The GPU the tests run on: lavapipe as the only Vulkan driver (unless
/// [`on_system_gpu`]), and a runtime folder so that Mesa does not warn; once per test
/// binary, before any thread opens a GPU.
fn use_test_gpu() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let runtime = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("gpu-xdg-runtime");
        let _ = std::fs::create_dir_all(&runtime);
        // SAFETY: set once, before any test of this binary opens a GPU or reads these.
        unsafe {
            if !on_system_gpu() {
                std::env::set_var("VK_DRIVER_FILES", LAVAPIPE_ICD);
                std::env::set_var("WGPU_BACKEND", "vulkan");
            }
            std::env::set_var("XDG_RUNTIME_DIR", &runtime);
        }
    });
}

/// The GPU the tests run on, opened as murk opens it.
fn test_gpu() -> &'static Gpu {
    Gpu::shared().unwrap_or_else(|e| panic!("the GPU under test: {e}"))
}

/// What the stats call a render on the GPU under test (`gpu: ` and the adapter's name).
fn gpu_device() -> String {
    format!("gpu: {}", test_gpu().name)
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
    assert_eq!(gpu.stats.device, gpu_device());
    assert_eq!(cpu.frame.channel_names(), gpu.frame.channel_names());
    // The GPU's stages are parts of its render: the layout of the upload, and the
    // upload, rays, march and record of the render stage, each one timed.
    let stage = |name: &str| gpu.stats.scene.stages.get(name).map(|s| s.seconds);
    let parts = ["gpu_upload", "gpu_rays", "gpu_march", "gpu_record"].map(stage);
    // The shadow bake's light columns ran on the GPU too, inside the shadows stage
    // (where maps are baked: not with marched shadow rays, nor maps read from a cache).
    let bake = ["gpu_bake_upload", "gpu_bake"].map(stage);
    let baked = !matches!(o.shadows.as_deref(), Some("march" | "none")) && o.shadow_cache.is_none();
    assert!(
        !baked
            || bake.iter().all(|s| s.is_some_and(|s| s > 0.0))
                && bake.iter().flatten().sum::<f64>() <= stage("shadows").unwrap_or(0.0),
        "{bake:?} in {:?}",
        stage("shadows")
    );
    assert!(
        parts.iter().all(|s| s.is_some_and(|s| s > 0.0)),
        "{parts:?}"
    );
    // The GPU's own time in the march's and the columns' kernels, where the adapter
    // times its passes (lavapipe does): part of the stages around each. The march's
    // chunks run on the GPU while the CPU makes the rays of the chunk after and records
    // the chunk before, so its kernel is part of the three.
    let streamed = ["gpu_rays", "gpu_march", "gpu_record"]
        .map(stage)
        .iter()
        .flatten()
        .sum::<f64>();
    for (kernel, around, ran) in [
        ("gpu_march_kernel", Some(streamed), true),
        ("gpu_bake_kernel", stage("gpu_bake"), baked),
    ] {
        match (stage(kernel), around) {
            (Some(k), Some(a)) => assert!(k > 0.0 && k <= a, "{kernel} {k} of {a}"),
            (k, _) => assert!(k.is_none() && !(test_gpu().timestamps && ran), "{kernel}"),
        }
    }
    // The CPU's wait for the march's chunks: within the stage.
    let wait = stage("gpu_march_wait");
    let march = stage("gpu_march");
    assert!(
        wait.is_some_and(|w| w > 0.0 && w <= march.unwrap_or(0.0)),
        "gpu_march_wait {wait:?}: gpu_march {march:?}"
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

/// cloud.vdb's view with two lights (a layer each; a point light's six charts) in a
/// coloured medium.
fn two_lights_in_a_coloured_medium() -> RenderOptions {
    let mut o = options("32x18");
    o.light = vec![
        "sun:0.3,1,0.2:1,0.9,0.8:4".into(),
        "point:2,2,3:0.6,0.8,1:30".into(),
    ];
    o.sigma_a = Some("0.1,0.2,0.4".into());
    o.sigma_s = Some("3,2.5,2".into());
    o
}

/// sphere.vdb's view lit from behind through a forward-peaked phase function (g = 0.9).
fn forward_peaked_sphere() -> RenderOptions {
    let mut o = options("32x18");
    o.g = Some(0.9);
    o.light = vec!["sun:-0.2,0.1,-1:1,1,1:6".into()];
    o
}

mod closed_forms;
mod device;
mod emission;
mod fast;
mod ground;
mod memory;
mod path;
mod path_features;
mod sequence;
mod single;
mod sweep;
