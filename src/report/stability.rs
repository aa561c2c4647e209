//! `murk check-stability`: a fixed battery of stiff and extreme inputs. Every case must
//! give no NaN or Inf, `0 ≤ α ≤ 1` and radiance under its analytic bound, and match its
//! closed form (or the image it must equal).
//!
//! Cases that need f64 answers march rays directly through the render's own code
//! (the march, [`SceneLights`] with exact marched shadows); the others write a small
//! `.vdb` to a temporary directory and render it from a plan, as `murk render` would
//! ([`super::stability_rendered`]).

use super::ReportError;
use super::check::{CaseResult, Check, scatter_bound};
use super::stability_rendered::{
    Scratchpad, bad_voxels, empty_grid, hot_temperature, single_voxel, translated,
};
use crate::field::shapes::{ConstantBox, ConstantSphere};
use crate::field::{Field, VoxelGrid};
use crate::integrate::phase::hg;
use crate::integrate::{
    Companion, Emission, Illumination, MarchSettings, Medium, RayResult, Scratch, Volume, WorldRay,
    march,
};
use crate::scene::light::Light;
use crate::scene::lights::{LightShadow, SceneLights};
use crate::shadow::ShadowQuadrature;
use glam::{DMat4, DVec3, IVec3};

type Result<T> = std::result::Result<T, ReportError>;

fn grey_medium(sigma_a: f64, sigma_s: f64, g: f64) -> Medium {
    Medium {
        sigma_a: DVec3::splat(sigma_a),
        sigma_s: DVec3::splat(sigma_s),
        density_scale: 1.0,
        g,
    }
}

/// The render's lights over `field`, with exact marched shadows (the reference's).
fn marched_lights<'a>(lights: &'a [Light], field: &'a dyn Field) -> SceneLights<'a> {
    SceneLights {
        lights,
        density: field,
        shadows: lights
            .iter()
            .map(|_| LightShadow::Marched)
            .collect::<Vec<_>>()
            .into(),
        quadrature: ShadowQuadrature::Exact,
        enough: f64::INFINITY,
    }
}

fn sun(spec: &str) -> Vec<Light> {
    vec![Light::parse(spec, "sun0".into()).expect("a valid sun")]
}

fn trace(
    vol: &Volume,
    lights: Option<&SceneLights>,
    o: DVec3,
    d: DVec3,
    settings: &MarchSettings,
) -> RayResult {
    let mut scratch = Scratch::new(lights.map_or(0, |l| l.light_count()));
    march(
        vol,
        lights.map(|l| l as &dyn Illumination),
        &WorldRay::new(o, d),
        settings,
        0.5,
        &mut scratch,
    )
}

fn exact(step_voxels: f64) -> MarchSettings {
    MarchSettings {
        step_voxels,
        termination: 0.0,
    }
}

/// σt·ds per step from 1e-10 to 1e6 on a homogeneous slab (depth D = 1, voxel 0.05, step
/// 0.5 voxel), sun behind the camera: `L = σs·p·E(1 − e^{−2σt D})/(2σt)`,
/// `α = 1 − e^{−σt D}`.
fn stiff_slab() -> CaseResult {
    let slab = ConstantBox::new(
        DVec3::new(-4.0, -4.0, 0.0),
        DVec3::new(4.0, 4.0, 1.0),
        1.0,
        0.05,
    )
    .expect("a valid box");
    let lights = sun("sun:0,0,1:1,1,1:2");
    let (e, g, albedo) = (2.0, 0.3, 0.8);
    let ds = 0.5 * 0.05;
    let mut check = Check::new(scatter_bound(&lights, 1.0 - albedo, albedo, g), 1e-6);
    let sl = marched_lights(&lights, &slab);
    let mut exponent = -10;
    while exponent <= 6 {
        let sigma_t = 10f64.powi(exponent) / ds;
        let vol = Volume::of(
            &slab,
            grey_medium(sigma_t * (1.0 - albedo), sigma_t * albedo, g),
        );
        for o in [DVec3::new(0.1, 0.2, 3.0), DVec3::new(-1.37, 0.53, 3.0)] {
            let r = trace(&vol, Some(&sl), o, DVec3::NEG_Z, &exact(0.5));
            check.ray(&r);
            let want_l =
                sigma_t * albedo * hg(-1.0, g) * e * -(-2.0 * sigma_t).exp_m1() / (2.0 * sigma_t);
            check.compare(&format!("σt·ds 1e{exponent} L"), r.scatter.x, want_l);
            check.compare(
                &format!("σt·ds 1e{exponent} α"),
                r.alpha(),
                -(-sigma_t).exp_m1(),
            );
        }
        exponent += 1;
    }
    check.note("σt·ds = 1e-10 … 1e6, 17 decades".into());
    check.finish(
        "stiff_slab",
        "σt·ds from 1e-10 to 1e6 on the homogeneous slab, closed form each time",
    )
}

