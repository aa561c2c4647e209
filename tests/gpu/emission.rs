//! Emission, blackbody temperature, colour grids and the coloured water-drop phase
//! function on the GPU: the grids beside the density packed after its nodes, against
//! the CPU's image on every layer.

use super::*;
use glam::{DMat4, DVec3, IVec3};
use murk::vdb::{FloatGridOut, write_float_grids};

/// The share of the CPU's beauty (R, G, B summed) that its `emission` layer is.
pub(super) fn emission_share(input: &str, o: &RenderOptions) -> f64 {
    let cpu = render(input, o, Device::Cpu);
    let sum = |names: [&str; 3]| -> f64 {
        names
            .iter()
            .flat_map(|n| plane(&cpu, n).iter())
            .map(|v| *v as f64)
            .sum()
    };
    sum(["emission.R", "emission.G", "emission.B"]) / sum(["R", "G", "B"])
}

#[test]
fn the_gpu_integrates_flame_and_blackbody_emission_as_the_cpu_does() {
    need_gpu!();
    // pyro.vdb: density, flame and temperature (half floats, the flame's nodes offset
    // from the density's), a colour grid Cd. Its emission is most of the image, so a
    // march that dropped it would miss the beauty by far more than the tolerance.
    let o = options("40x24");
    let share = emission_share("pyro.vdb", &o);
    assert!(share > 0.3, "pyro.vdb: emission is {share:.3} of the image");
    let (beauty, _) = gpu_matches_cpu("pyro.vdb", &o);
    eprintln!("pyro.vdb, single: radiance rel. RMSE {beauty:e}, emission {share:.3} of it");
    // A Mantaflow fire: flame and temperature on the density's lattice, each with
    // other bounds than the density's (cells visited where only they are non-zero).
    let o = options("32x18");
    let share = emission_share("caches/mantaflow_fire.vdb", &o);
    assert!(
        share > 10.0 * RADIANCE_RMSE,
        "mantaflow_fire: emission {share:.3}"
    );
    gpu_matches_cpu("caches/mantaflow_fire.vdb", &o);
}

#[test]
fn the_gpu_tints_scattering_by_colour_grids_under_single_and_fast() {
    need_gpu!();
    // Houdini's Cd (one grid of three channels) and temperature, with the fast
    // mode's lattice; Blender's color_r/g/b (three grids) and temperature.
    let o = options("32x18");
    gpu_matches_cpu("houdini_pyro.vdb", &fast(&o));
    gpu_matches_cpu("blender_smoke.vdb", &o);
}

#[test]
fn the_gpu_scatters_through_water_drops_phase_tables_under_single_and_fast() {
    need_gpu!();
    let mut o = options("32x18");
    o.phase = Some(murk::integrate::phase::PhaseKind::WaterDrop);
    let (beauty, _) = gpu_matches_cpu("cloud.vdb", &o);
    eprintln!("cloud.vdb, water drops, single: radiance rel. RMSE {beauty:e}");
    // Lit from behind: the drops' forward peak (under a milliradian wide for 500 µm
    // drops) is in view, where a table resampled evenly, or angles from the cosine in
    // f32, missed the CPU.
    let mut behind = forward_peaked_sphere();
    behind.phase = o.phase;
    let (beauty, _) = gpu_matches_cpu("sphere.vdb", &behind);
    eprintln!("sphere.vdb, water drops lit from behind: radiance rel. RMSE {beauty:e}");
    // The lattice's ḡ is the drops' mean cosine, as on the CPU.
    gpu_gathers_the_cpus_lattice("cloud.vdb", &o);
}

/// A ball of `radius` (world) around `centre`, `1 − r/radius` times `peak` inside, on
/// the lattice `index_to_world`, as the voxels of a grid named `name`.
fn ball(name: &str, index_to_world: DMat4, centre: DVec3, radius: f64, peak: f32) -> FloatGridOut {
    let to_index = index_to_world.inverse();
    let (lo, hi) = (
        to_index.transform_point3(centre - DVec3::splat(radius * 2.0)),
        to_index.transform_point3(centre + DVec3::splat(radius * 2.0)),
    );
    let (lo, hi) = (lo.min(hi).floor().as_ivec3(), lo.max(hi).ceil().as_ivec3());
    let mut voxels = Vec::new();
    for i in lo.x..=hi.x {
        for j in lo.y..=hi.y {
            for k in lo.z..=hi.z {
                let w = index_to_world.transform_point3(DVec3::new(i as f64, j as f64, k as f64));
                let r = (w - centre).length() / radius;
                if r < 1.0 {
                    voxels.push((IVec3::new(i, j, k), peak * (1.0 - r as f32)));
                }
            }
        }
    }
    FloatGridOut {
        name: name.into(),
        index_to_world,
        voxels,
        metadata: vec![],
    }
}

/// A VDB (written in a scratch folder `dir`) of a density ball, flame on a rotated,
/// finer lattice and temperature on the density's voxel size shifted by a fraction of
/// a voxel (no integer offset: sampled through the map between the lattices, at each
/// segment's midpoint, as the CPU does).
pub(super) fn three_lattices(dir: &str) -> PathBuf {
    let density = ball(
        "density",
        DMat4::from_scale(DVec3::splat(0.1)),
        DVec3::ZERO,
        0.8,
        1.0,
    );
    let rotated = DMat4::from_translation(DVec3::new(0.013, 0.021, -0.017))
        * DMat4::from_rotation_z(0.3)
        * DMat4::from_scale(DVec3::splat(0.07));
    let flame = ball("flame", rotated, DVec3::new(0.1, -0.1, 0.0), 0.5, 1.0);
    let shifted = DMat4::from_translation(DVec3::new(0.043, 0.0, 0.021))
        * DMat4::from_scale(DVec3::splat(0.1));
    let temperature = ball(
        "temperature",
        shifted,
        DVec3::new(-0.1, 0.2, 0.0),
        0.6,
        2500.0,
    );
    let path = scratch(dir).join("lattices.vdb");
    write_float_grids(&path, &[density, flame, temperature], &[]).unwrap();
    path
}

#[test]
fn the_gpu_samples_flame_and_temperature_on_other_lattices_than_the_density() {
    need_gpu!();
    let path = three_lattices("gpu-lattices");
    let input = path.to_str().unwrap();
    let mut o = options("32x18");
    o.eye = Some("0,0,3".into());
    o.look_at = Some("0,0,0".into());
    o.temperature_scale = Some(1.0);
    o.temperature_offset = Some(0.0);
    let share = emission_share(input, &o);
    assert!(share > 0.3, "emission is {share:.3} of the image");
    let (beauty, _) = gpu_matches_cpu(input, &o);
    eprintln!("three lattices: radiance rel. RMSE {beauty:e}, emission {share:.3} of it");
}
