//! `--scattering fast` on the GPU: the CPU's lattice gathered in the GPU's march.

use super::*;

#[test]
fn the_gpu_gathers_the_fast_lattice_as_the_cpu_does_on_the_demo_cloud() {
    need_gpu!();
    gpu_gathers_the_cpus_lattice("cloud.vdb", &options("40x24"));
}

#[test]
fn the_gpu_gathers_the_fast_lattice_on_tiles_rotated_grids_and_several_lights() {
    need_gpu!();
    // tiles.vdb's lattice spans its 4096³ tile: its cells are coarser than the leaves
    // that scatter, so little of its image is multiply scattered; equal all the same.
    gpu_matches_cpu("tiles.vdb", &fast(&options("32x18")));
    gpu_gathers_the_cpus_lattice("rotated.vdb", &options("32x18"));
    // Two lights (a lattice and a layer each), a point light's cube map, a coloured
    // medium; a forward-peaked phase function (the lattice's similarity and ḡ² lobe).
    gpu_gathers_the_cpus_lattice("cloud.vdb", &two_lights_in_a_coloured_medium());
    gpu_gathers_the_cpus_lattice("sphere.vdb", &forward_peaked_sphere());
}
