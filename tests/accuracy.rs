//! The reference mode against closed forms (murk reports its own error against run time).
//!
//! Orthographic rays through pixel centres (jitter 0.5), `p` the phase value, `E` the
//! sun's irradiance, `a = σs/σt`, `μv` the cosine between the view ray and the slab
//! normal, `μl` the sun's:
//!
//! - **S1** emission–absorption slab: `L = S(1 − e^{−σD/μv}) + B·e^{−σD/μv}`,
//!   `α = 1 − e^{−σD/μv}`, σD from 1e-8 to 1e4;
//! - **S2** homogeneous sphere, chord ℓ: `α = 1 − e^{−σt ℓ}`; sun behind the camera
//!   `L = σs·p·E(1 − e^{−2σt ℓ})/(2σt)`; sun behind the sphere `L = σs·p·E·ℓ·e^{−σt ℓ}`;
//!   camera at the centre, `h = √(R² − b²)`: `L = σs·p·E·e^{−σt h}(1 − e^{−2σt h})/(2σt)`,
//!   `α = 1 − e^{−σt h}`;
//! - **S3** stratified slab σt(z) (a linear ramp), sun grazing at μl = 0.05:
//!   `L = a·p·E(1 − e^{−Kτ_D})/(μv·K)`, `K = 1/μv + 1/μl`, `α = 1 − e^{−τ_D/μv}` — the
//!   profile drops out once depth is measured in optical depth τ;
//! - **S4** one-voxel sheet (density ρ, voxel h) crossed at θ: `T = e^{−ρh/cos θ}` for
//!   every pixel.
//!
//! The reference ([`MarchSettings::reference`], exact shadow optical depth) must meet
//! every one to 1e-9 relative; the default march the homogeneous ones to 1e-5 at every
//! step (S3 and S4 exactly), and its error on a smooth heterogeneous field must fall
//! with order ≥ 1.9 in the step.

mod common;

use common::march::{Sun, fixture, grey, medium, ray, ray_with, rel};
use glam::{DMat4, DVec3, IVec3};
use murk::field::VoxelGrid;
use murk::field::shapes::ConstantSphere;
use murk::integrate::phase::hg;
use murk::integrate::{Companion, Emission, MarchSettings, RayResult, Volume};
use murk::render::{RenderOptions, RenderPlan};
use murk::scene::plan::ShadowMode;
use murk::shadow::ShadowQuadrature;

const STEPS: [f64; 5] = [0.125, 0.25, 0.5, 1.0, 2.0];

fn reference(vol: &Volume, sun: Option<&Sun>, o: DVec3, d: DVec3) -> RayResult {
    ray_with(vol, sun, o, d, &MarchSettings::reference(), 0.5)
}

/// S1 on the slab fixture (∫ρ dz = 20 voxels of 0.05 = D = 1): emission ε = σ·S·ρ, a
/// background B behind it.
#[test]
fn s1_emission_absorption_slab() {
    let slab = fixture("slab.vdb");
    let (s, b) = (0.7, 0.3);
    for sigma in [1e-8, 1e-5, 1e-3, 0.5, 4.0, 100.0, 1e4] {
        let emission = Emission::grey(Companion::new(&slab, &slab), sigma * s);
        let vol = Volume {
            emission: Some(emission),
            ..Volume::of(&slab, medium(sigma, 0.0, 0.0))
        };
        for mu in [1.0f64, 0.6] {
            let d = DVec3::new((1.0 - mu * mu).sqrt(), 0.0, -mu);
            let o = DVec3::new(0.0, 0.0, 0.475) - d * 3.0;
            let opacity = -(-sigma / mu).exp_m1();
            let want_l = s * opacity + b * (-sigma / mu).exp();
            let check = |r: &RayResult, tol: f64, what: &str| {
                let l = r.emission.x + b * r.transmittance.x;
                assert!(
                    rel(l, want_l) <= tol,
                    "{what} σD {sigma} μ {mu}: L {l} vs {want_l}"
                );
                assert!(
                    rel(r.alpha(), opacity) <= tol,
                    "{what} σD {sigma} μ {mu}: α {} vs {opacity}",
                    r.alpha()
                );
            };
            check(&reference(&vol, None, o, d), 1e-9, "reference");
            for step in STEPS {
                check(&ray(&vol, None, o, d, step, 0.5), 1e-5, "step");
            }
        }
    }
}

