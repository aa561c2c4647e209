//! `--scattering fast` with the lattice's sweeps on the GPU (render/gpu/sweep.rs): the
//! lattice it solves against the CPU's node by node, the image against the CPU's, the
//! same image for any thread count, and the automatic choice on lavapipe (the CPU).

use super::*;
use murk::integrate::ms_lattice::MsLattice;
use murk::render::gpu::{Gpu, GpuSweeper};
use murk::scene::Scene;
use murk::scene::plan::LatticeDevice;

/// A fixture's lattice (at most `nodes` nodes) solved on the CPU and with its sweeps on
/// lavapipe; per light and node, each moment's largest difference relative to the
/// node's own `J` of its kind (twice-or-more, or once scattered). Asserts the GPU swept
/// every order, as many as the CPU.
fn lattices(input: &str, o: &RenderOptions, nodes: usize) -> (f64, MsLattice) {
    let plan = RenderPlan::new(&fast(o), fixture(input)).unwrap();
    let scene = Scene::build(&plan, &murk::render::Silent).unwrap();
    let traversal = scene.traversal();
    let volume = scene.volume(&traversal);
    let lights = scene.illumination();
    let mut settings = plan.transport.fast_settings().lattice();
    settings.max_nodes = nodes;
    let cpu = MsLattice::build(&volume, &lights, &settings);
    let sweeper = GpuSweeper::new(Gpu::shared().unwrap());
    let gpu = MsLattice::build_with(&volume, &lights, &settings, Some(&sweeper));
    assert_eq!(sweeper.failure(), None);
    assert_eq!(cpu.report.swept_on, "cpu");
    assert_eq!(gpu.report.swept_on, gpu_device());
    assert_eq!(gpu.report.orders_swept, cpu.report.orders_swept);
    assert_eq!(
        sweeper.times().orders,
        cpu.report
            .orders_swept
            .iter()
            .map(|o| *o as u64)
            .sum::<u64>()
    );
    let mut worst = 0f64;
    for (c, g) in cpu.moments_of().iter().zip(gpu.moments_of()) {
        assert_eq!(c.len(), g.len());
        let peak = c.iter().map(|m| m[0].max(m[12])).fold(0f32, f32::max) as f64;
        assert!(peak > 0.0, "{input}: an unlit lattice proves nothing");
        for (a, b) in c.iter().zip(g) {
            for (k, (x, y)) in a.iter().zip(b).enumerate() {
                // J and its flux G (|G| ≤ J: its components are sums that cancel) against
                // the node's J; J₁ against itself. A floor of 1e-7 of the lattice's peak
                // for nodes at the rounding level of their neighbours.
                let scale = match k {
                    0..3 => a[k],
                    3..12 => a[(k - 3) / 3],
                    _ => a[k],
                } as f64;
                let d = (*x as f64 - *y as f64).abs() / (scale.abs() + 1e-7 * peak);
                worst = worst.max(d);
            }
        }
    }
    (worst, gpu)
}

/// The GPU's sweeps are the CPU's to f32 rounding: each node's update is the same f32
/// arithmetic in the same order (the directions' sums too), but the GPU's `exp` and its
/// fused multiply-adds round differently, by an ulp or two per operation. A node's value
/// is a sum of positive terms (the upstream radiance attenuated, the source along the
/// step), so these do not grow along a sweep: ~10⁻⁷ per operation, some 60 planes and
/// 10–23 orders, is ~10⁻⁵ at worst; the diffusion tail's conjugate gradients stop at a
/// residual of 10⁻⁵. 10⁻⁴ holds both with room and fails any error in the port (a tap,
/// weight, plane or direction wrong moves nodes by 10⁻² or more).
const LATTICE_REL: f64 = 1e-4;

