//! Closed forms on the GPU: a constant slab's alpha, a holdout's cut, the clipping planes.

use super::*;

#[test]
fn a_constant_slab_seen_straight_through_has_the_closed_form_alpha() {
    need_gpu!();
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
    need_gpu!();
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
    need_gpu!();
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