/// S2: single scattering and opacity of a homogeneous sphere (R = 1), chord ℓ, by the
/// reference (1e-9) and by the default march at every step (1e-5; α 1e-9):
/// - sun behind the camera: L = σs·p·E(1 − e^{−2σt ℓ})/(2σt), α = 1 − e^{−σt ℓ};
/// - sun behind the sphere: L = σs·p·E·ℓ·e^{−σt ℓ};
/// - camera at the centre, sun behind it, h = √(R² − b²): L = σs·p·E·e^{−σt h}(1 − e^{−2σt h})/(2σt),
///   α = 1 − e^{−σt h}.
#[test]
fn s2_homogeneous_sphere() {
    let r = 1.0;
    let sphere = ConstantSphere::new(DVec3::ZERO, r, 1.0, 0.05).unwrap();
    let (sigma_a, sigma_s, e, g) = (0.4, 1.1, 3.0, 0.3);
    let sigma_t = sigma_a + sigma_s;
    let vol = Volume::of(&sphere, medium(sigma_a, sigma_s, g));
    let sun = |toward| Sun {
        field: &sphere,
        toward,
        irradiance: e,
    };
    let (behind_camera, behind_sphere) = (sun(DVec3::Z), sun(DVec3::NEG_Z));
    for b in [0.0, 0.4, 0.8, 0.99] {
        let ell = 2.0 * (r * r - b * b).sqrt();
        let h = ell / 2.0;
        let o = DVec3::new(b, 0.0, 4.0);
        let back_want =
            sigma_s * hg(-1.0, g) * e * -(-2.0 * sigma_t * ell).exp_m1() / (2.0 * sigma_t);
        let front_want = sigma_s * hg(1.0, g) * e * ell * (-sigma_t * ell).exp();
        let inside_want =
            sigma_s * hg(-1.0, g) * e * (-sigma_t * h).exp() * -(-2.0 * sigma_t * h).exp_m1()
                / (2.0 * sigma_t);
        let alpha_want = -(-sigma_t * ell).exp_m1();
        let inside_alpha_want = -(-sigma_t * h).exp_m1();
        let centre = DVec3::new(b, 0.0, 0.0);
        let cases: [(&str, f64); 2] = [("reference", 1e-9), ("step", 1e-5)];
        for (what, tol) in cases {
            let steps: &[f64] = if what == "reference" { &[0.0] } else { &STEPS };
            for &step in steps {
                let march = |sun: &Sun, o: DVec3| {
                    if what == "reference" {
                        reference(&vol, Some(sun), o, DVec3::NEG_Z)
                    } else {
                        ray(&vol, Some(sun), o, DVec3::NEG_Z, step, 0.5)
                    }
                };
                let back = march(&behind_camera, o);
                let front = march(&behind_sphere, o);
                let inside = march(&behind_camera, centre);
                // Optical depth is exact at every step, so α is held to 1e-9 in both.
                for (name, got, want, tol) in [
                    ("sun behind camera", back.scatter.x, back_want, tol),
                    ("sun behind sphere", front.scatter.x, front_want, tol),
                    ("camera inside", inside.scatter.x, inside_want, tol),
                    ("α", back.alpha(), alpha_want, 1e-9),
                    ("α inside", inside.alpha(), inside_alpha_want, 1e-9),
                ] {
                    assert!(
                        rel(got, want) <= tol,
                        "{what} {step} b {b} {name}: {got} vs {want}"
                    );
                }
            }
        }
    }
}

/// A slab stratified in z: voxel layers k = 0..NZ−1 of density ρ0 + (ρ1 − ρ0)·k/(NZ−1),
/// wide enough in x (toward the grazing sun) that light enters only through the top.
/// Voxel size 1; ∫ρ dz = Σₖ ρₖ (the trilinear reconstruction is piecewise linear).
struct Stratified {
    grid: VoxelGrid,
    column: f64,
    top: f64,
}

const NZ: i32 = 16;

fn stratified(rho0: f32, rho1: f32) -> Stratified {
    let layer = |k: i32| rho0 + (rho1 - rho0) * k as f32 / (NZ - 1) as f32;
    let mut voxels = Vec::new();
    for i in -48..=400 {
        for j in -3..=3 {
            for k in 0..NZ {
                voxels.push((IVec3::new(i, j, k), layer(k)));
            }
        }
    }
    Stratified {
        grid: VoxelGrid::from_voxels("density", voxels, DMat4::IDENTITY).unwrap(),
        column: (0..NZ).map(|k| layer(k) as f64).sum(),
        top: NZ as f64,
    }
}

