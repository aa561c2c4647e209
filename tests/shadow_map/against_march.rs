//! The map against marched shadow rays: whole images and sampled points.

use super::*;

fn render(shadows: &str, extra: impl FnOnce(&mut RenderOptions)) -> murk::output::Frame {
    let mut o = RenderOptions {
        output: Some(std::env::temp_dir().join("murk-unused.exr")),
        res: Some("96x54".into()),
        shadows: Some(shadows.into()),
        shadow_step: Some(0.25),
        quiet: true,
        ..Default::default()
    };
    extra(&mut o);
    let plan = RenderPlan::new(&o, fixture_path("cloud.vdb")).unwrap();
    render_image(&plan).unwrap().frame
}

/// On the demo cloud, the images with the map and with marched shadows differ by at most
/// twice the tolerance, per pixel, relative to the light's intensity (6).
#[test]
fn demo_cloud_dsm_matches_marched_shadows() {
    let dsm = render("dsm", |_| {});
    let march = render("march", |_| {});
    let mut worst: f64 = 0.0;
    for c in ["R", "G", "B", "A"] {
        for (a, b) in dsm
            .channel(c)
            .unwrap()
            .iter()
            .zip(march.channel(c).unwrap())
        {
            worst = worst.max((a - b).abs() as f64);
        }
    }
    assert!(
        worst / 6.0 <= 2.0 * TOL,
        "max |Δ| {worst} (relative {})",
        worst / 6.0
    );
    // And the map is not a no-op: without shadows the image is far brighter.
    let none = render("none", |_| {});
    let r_none: f32 = none.channel("R").unwrap().iter().sum();
    let r_dsm: f32 = dsm.channel("R").unwrap().iter().sum();
    assert!(r_none > 1.5 * r_dsm, "{r_none} vs {r_dsm}");
}

/// The tolerance holds pointwise on three fixtures: at 10,000 random points inside the
/// density, the map's transmittance differs from an exact marched shadow ray by at most
/// the tolerance, in every channel. Three suns each: the default one (oblique to every
/// voxel face: Hermite across), one along a voxel axis (linear across both ways) and
/// one parallel to one family of voxel faces (linear one way, Hermite the other).
#[test]
fn tolerance_holds_at_sampled_points_on_three_fixtures() {
    for name in ["cloud.vdb", "levelset_fog.vdb", "pyro.vdb"] {
        let g = fixture(name);
        for sun in [
            DVec3::new(0.6, 1.0, 0.5),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.6, 1.0, 0.0),
        ] {
            let light = LightGeometry::Sun {
                travel: -sun.normalize(),
            };
            let (map, _) = bake(&g, light, &settings());
            let r = murk::shadow::verify(&map, &g, light, DVec3::splat(SIGMA), TOL, 10_000, 11);
            assert_eq!(r.points, 10_000, "{name}");
            assert!(r.max_error <= TOL, "{name}, sun {sun}: {r:?}");
            assert_eq!(r.over_tolerance, 0, "{name}, sun {sun}: {r:?}");
        }
    }
}
