//! Single scattering on the GPU against the CPU's image: the demo cloud, tiles at every
//! level, rotated grids, point lights' cube maps, coloured and anisotropic media.

use super::*;

#[test]
fn the_gpu_renders_the_cpus_image_of_the_demo_cloud() {
    need_gpu!();
    let (e, _) = gpu_matches_cpu("cloud.vdb", &options("40x24"));
    eprintln!("cloud: radiance rel. RMSE {e:e}");
}

#[test]
fn the_gpu_walks_tiles_at_every_level_and_rotated_grids() {
    need_gpu!();
    // Leaves and 8³, 128³ and 4096³ tiles; an affine transform.
    gpu_matches_cpu("tiles.vdb", &options("32x18"));
    gpu_matches_cpu("rotated.vdb", &options("32x18"));
}

#[test]
fn the_gpu_looks_shadows_up_in_point_lights_cube_maps_and_anisotropic_media() {
    need_gpu!();
    // Two lights (a layer each), a point light's six charts, a coloured medium, and a
    // forward-peaked Henyey–Greenstein phase function from its table.
    gpu_matches_cpu("cloud.vdb", &two_lights_in_a_coloured_medium());
    gpu_matches_cpu("sphere.vdb", &forward_peaked_sphere());
}

#[test]
fn the_gpu_renders_the_maps_a_shadow_cache_holds() {
    need_gpu!();
    // A look re-rendered from `murk bake-shadows`'s cache after a camera move: both
    // devices read the sun's map from the file instead of baking it, and the GPU's image
    // of it is the CPU's.
    let cache = scratch("gpu-shadow-cache").join("shadows.vdb");
    let mut bake = options("16x9");
    bake.output = Some(cache.clone());
    let plan = RenderPlan::new(&bake, fixture("cloud.vdb")).unwrap();
    bake_shadow_file(&plan, &Silent).unwrap();
    let mut o = options("40x24");
    o.eye = Some("3,1,2".into());
    o.shadow_cache = Some(cache.clone());
    for device in [Device::Cpu, Device::Gpu] {
        let maps = render("cloud.vdb", &o, device).stats.scene.shadow_maps;
        assert!(
            !maps.is_empty() && maps.iter().all(|m| m.source.starts_with("cache")),
            "{device:?}: the maps came from {:?}",
            maps.iter().map(|m| &m.source).collect::<Vec<_>>()
        );
    }
    let (e, _) = gpu_matches_cpu("cloud.vdb", &o);
    eprintln!("maps from a cache: radiance rel. RMSE {e:e}");
}

#[test]
fn the_gpus_buffers_are_at_most_one_and_a_half_times_the_cpus_density_and_maps() {
    need_gpu!();
    // The memory target: what the GPU holds of the scene (the grid's nodes with
    // their cells' ranges, the maps, the lights and phase table) against the CPU's
    // density structure and shadow maps, as the stats report both.
    for input in ["cloud.vdb", "tiles.vdb"] {
        let o = options("16x9");
        let cpu = render(input, &o, Device::Cpu);
        assert_eq!(cpu.stats.scene.gpu_memory_bytes, 0, "{input}: on the CPU");
        assert_eq!(cpu.stats.scene.gpu_stream_bytes, 0, "{input}: on the CPU");
        let s = render(input, &o, Device::Gpu).stats.scene;
        // The samples' buffers, apart: two chunks of at most the frame's 144 centres
        // (16 bytes in, 4 bytes a result float out) or its silhouette pixels' 4×4 each.
        let most = 2 * 144 * 16 * (16 + 4 * 64);
        assert!(
            s.gpu_stream_bytes > 0 && s.gpu_stream_bytes <= most,
            "{input}: {} bytes streamed through",
            s.gpu_stream_bytes
        );
        let held = s.density_memory_bytes + s.shadow_map_memory_bytes;
        let ratio = s.gpu_memory_bytes as f64 / held as f64;
        eprintln!(
            "{input}: GPU {} bytes, CPU density {} + maps {} bytes: {ratio:.3}×",
            s.gpu_memory_bytes, s.density_memory_bytes, s.shadow_map_memory_bytes
        );
        assert!(
            s.gpu_memory_bytes > 0 && ratio <= 1.5,
            "{input}: the GPU holds {ratio:.3}× the CPU's"
        );
    }
}

#[test]
fn the_gpu_makes_the_cpus_jittered_rays_in_an_overscanned_frame() {
    need_gpu!();
    // Rays made on the GPU from each sample's pixel: four jittered samples a pixel, and
    // an overscan, whose pixels left of and above the image key their random streams by
    // wrapped (negative) coordinates. Jitter drawn from other numbers than the CPU's
    // moves a 4-sample pixel's mean by its noise, far past the tolerance.
    let mut o = options("24x14");
    o.spp = Some(4);
    o.overscan = Some("3,2".into());
    let (e, a) = gpu_matches_cpu("cloud.vdb", &o);
    eprintln!("jittered, overscanned: radiance rel. RMSE {e:e}, alpha RMSE {a:e}");
}