/// A million steps of optical depth 1e-8 (emission on, so steps are not lengthened):
/// `T = e^{−0.01}`, not 1.
fn thin_media() -> CaseResult {
    let slab = ConstantBox::new(
        DVec3::new(-1.0, -1.0, 0.0),
        DVec3::new(1.0, 1.0, 1.0),
        1.0,
        0.05,
    )
    .expect("a valid box");
    let steps = 1_000_000.0;
    let sigma_t = 0.01;
    let emission = Emission::grey(Companion::new(&slab, &slab), sigma_t * 0.5);
    let vol = Volume {
        emission: Some(emission),
        ..Volume::of(&slab, grey_medium(sigma_t, 0.0, 0.0))
    };
    // 20 voxels deep: 1e6 steps of 2e-5 voxel, each of optical depth 1e-8.
    let r = trace(
        &vol,
        None,
        DVec3::new(0.1, 0.1, 2.0),
        DVec3::NEG_Z,
        &exact(20.0 / steps),
    );
    let mut check = Check::new(0.5, 1e-9);
    check.ray(&r);
    check.compare("T", r.transmittance.x, (-0.01f64).exp());
    check.compare("α", r.alpha(), -(-0.01f64).exp_m1());
    check.compare("L", r.emission.x, 0.5 * -(-0.01f64).exp_m1());
    if (r.samples as f64) < steps {
        check.fail(format!("only {} steps taken", r.samples));
    }
    check.note(format!(
        "{} steps, T = {:.15}",
        r.samples, r.transmittance.x
    ));
    check.finish(
        "thin_media",
        "a million steps of optical depth 1e-8: T = e^{-0.01}",
    )
}

/// Voxels of a sheet one voxel thick (layer k = 0), density `rho`, `half` voxels each way.
fn sheet_voxels(rho: f32, half: i32) -> Vec<(IVec3, f32)> {
    (-half..half)
        .flat_map(|i| (-half..half).map(move |j| (IVec3::new(i, j, 0), rho)))
        .collect()
}

/// A one-voxel sheet crossed at 30° by rays of many phases against the grid:
/// `T = e^{−σt·ρh/cos θ}`, at the reference step and the default one.
fn sheet_at_thirty_degrees() -> Result<CaseResult> {
    let (rho, h, sigma_t) = (0.8f32, 0.1, 3.0);
    let sheet = VoxelGrid::from_voxels(
        "density",
        sheet_voxels(rho, 48),
        DMat4::from_scale(DVec3::splat(h)),
    )?;
    let vol = Volume::of(&sheet, grey_medium(sigma_t, 0.0, 0.0));
    let theta = 30f64.to_radians();
    let want = (-sigma_t * rho as f64 * h / theta.cos()).exp();
    let mut check = Check::new(0.0, 1e-9);
    for azimuth in [0.0f64, 0.7, 1.9, 3.3] {
        let d = DVec3::new(
            theta.sin() * azimuth.cos(),
            theta.sin() * azimuth.sin(),
            -theta.cos(),
        );
        for n in 0..40 {
            let o = DVec3::new(n as f64 * 0.01373, n as f64 * 0.02917, 0.0) - d;
            for settings in [MarchSettings::reference(), exact(0.5)] {
                let r = trace(&vol, None, o, d, &settings);
                check.ray(&r);
                check.compare("T", r.transmittance.x, want);
            }
        }
    }
    Ok(check.finish(
        "sheet_30deg",
        "a one-voxel sheet at 30°: exact transmittance whatever the ray's phase",
    ))
}

