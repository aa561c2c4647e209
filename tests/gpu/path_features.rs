//! `--scattering path` on the GPU with the rest of the render's features: emission and
//! blackbody temperature gathered along every flight, colour grids tinting σs at each
//! event, and the water drops' coloured phase function evaluated and sampled from its
//! table, each on the CPU's paths (the same streams: far closer than the noise).

use super::emission::{emission_share, three_lattices};
use super::path::{gpu_traces_the_cpus_paths, path};
use super::*;

#[test]
fn the_gpus_paths_gather_flame_and_blackbody_emission_as_the_cpus() {
    need_gpu!();
    // pyro.vdb: flame (its nodes offset from the density's), temperature and Cd; its
    // emission is most of the image (directly and scattered), so paths that dropped it
    // would miss by far more than the tolerance.
    let mut o = path(options("32x18"), 2);
    o.bounces = Some(4);
    let share = emission_share("pyro.vdb", &o);
    assert!(share > 0.3, "pyro.vdb: emission is {share:.3} of the image");
    gpu_traces_the_cpus_paths("pyro.vdb", &o, 1e-3, 1e-4);
    // A Mantaflow fire: flame and temperature on the density's lattice with other
    // bounds than it (gathered past the density's last block).
    let o = path(options("24x14"), 2);
    let share = emission_share("caches/mantaflow_fire.vdb", &o);
    assert!(share > 10.0 * RADIANCE_RMSE, "mantaflow_fire: {share:.3}");
    gpu_traces_the_cpus_paths("caches/mantaflow_fire.vdb", &o, 1e-3, 1e-4);
}

#[test]
fn the_gpus_paths_sample_flame_and_temperature_on_other_lattices() {
    need_gpu!();
    // Flame on a rotated, finer lattice and temperature half a voxel off the density's:
    // sampled at each piece's midpoint through the map between the lattices.
    let file = three_lattices("gpu-path-lattices");
    let input = file.to_str().unwrap();
    let mut o = path(options("24x14"), 2);
    o.eye = Some("0,0,3".into());
    o.look_at = Some("0,0,0".into());
    o.temperature_scale = Some(1.0);
    o.temperature_offset = Some(0.0);
    // (Under path the volume scatters more of the light to the camera than single.)
    let share = emission_share(input, &o);
    assert!(share > 0.2, "emission is {share:.3} of the image");
    gpu_traces_the_cpus_paths(input, &o, 1e-3, 1e-4);
}

#[test]
fn the_gpus_paths_are_tinted_by_colour_grids_as_the_cpus() {
    need_gpu!();
    // Houdini's Cd (one grid of three channels) with temperature; Blender's
    // color_r/g/b (three grids). The tint colours σs at every event.
    let o = path(options("24x14"), 2);
    gpu_traces_the_cpus_paths("houdini_pyro.vdb", &o, 1e-3, 1e-4);
    gpu_traces_the_cpus_paths("blender_smoke.vdb", &o, 1e-3, 1e-4);
}

#[test]
fn the_gpus_paths_scatter_through_water_drops_as_the_cpus() {
    need_gpu!();
    // One event: the drops' table evaluated toward the light at each path's first
    // event, as exact as single scattering's (f32 angles where the table is steep).
    let mut o = path(options("32x18"), 2);
    o.phase = Some(murk::integrate::phase::PhaseKind::WaterDrop);
    o.bounces = Some(1);
    o.light = vec!["sun:0.3,1,0.2:1,1,1:4".into()];
    gpu_traces_the_cpus_paths("cloud.vdb", &o, 1e-3, 1e-3);
    // Lit from behind: the forward peak (under a milliradian wide) in view.
    let mut behind = path(forward_peaked_sphere(), 2);
    behind.phase = o.phase;
    behind.bounces = Some(1);
    gpu_traces_the_cpus_paths("sphere.vdb", &behind, 1e-3, 1e-3);
    // Six events and the dome: the table sampled at every event (the bin, and θ in it,
    // the CPU's; the weight p/pdf per channel). The drops' weights range over orders of
    // magnitude, and a few of the paths part from the CPU's (2–4 % of the pixels here
    // differ by over 1 %), so this asserts the same image within the noise, most pixels
    // the CPU's, and the image's relative RMSE well under the seed-to-seed noise's.
    o.bounces = Some(6);
    o.light.push("env:0.3,0.4,0.6".into());
    gpu_traces_the_cpus_paths("cloud.vdb", &o, 0.2, 1e-2);
}