/// S3 for a view direction μv: the ray, the sun, and (L, α) from the closed form.
fn s3_case(
    slab: &Stratified,
    sigma_a: f64,
    sigma_s: f64,
    g: f64,
    mu_v: f64,
) -> (DVec3, DVec3, Sun<'_>, f64, f64) {
    let (mu_l, e): (f64, f64) = (0.05, 2.0);
    let sigma_t = sigma_a + sigma_s;
    let d = DVec3::new(-(1.0 - mu_v * mu_v).sqrt(), 0.0, -mu_v);
    let toward = DVec3::new((1.0 - mu_l * mu_l).sqrt(), 0.0, mu_l);
    let o = DVec3::new(0.37, 0.3, slab.top + 2.0) - d * 2.0;
    let tau_d = sigma_t * slab.column;
    let k = 1.0 / mu_v + 1.0 / mu_l;
    let p = hg(toward.dot(d), g);
    let l = sigma_s / sigma_t * p * e * -(-k * tau_d).exp_m1() / (mu_v * k);
    let alpha = -(-tau_d / mu_v).exp_m1();
    let sun = Sun {
        field: &slab.grid,
        toward,
        irradiance: e,
    };
    (o, d, sun, l, alpha)
}

/// S3 with the reference: exact to 1e-9 although the medium is not homogeneous.
#[test]
fn s3_stratified_slab_with_a_grazing_sun() {
    let slab = stratified(0.02, 0.12);
    let (sigma_a, sigma_s, g) = (0.3, 1.2, 0.4);
    let vol = Volume::of(&slab.grid, medium(sigma_a, sigma_s, g));
    for mu_v in [1.0f64, 0.8, 0.5] {
        let (o, d, sun, l, alpha) = s3_case(&slab, sigma_a, sigma_s, g, mu_v);
        let r = reference(&vol, Some(&sun), o, d);
        assert!(
            rel(r.scatter.x, l) <= 1e-9,
            "μv {mu_v}: L {} vs {l} (rel {:e})",
            r.scatter.x,
            rel(r.scatter.x, l)
        );
        assert!(
            rel(r.alpha(), alpha) <= 1e-9,
            "μv {mu_v}: α {} vs {alpha}",
            r.alpha()
        );
        assert!(r.scatter.is_finite());
    }
}

/// The default march on S3 is exact at every step too: inside a segment it takes the
/// extinction as constant and the sun's optical depth as linear, which in a stratified
/// medium is a linear change of variable to optical depth, where the integrand is an
/// exponential it integrates exactly.
#[test]
fn s3_default_march_is_exact_at_every_step() {
    let slab = stratified(0.02, 0.12);
    let (sigma_a, sigma_s, g) = (0.3, 1.2, 0.4);
    let vol = Volume::of(&slab.grid, medium(sigma_a, sigma_s, g));
    let (o, d, sun, l, alpha) = s3_case(&slab, sigma_a, sigma_s, g, 0.8);
    for step in [4.0, 2.0, 1.0, 0.5, 0.25] {
        let r = ray(&vol, Some(&sun), o, d, step, 0.5);
        assert!(
            rel(r.alpha(), alpha) <= 1e-9,
            "step {step}: α {}",
            r.alpha()
        );
        assert!(
            rel(r.scatter.x, l) <= 1e-9,
            "step {step}: L {} vs {l}",
            r.scatter.x
        );
    }
}

/// On a smooth field that is not stratified (a Gaussian blob, lit from the side), the
/// march's error against the reference falls as step²: fitted order ≥ 1.9 (naive
/// left-endpoint marching would give 1).
#[test]
fn marching_converges_with_order_two_on_a_smooth_field() {
    let voxels = (-20..=20).flat_map(|i| {
        (-20..=20).flat_map(move |j| {
            (-20..=20).map(move |k| {
                let r2 = (i * i + j * j + k * k) as f64 / 100.0;
                (IVec3::new(i, j, k), (1.5 * (-r2).exp()) as f32)
            })
        })
    });
    let blob = VoxelGrid::from_voxels("density", voxels, DMat4::from_scale(grey(0.05))).unwrap();
    let vol = Volume::of(&blob, medium(0.5, 8.0, 0.2));
    let sun = Sun {
        field: &blob,
        toward: DVec3::new(1.0, 0.6, 0.2).normalize(),
        irradiance: 3.0,
    };
    let d = DVec3::new(0.1, -0.2, -1.0).normalize();
    let origins: Vec<DVec3> = (0..6)
        .map(|n| DVec3::new(-0.3 + 0.11 * n as f64, 0.2 - 0.07 * n as f64, 0.0) - d * 2.0)
        .collect();
    let total = |settings: &MarchSettings| -> f64 {
        origins
            .iter()
            .map(|&o| ray_with(&vol, Some(&sun), o, d, settings, 0.5).scatter.x)
            .sum()
    };
    let want = total(&MarchSettings::reference());
    let mut points = Vec::new();
    for step in [1.0, 0.5, 0.25, 0.125] {
        let err = rel(
            total(&MarchSettings {
                step_voxels: step,
                termination: 0.0,
            }),
            want,
        );
        assert!(err > 0.0 && err < 0.1, "step {step}: error {err}");
        points.push((f64::ln(step), err.ln()));
    }
    let order = murk::report::fit_slope(&points);
    assert!(
        order >= 1.9,
        "fitted order {order} (errors {:?})",
        points.iter().map(|p| p.1.exp()).collect::<Vec<_>>()
    );
}

