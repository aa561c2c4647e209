//! Phase functions: the angular distribution of single scattering.
//!
//! # Angle convention
//!
//! `cos_theta` is the cosine of the **scattering angle** θ: the angle between the
//! direction the incoming light *propagates* (from the light towards the scattering
//! point) and the direction the scattered light leaves in (from the scattering point
//! towards the camera). θ = 0 means the light continues straight on (forward
//! scattering, the camera looks into the light through the medium); θ = π means it
//! bounces straight back (the light is behind the camera).
//!
//! With this convention the Henyey–Greenstein asymmetry `g > 0` is forward scattering
//! and `g < 0` back scattering, and `g` equals the mean cosine `∫ cosθ · p dΩ`.
//!
//! In renderer terms, with `view_dir` the camera ray direction (camera → point) and
//! `to_light` the direction from the point towards the light:
//! `cos_theta = dot(−to_light, −view_dir) = dot(to_light, view_dir)`; see
//! [`scattering_cosine`].

pub mod choice;
pub mod hg;
pub mod mie;
pub mod water_drop;

pub use choice::PhaseKind;
pub use hg::{G_MAX, HenyeyGreenstein, hg};
pub use water_drop::WaterDrop;

use glam::DVec3;
use std::f64::consts::PI;

/// The isotropic phase function `1/(4π)` (per steradian).
pub const ISOTROPIC: f64 = 1.0 / (4.0 * PI);

/// Cosine of the scattering angle (see the module docs) from the direction the light
/// propagates (light → point) and the direction towards the camera (point → camera).
/// Neither needs to be normalised; a zero vector gives 0 (as if perpendicular).
/// The result is clamped to `[−1, 1]`.
#[inline]
pub fn scattering_cosine(light_propagation: DVec3, toward_camera: DVec3) -> f64 {
    let c = light_propagation
        .normalize_or_zero()
        .dot(toward_camera.normalize_or_zero());
    c.clamp(-1.0, 1.0)
}

/// A direction drawn from a phase function.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhaseSample {
    /// Unit direction the scattered light propagates in.
    pub dir: DVec3,
    /// `p(θ)` per channel divided by [`PhaseSample::pdf`]: what a path's throughput is
    /// multiplied by (1 in every channel when the sampling is exact and grey).
    pub weight: DVec3,
    /// Probability density of `dir`, per steradian.
    pub pdf: f64,
}

/// The angular distribution of single scattering, per RGB channel, as a function of
/// the cosine of the scattering angle (see the module docs for the convention).
/// Every implementation integrates to 1 over the sphere in every channel.
pub trait PhaseFunction: Send + Sync {
    /// `p(cosθ)` per steradian, per channel.
    fn eval(&self, cos_theta: f64) -> DVec3;
    /// Draws the direction light propagating along `incoming` (unit) leaves in, from
    /// `u` uniform in `[0, 1)²`.
    fn sample(&self, incoming: DVec3, u: [f64; 2]) -> PhaseSample;
    /// The density [`PhaseFunction::sample`] draws a direction at scattering-angle
    /// cosine `cos_theta` with, per steradian.
    fn pdf(&self, cos_theta: f64) -> f64;
    /// True when every channel has the same value at every angle, so callers may do
    /// their arithmetic once for all three.
    fn is_grey(&self) -> bool {
        true
    }
    /// The largest value over all angles and channels (a majorant for the march).
    fn max_value(&self) -> f64;
    /// The table the phase function interpolates, where it is one (a renderer elsewhere,
    /// the GPU, then interpolates the same nodes); `None` for a closed form.
    fn table(&self) -> Option<PhaseTable<'_>> {
        None
    }
}

/// A phase function that is linear in the scattering angle θ between nodes placed as
/// [`water_drop::AngleGrid`] places them: `θᵢ = θ₀(e^{iδ} − 1)` for `i ≤ n_log`, then
/// steps of `step` from `theta_split` to π.
pub struct PhaseTable<'a> {
    pub theta0: f64,
    pub delta: f64,
    pub n_log: usize,
    pub theta_split: f64,
    pub step: f64,
    /// θ at each node.
    pub nodes: &'a [f64],
    /// The phase function at each node, per channel.
    pub values: &'a [DVec3],
    /// How [`PhaseFunction::sample`] draws θ: the cumulative probability at each node,
    /// `1 − cos θ` at each node (linear in the probability within a bin), and the
    /// sampling density of each bin (one fewer than the nodes), per steradian.
    pub cdf: &'a [f64],
    pub one_minus_cos: &'a [f64],
    pub bin_pdf: &'a [f64],
}

/// A direction at angle `acos(cos_theta)` from the unit vector `axis`, at azimuth
/// `phi` (radians) about it.
pub fn frame_around(axis: DVec3, cos_theta: f64, phi: f64) -> DVec3 {
    let c = cos_theta.clamp(-1.0, 1.0);
    let s = (1.0 - c * c).max(0.0).sqrt();
    let (t1, t2) = axis.any_orthonormal_pair();
    (axis * c + (t1 * phi.cos() + t2 * phi.sin()) * s).normalize()
}

/// Uniform over the sphere.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Isotropic;

impl PhaseFunction for Isotropic {
    fn eval(&self, _cos_theta: f64) -> DVec3 {
        DVec3::splat(ISOTROPIC)
    }
    fn sample(&self, incoming: DVec3, u: [f64; 2]) -> PhaseSample {
        PhaseSample {
            dir: frame_around(incoming, 1.0 - 2.0 * u[0], 2.0 * PI * u[1]),
            weight: DVec3::ONE,
            pdf: ISOTROPIC,
        }
    }
    fn pdf(&self, _cos_theta: f64) -> f64 {
        ISOTROPIC
    }
    fn max_value(&self) -> f64 {
        ISOTROPIC
    }
}
