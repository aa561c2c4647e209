//! The march against closed forms. Orthographic rays, pixel centres; `p` is the phase
//! value, `E` the sun's irradiance, `μ` the cosine between the ray and the slab normal.

mod common;

use common::march::{Sun, fixture, medium, ray, rel};
use glam::DVec3;
use murk::field::shapes::{ConstantBox, ConstantSphere};
use murk::integrate::phase::hg;
use murk::integrate::{Companion, Emission, Volume};

const STEPS: [f64; 4] = [0.25, 0.5, 1.0, 2.0];

/// Alpha through the slab fixture (voxels k = 0..19 at 0.05, value 1): the trilinear
/// reconstruction ramps over one voxel on each side, and ∫ρ dz = 20 voxels = D = 1.0 world
/// unit, so α = 1 − e^{−σt·D/μ} — for any step, because optical depth is integrated
/// voxel by voxel exactly.
#[test]
fn slab_alpha_is_exact_at_every_step() {
    let slab = fixture("slab.vdb");
    for sigma_t in [0.3, 1.5, 6.0] {
        let vol = Volume::of(&slab, medium(sigma_t, 0.0, 0.0));
        for mu in [1.0f64, 0.8, 0.5] {
            let d = DVec3::new((1.0 - mu * mu).sqrt(), 0.0, -mu);
            let want = -(-sigma_t * 1.0 / mu).exp_m1();
            for step in STEPS {
                for jitter in [0.5, 0.1, 0.93] {
                    // Crossing the slab's mid-plane near its centre, from above.
                    let o = DVec3::new(0.013, -0.021, 0.475) - d * 3.0;
                    let got = ray(&vol, None, o, d, step, jitter).alpha();
                    assert!(
                        rel(got, want) <= 1e-4,
                        "σt {sigma_t} μ {mu} step {step}: α {got} vs {want}"
                    );
                    assert!(
                        rel(got, want) <= 1e-6,
                        "σt {sigma_t} μ {mu} step {step}: α {got} vs {want} (exactness lost)"
                    );
                }
            }
        }
    }
}

/// Alpha through a homogeneous sphere along a chord ℓ = 2√(R² − b²): α = 1 − e^{−σt·ℓ}.
#[test]
fn sphere_alpha_is_exact_along_every_chord() {
    let r = 1.0;
    let sphere = ConstantSphere::new(DVec3::new(0.1, -0.2, 0.3), r, 1.0, 0.05).unwrap();
    let sigma_t = 2.0;
    let vol = Volume::of(&sphere, medium(sigma_t, 0.0, 0.0));
    for b in [0.0, 0.3, 0.7, 0.95, 0.999] {
        let ell = 2.0 * (r * r - b * b).sqrt();
        let want = -(-sigma_t * ell).exp_m1();
        for step in STEPS {
            let o = sphere.center() + DVec3::new(b, 0.0, 3.0);
            let got = ray(&vol, None, o, DVec3::NEG_Z, step, 0.37).alpha();
            assert!(
                rel(got, want) <= 1e-9,
                "b {b} step {step}: α {got} vs {want}"
            );
        }
    }
}

/// Emission–absorption slab: emission ε = σ·S·ρ per world unit, so L = S(1 − e^{−σD/μ}).
#[test]
fn emission_absorption_slab() {
    let slab = fixture("slab.vdb");
    let s = 0.7;
    for sigma in [1e-8, 1e-3, 0.5, 4.0, 1e4] {
        let emission = Emission::grey(Companion::new(&slab, &slab), sigma * s);
        let vol = Volume {
            emission: Some(emission),
            ..Volume::of(&slab, medium(sigma, 0.0, 0.0))
        };
        let mu: f64 = 0.6;
        let d = DVec3::new((1.0 - mu * mu).sqrt(), 0.0, -mu);
        let want = s * -(-sigma / mu).exp_m1();
        for step in STEPS {
            let o = DVec3::new(0.0, 0.0, 0.475) - d * 3.0;
            let r = ray(&vol, None, o, d, step, 0.5);
            assert!(
                rel(r.emission.x, want) <= 1e-6,
                "σD {sigma} step {step}: L {} vs {want}",
                r.emission.x
            );
            assert!(r.emission.is_finite() && r.alpha() <= 1.0);
        }
    }
}

// Single scattering on a homogeneous sphere: `s2_homogeneous_sphere` in accuracy.rs,
// at every step of the default march and by the reference.

/// A box lit from the side is a check that shadows are applied where the closed form is
/// simple: a thin slab of the box seen edge-on… instead, the bounds every result must
/// respect: 0 ≤ α ≤ 1 and scatter ≤ albedo·p_max·E for any ray, at extreme σt·ds.
#[test]
fn extreme_optical_thickness_stays_finite_and_bounded() {
    let cube = ConstantBox::new(DVec3::splat(-0.5), DVec3::splat(0.5), 1.0, 0.05).unwrap();
    for sigma_t in [1e-10, 1e-4, 1.0, 1e3, 1e6] {
        let vol = Volume::of(&cube, medium(sigma_t * 0.2, sigma_t * 0.8, 0.0));
        let sun = Sun {
            field: &cube,
            toward: DVec3::new(1.0, 1.0, 0.3).normalize(),
            irradiance: 2.0,
        };
        for step in STEPS {
            let r = ray(
                &vol,
                Some(&sun),
                DVec3::new(0.1, 0.2, 3.0),
                DVec3::new(0.05, -0.02, -1.0),
                step,
                0.5,
            );
            let a = r.alpha();
            assert!(
                (0.0..=1.0).contains(&a) && r.scatter.is_finite() && r.transmittance.is_finite(),
                "σt {sigma_t}: {r:?}"
            );
            assert!(
                r.scatter.x >= 0.0 && r.scatter.x <= 0.8 * hg(1.0, 0.0) * 2.0 + 1e-12,
                "σt {sigma_t}: {r:?}"
            );
            // Optical depth is ~σt (chord ≈ 1): α must follow it, also when tiny.
            if sigma_t < 1e-3 {
                assert!(
                    a > 0.5 * sigma_t && a < 2.0 * sigma_t,
                    "σt {sigma_t}: α {a}"
                );
            }
        }
    }
}