/// S4: a one-voxel sheet (layer k = 0, density ρ, voxel h = 0.1) crossed at θ = 30°
/// from its normal by rays of every phase against the grid: T = e^{−σt·ρh/cos θ} for
/// each, at the reference and at every step.
#[test]
fn s4_one_voxel_sheet_at_thirty_degrees() {
    let (rho, h, sigma_t) = (0.8f32, 0.1, 3.0);
    let voxels = (-64..64)
        .flat_map(|i| (-64..64).map(move |j| (IVec3::new(i, j, 0), rho)))
        .collect::<Vec<_>>();
    let sheet = VoxelGrid::from_voxels("density", voxels, DMat4::from_scale(grey(h))).unwrap();
    let vol = Volume::of(&sheet, medium(sigma_t, 0.0, 0.0));
    let theta = 30f64.to_radians();
    let d = DVec3::new(theta.sin() * 0.6, theta.sin() * 0.8, -theta.cos());
    let want = (-sigma_t * rho as f64 * h / theta.cos()).exp();
    for px in 0..7 {
        for py in 0..5 {
            // Phases against the grid: offsets of irrational-ish fractions of a voxel.
            let o = DVec3::new(px as f64 * 0.0137, py as f64 * 0.0291, 0.0) - d * 1.0;
            let r = reference(&vol, None, o, d);
            assert!(
                rel(r.transmittance.x, want) <= 1e-9,
                "pixel {px},{py}: T {} vs {want}",
                r.transmittance.x
            );
            for step in STEPS {
                let r = ray(&vol, None, o, d, step, 0.5);
                assert!(rel(r.transmittance.x, want) <= 1e-9, "step {step}");
            }
        }
    }
}

/// `--reference` means: the reference march, exact shadow rays (marched), no early
/// termination; it refuses what would contradict that.
#[test]
fn reference_plan_settings_and_refusals() {
    let opts = |extra: &[&str]| {
        let mut o = RenderOptions {
            output: Some("x.exr".into()),
            reference: true,
            ..Default::default()
        };
        for pair in extra.chunks(2) {
            match pair[0] {
                "shadows" => o.shadows = Some(pair[1].into()),
                "termination" => o.termination = Some(pair[1].parse().unwrap()),
                "step" => o.step = Some(pair[1].parse().unwrap()),
                _ => unreachable!(),
            }
        }
        RenderPlan::new(&o, "in.vdb".into()).map_err(|e| e.to_string())
    };
    let plan = opts(&[]).unwrap();
    assert_eq!(plan.march_settings(), MarchSettings::reference());
    assert_eq!(plan.shadow_quadrature(), ShadowQuadrature::Exact);
    assert_eq!(plan.shadows.mode, ShadowMode::March);
    assert_eq!(
        opts(&["step", "0.25"])
            .unwrap()
            .march_settings()
            .step_voxels,
        0.25
    );
    assert!(opts(&["shadows", "march"]).is_ok());
    for bad in [
        &["shadows", "dsm"][..],
        &["shadows", "none"],
        &["termination", "1e-4"],
    ] {
        let e = opts(bad).unwrap_err();
        assert!(e.contains("--reference"), "{e}");
    }
    // Without --reference nothing changes.
    let o = RenderOptions {
        output: Some("x.exr".into()),
        ..Default::default()
    };
    let plan = RenderPlan::new(&o, "in.vdb".into()).unwrap();
    assert_eq!(plan.march_settings(), MarchSettings::default());
    assert_eq!(plan.shadow_quadrature(), ShadowQuadrature::Step(1.0));
    assert_eq!(plan.shadows.mode, ShadowMode::Dsm);
}