/// Rays parallel to voxel faces (±0 direction components, on face planes) and rays
/// grazing the grid's bounds, through a slab 20 voxels thick (∫ρ = 1 world unit).
fn parallel_and_grazing() -> Result<CaseResult> {
    let voxels = (-16..16).flat_map(|i| {
        (-16..16).flat_map(move |j| (0..20).map(move |k| (IVec3::new(i, j, k), 1.0f32)))
    });
    let slab = VoxelGrid::from_voxels("density", voxels, DMat4::from_scale(DVec3::splat(0.05)))?;
    let (sigma_a, sigma_s, g) = (0.3, 1.7, 0.2);
    let vol = Volume::of(&slab, grey_medium(sigma_a, sigma_s, g));
    let lights = sun("sun:0.3,0.2,1:1,1,1:3");
    let sl = marched_lights(&lights, &slab);
    let mut check = Check::new(scatter_bound(&lights, sigma_a, sigma_s, g), 1e-9);
    let sigma_t = sigma_a + sigma_s;
    // Straight down, with every sign of zero, on and between voxel face planes.
    let mut first: Option<RayResult> = None;
    for (dx, dy) in [(0.0, 0.0), (-0.0, 0.0), (0.0, -0.0), (-0.0, -0.0)] {
        for (x, y) in [(0.0, 0.0), (0.05, -0.1), (0.025, 0.0), (0.1, 0.0375)] {
            let r = trace(
                &vol,
                Some(&sl),
                DVec3::new(x, y, 2.0),
                DVec3::new(dx, dy, -1.0),
                &exact(0.5),
            );
            check.ray(&r);
            check.compare("α down", r.alpha(), -(-sigma_t * 1.0f64).exp_m1());
            if x == 0.0 && y == 0.0 {
                match &first {
                    None => first = Some(r),
                    Some(f) => check.compare("±0 directions agree", r.scatter.x, f.scatter.x),
                }
            }
        }
    }
    // Along x inside the slab, on a voxel face plane (z = 10 voxels) and between planes:
    // 32 voxels of density 1: a 31-voxel plateau and a half-voxel ramp at each end.
    for z in [0.5, 0.525, 0.3] {
        for dy in [0.0, -0.0] {
            let r = trace(
                &vol,
                Some(&sl),
                DVec3::new(-3.0, 0.0, z),
                DVec3::new(1.0, dy, 0.0),
                &exact(0.5),
            );
            check.ray(&r);
            check.compare(
                "α along x",
                r.alpha(),
                -(-sigma_t * 32.0 * 0.05f64).exp_m1(),
            );
        }
    }
    // Grazing: along the top and bottom of the reconstruction (where density is 0) and
    // along the grid's side faces, and a ray just inside the top.
    for (o, d) in [
        (DVec3::new(-3.0, 0.0, 1.0), DVec3::X),
        (DVec3::new(-3.0, 0.0, -0.05), DVec3::X),
        (DVec3::new(-0.8, -3.0, 0.4), DVec3::Y),
        (DVec3::new(0.75, -3.0, 0.4), DVec3::new(0.0, 1.0, 1e-12)),
        (
            DVec3::new(-3.0, 0.0, 0.95 + 1e-9),
            DVec3::new(1.0, 0.0, -1e-15),
        ),
    ] {
        let r = trace(&vol, Some(&sl), o, d, &exact(0.5));
        check.ray(&r);
    }
    Ok(check.finish(
        "parallel_grazing",
        "rays parallel to voxel faces (±0 components) and grazing the grid",
    ))
}