#[test]
fn the_gpu_sweeps_the_cpus_lattice_node_by_node() {
    need_gpu!();
    // A sun, one channel, isotropic (no flux): the default render's lattice.
    let (sun, _) = lattices("cloud.vdb", &options("40x24"), 6000);
    // Two lights in a coloured medium: three channels, a point light's phase weights
    // per node, and a forward-peaked phase (the flux G).
    let mut o = two_lights_in_a_coloured_medium();
    o.g = Some(0.6);
    let (coloured, _) = lattices("cloud.vdb", &o, 6000);
    // Thick enough for the lattice to grow: fewer orders, the diffusion tail.
    let mut thick = options("40x24");
    thick.sigma_a = Some("1,1,1".into());
    thick.sigma_s = Some("60,60,60".into());
    let (grown_err, grown) = lattices("sphere.vdb", &thick, 2000);
    assert_eq!(grown.report.tail, "diffusion", "{:?}", grown.report);
    eprintln!("node by node, rel.: sun {sun:e}, coloured {coloured:e}, grown {grown_err:e}");
    for (what, e) in [("sun", sun), ("coloured", coloured), ("grown", grown_err)] {
        assert!(e <= LATTICE_REL, "{what}: {e:e}");
    }
}

/// `o`'s render on `device`, its lattice swept where `lattice` says.
fn render_with(
    input: &str,
    o: &RenderOptions,
    device: Device,
    lattice: LatticeDevice,
) -> murk::render::RenderedImage {
    let mut o = fast(o);
    o.device = Some(device);
    let mut plan = RenderPlan::new(&o, fixture(input)).unwrap();
    plan.sampling.lattice = lattice;
    render_image(&plan).unwrap()
}

#[test]
fn the_fast_image_with_the_gpu_swept_lattice_is_the_cpus_for_any_thread_count() {
    need_gpu!();
    let o = options("40x24");
    let cpu = render_with("cloud.vdb", &o, Device::Cpu, LatticeDevice::Auto);
    let swept = render_with("cloud.vdb", &o, Device::Gpu, LatticeDevice::Gpu);
    let lattice = |r: &murk::render::RenderedImage| {
        let m = r.stats.multiple_scattering.as_ref().unwrap();
        (
            m.swept_on.clone(),
            r.stats.scene.stages.contains_key("gpu_lattice"),
        )
    };
    let (on, staged) = lattice(&swept);
    assert!(on == gpu_device() && staged, "{on} {staged}");
    // The GPU's own time in the sweeps, where the adapter times its passes (lavapipe
    // does): part of the stage around them.
    let stage = |name: &str| swept.stats.scene.stages.get(name).map(|s| s.seconds);
    match (stage("gpu_lattice_kernel"), stage("gpu_lattice")) {
        (Some(k), Some(a)) => assert!(k > 0.0 && k <= a, "gpu_lattice_kernel {k} of {a}"),
        (k, _) => assert!(k.is_none() && !test_gpu().timestamps, "{k:?}"),
    }
    assert_eq!(lattice(&cpu), ("cpu".into(), false));
    let beauty = rel_rmse(&swept, &cpu, &["R", "G", "B"]);
    let indirect = rel_rmse(&swept, &cpu, &["indirect.R", "indirect.G", "indirect.B"]);
    let alpha = rmse(plane(&swept, "A"), plane(&cpu, "A"));
    eprintln!("GPU-swept lattice against the CPU: beauty {beauty:e}, indirect {indirect:e}");
    assert!(
        beauty <= RADIANCE_RMSE && indirect <= RADIANCE_RMSE,
        "{beauty:e} {indirect:e}"
    );
    assert!(alpha <= ALPHA_RMSE, "{alpha:e}");
    let lit: f64 = plane(&cpu, "indirect.R").iter().map(|v| *v as f64).sum();
    assert!(lit > 0.0, "no multiple scattering to compare");
    // Under --device auto's rule the lattice is swept on the CPU where the adapter runs
    // on the CPU (lavapipe), and gathered on the GPU: the same image to the lattice's
    // rounding. On a real GPU auto sweeps it there.
    let auto = render_with("cloud.vdb", &o, Device::Gpu, LatticeDevice::Auto);
    if test_gpu().on_cpu {
        assert_eq!(lattice(&auto), ("cpu".into(), false));
    } else {
        assert_eq!(lattice(&auto), (gpu_device(), true));
    }
    let between = rel_rmse(&swept, &auto, &["indirect.R", "indirect.G", "indirect.B"]);
    assert!(between <= 1e-4, "{between:e}");
    // The GPU's sweeps, the CPU's sources and tail: the same image on one thread.
    let mut one = o.clone();
    one.threads = Some(1);
    let single = render_with("cloud.vdb", &one, Device::Gpu, LatticeDevice::Gpu);
    for name in swept.frame.channel_names() {
        assert_eq!(plane(&single, name), plane(&swept, name), "{name}");
    }
}
