//! The ground plane and marched shadow rays on the GPU: against the CPU's image on the
//! fixtures (every layer, the ground's shadow and colour among them), and the ground
//! under a constant slab in closed form.

use super::*;

/// cloud.vdb's view (its voxels span y from −1.05 to 1.55) with a ground just under it.
fn cloud_on_the_ground(visible: bool) -> RenderOptions {
    let mut o = options("32x18");
    o.ground = Some(-1.1);
    o.ground_visible = visible;
    o
}

/// The share of `image`'s pixels whose `shadow` layer is below 0.99 (the ground in the
/// volume's shadow), and above 0.99 (lit, or no ground): a test where either is empty
/// proves little.
fn shadowed_share(image: &murk::render::RenderedImage) -> (f64, f64) {
    let s = plane(image, "shadow.R");
    let dark = s.iter().filter(|v| **v < 0.99).count() as f64 / s.len() as f64;
    (dark, 1.0 - dark)
}

#[test]
fn the_gpu_lights_the_ground_through_the_shadow_maps_as_the_cpu_does() {
    need_gpu!();
    for visible in [false, true] {
        let o = cloud_on_the_ground(visible);
        let (e, _) = gpu_matches_cpu("cloud.vdb", &o);
        let (dark, lit) = shadowed_share(&render("cloud.vdb", &o, Device::Cpu));
        eprintln!(
            "ground (visible {visible}): radiance rel. RMSE {e:e}; {dark:.2} of the pixels shadowed"
        );
        assert!(dark > 0.05 && lit > 0.05, "{dark} shadowed");
    }
    // Under fast too (the ground takes the lights' direct light only), and in a coloured
    // medium with a point light's cube map.
    gpu_gathers_the_cpus_lattice("cloud.vdb", &cloud_on_the_ground(true));
    let mut o = two_lights_in_a_coloured_medium();
    o.ground = Some(-1.1);
    o.ground_visible = true;
    gpu_matches_cpu("cloud.vdb", &o);
}

#[test]
fn the_gpu_marches_shadow_rays_as_the_cpu_does() {
    need_gpu!();
    let march = |mut o: RenderOptions| {
        o.shadows = Some("march".into());
        o
    };
    let (e, _) = gpu_matches_cpu("cloud.vdb", &march(options("32x18")));
    eprintln!("cloud, marched shadows: radiance rel. RMSE {e:e}");
    // Two suns (a layer each) in a coloured medium; a rotated grid (the sun's direction
    // in its index space); the ground's shadow marched too.
    let mut suns = two_lights_in_a_coloured_medium();
    suns.light[1] = "sun:-0.5,0.8,0.4:0.6,0.8,1:2".into();
    gpu_matches_cpu("cloud.vdb", &march(suns));
    gpu_matches_cpu("rotated.vdb", &march(options("24x16")));
    // Toward a point light (and a sun) in a coloured medium.
    gpu_matches_cpu("cloud.vdb", &march(two_lights_in_a_coloured_medium()));
    let o = march(cloud_on_the_ground(true));
    gpu_matches_cpu("cloud.vdb", &o);
    let (dark, lit) = shadowed_share(&render("cloud.vdb", &o, Device::Gpu));
    assert!(dark > 0.05 && lit > 0.05, "{dark} shadowed");
    // Marched shadows are not the map's lookups (a march that looked the map up would
    // pass the comparisons above), yet near them: the map's tolerance apart.
    let mapped = render("cloud.vdb", &options("32x18"), Device::Gpu);
    let marched = render("cloud.vdb", &march(options("32x18")), Device::Gpu);
    let apart = rel_rmse(&marched, &mapped, &["R", "G", "B"]);
    eprintln!("marched against mapped shadows on the GPU: {apart:e}");
    assert!(apart > 0.0 && apart < 5e-2, "{apart:e}");
}

/// A render at `res` lit by `lights` with marched shadow rays, seen from `eye` toward
/// `look_at` (None: the default view).
fn marched(res: &str, lights: &[&str], eye: Option<(&str, &str)>) -> RenderOptions {
    let mut o = options(res);
    o.light = lights.iter().map(|l| l.to_string()).collect();
    o.shadows = Some("march".into());
    if let Some((eye, look_at)) = eye {
        o.eye = Some(eye.into());
        o.look_at = Some(look_at.into());
    }
    o
}