/// The camera at the centre of a homogeneous sphere (R = 1), sun behind it, pixel at
/// offset b: `L = σs·p·E·e^{−σt h}(1 − e^{−2σt h})/(2σt)`, `α = 1 − e^{−σt h}`,
/// `h = √(R² − b²)`.
fn camera_inside() -> CaseResult {
    let sphere = ConstantSphere::new(DVec3::ZERO, 1.0, 1.0, 0.05).expect("a valid sphere");
    let (sigma_a, sigma_s, e, g) = (0.4, 1.1, 3.0, 0.3);
    let sigma_t = sigma_a + sigma_s;
    let lights = sun("sun:0,0,1:1,1,1:3");
    let vol = Volume::of(&sphere, grey_medium(sigma_a, sigma_s, g));
    let sl = marched_lights(&lights, &sphere);
    let mut check = Check::new(scatter_bound(&lights, sigma_a, sigma_s, g), 1e-9);
    for b in [0.0f64, 0.3, 0.6, 0.9, 0.99] {
        let h: f64 = (1.0 - b * b).sqrt();
        let r = trace(
            &vol,
            Some(&sl),
            DVec3::new(b, 0.0, 0.0),
            DVec3::NEG_Z,
            &MarchSettings::reference(),
        );
        check.ray(&r);
        let want =
            sigma_s * hg(-1.0, g) * e * (-sigma_t * h).exp() * -(-2.0 * sigma_t * h).exp_m1()
                / (2.0 * sigma_t);
        check.compare("L", r.scatter.x, want);
        check.compare("α", r.alpha(), -(-sigma_t * h).exp_m1());
    }
    check.finish(
        "camera_inside",
        "the camera inside the volume (sphere centre, closed form)",
    )
}

/// Runs every case, in order. A case that cannot run at all (a file it cannot write) is
/// a failed case, not an error of the command.
pub fn run_battery() -> Result<Vec<CaseResult>> {
    let pad = Scratchpad::new()?;
    let mut results = vec![stiff_slab(), thin_media()];
    let failed = |name: &str, e: ReportError| CaseResult {
        name: name.into(),
        what: "could not run".into(),
        pass: false,
        samples: 0,
        nan_inf: 0,
        alpha_min: 0.0,
        alpha_max: 0.0,
        radiance_max: 0.0,
        radiance_bound: 0.0,
        max_error: f64::INFINITY,
        tolerance: 0.0,
        detail: e.to_string(),
    };
    type Case<'a> = (&'a str, Box<dyn Fn() -> Result<CaseResult> + 'a>);
    let cases: Vec<Case> = vec![
        ("bad_voxels", Box::new(|| bad_voxels(&pad))),
        ("sheet_30deg", Box::new(sheet_at_thirty_degrees)),
        ("parallel_grazing", Box::new(parallel_and_grazing)),
        ("camera_inside", Box::new(|| Ok(camera_inside()))),
        ("translated", Box::new(|| translated(&pad))),
        ("empty_grid", Box::new(|| empty_grid(&pad))),
        ("single_voxel", Box::new(|| single_voxel(&pad))),
        ("hot_temperature", Box::new(|| hot_temperature(&pad))),
    ];
    for (name, case) in cases {
        results.push(case().unwrap_or_else(|e| failed(name, e)));
    }
    Ok(results)
}

/// The table `murk check-stability` prints.
pub fn table(results: &[CaseResult]) -> String {
    let mut s = String::from(
        "| case | result | NaN/Inf | alpha range | max radiance / bound | max error (tol) | what |\n|---|---|---|---|---|---|---|\n",
    );
    for r in results {
        s += &format!(
            "| {} | {} | {} | [{:.3}, {:.3}] | {:.3e} / {:.3e} | {:.1e} ({:.0e}) | {}{} |\n",
            r.name,
            if r.pass { "pass" } else { "FAIL" },
            r.nan_inf,
            r.alpha_min,
            r.alpha_max,
            r.radiance_max,
            r.radiance_bound,
            r.max_error,
            r.tolerance,
            r.what,
            if r.detail.is_empty() {
                String::new()
            } else {
                format!(" — {}", r.detail)
            },
        );
    }
    s
}