/// Shadow rays marched toward point lights outside the grid and inside it, beside a sun,
/// single and fast, as the CPU marches them; among them rays from right beside the
/// grid's local index origin (cloud.vdb's, world (0.15, 0.15, 0), lies inside its cloud,
/// and the camera stands on it), whose cell walk once stalled at a cell's face far from
/// there: its least step, scaled by the origin's coordinates alone, was under half an
/// f32 step of t, so t never moved and the walk spun until its cell budget ran out
/// (minutes on a real GPU; the ray cut short where that face was inside the grid).
#[test]
fn the_gpu_marches_shadow_rays_toward_point_lights_as_the_cpu_does() {
    need_gpu!();
    // Above cloud.vdb's grid (index (10, 40, 20): on voxel corners and a leaf's face).
    let above = "point:0.5,2,1:1,1,1:40";
    let sun = "sun:0.3,1,0.2:1,1,1:2";
    let inside = marched("16x9", &[above, sun], Some(("0.15,0.15,0", "0.5,-0.5,-1")));
    let (e, _) = gpu_matches_cpu("cloud.vdb", &inside);
    eprintln!("cloud from its index origin, marched toward a point and a sun: {e:e}");
    gpu_gathers_the_cpus_lattice("cloud.vdb", &inside);
    gpu_matches_cpu("cloud.vdb", &marched("16x9", &[above], None));
    // pyro.vdb (voxels of 0.1 over (−1.3, 0, −1.3)..(1.2, 3.8, 1.3)): a point light in the
    // plume, on a voxel corner, and one beside it.
    let pyro = marched(
        "16x9",
        &["point:0,1.5,0:1,0.8,0.6:20", "point:1.5,2,1:1,1,1:30"],
        None,
    );
    let (e, _) = gpu_matches_cpu("pyro.vdb", &pyro);
    eprintln!("pyro, point lights in and beside it: {e:e}");
    gpu_gathers_the_cpus_lattice("pyro.vdb", &pyro);
}

/// slab.vdb (density 1 for x, y in [−2, 1.95] and z in [0, 0.95], trilinear ramps of one
/// voxel, 0.05, on each face: ∫ρ dz = 1) standing on end; a ground at y = −1 seen from
/// straight above at z in [−0.7, −0.3], in front of the slab; no medium between the
/// camera and the ground.
fn ground_before_the_slab(toward_sun: &str, shadows: &str) -> RenderOptions {
    let mut o = options("8x8");
    o.camera = Some("ortho".into());
    o.eye = Some("0,5,-0.5".into());
    o.look_at = Some("0,-1,-0.5".into());
    o.up = Some("0,0,1".into());
    o.ortho_width = Some(0.4);
    o.sigma_a = Some("0.5,0.5,0.5".into());
    o.sigma_s = Some("0,0,0".into());
    o.light = vec![format!("sun:{toward_sun}:1,1,1:3")];
    o.shadows = Some(shadows.into());
    // The midpoint rule across the slab's ramps (kinks inside a step of one voxel) is
    // 2e-3 off ∫ρ ds: steps of a twentieth of a voxel are 400 times nearer.
    o.shadow_step = Some(0.05);
    o.ground = Some(-1.0);
    o.ground_visible = true;
    o
}

#[test]
fn the_ground_behind_a_constant_slab_has_the_closed_form_light() {
    need_gpu!();
    // The sun at 45° from +y+z: the light crosses the slab's full thickness on the way
    // down, √2 of it per unit z, so T = e^{−σt √2}; the ground's radiance is
    // albedo/π · E cos θ · T, with cos θ = 1/√2. From −z nothing is in the way: T = 1.
    let albedo = 0.18 / std::f64::consts::PI;
    let cos = std::f64::consts::FRAC_1_SQRT_2;
    for (toward, shadows, t, tol) in [
        ("0,1,1", "march", (-0.5f64 * 2f64.sqrt()).exp(), 1e-5),
        ("0,1,1", "dsm", (-0.5f64 * 2f64.sqrt()).exp(), 2e-3),
        ("0,1,-1", "march", 1.0, 1e-5),
    ] {
        let o = ground_before_the_slab(toward, shadows);
        let gpu = render("slab.vdb", &o, Device::Gpu);
        assert!(gpu.stats.device.starts_with("gpu"), "{}", gpu.stats.device);
        let want = albedo * 3.0 * cos * t;
        for (name, closed) in [("R", want), ("shadow.R", t), ("A", 1.0)] {
            for v in plane(&gpu, name) {
                let e = (*v as f64 - closed).abs() / closed;
                assert!(
                    e <= tol,
                    "sun {toward}, {shadows}: {name} {v}, closed form {closed} ({e:e})"
                );
            }
        }
        gpu_matches_cpu("slab.vdb", &o);
    }
}
