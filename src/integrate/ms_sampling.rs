//! What the multiple-scattering lattice of [`super::ms_lattice`] samples: the points of
//! a cell its density and first scattering are averaged over, the directions of each
//! order, and the phase function's mean cosine (with Henyey–Greenstein, the lobe of
//! light scattered twice).

use super::march::Volume;
use glam::DVec3;

/// Henyey–Greenstein with mean cosine `g` at `cos θ = mu`, times 4π (its mean over the
/// sphere is 1).
#[inline]
pub(super) fn hg(g: f64, mu: f64) -> f64 {
    let g = g.clamp(-0.999, 0.999);
    (1.0 - g * g) / (1.0 + g * g - 2.0 * g * mu).max(1e-12).powf(1.5)
}

/// Offsets of the sub-samples of a cell around its node.
pub(super) fn sub_offsets(h: f64, n: usize) -> Vec<DVec3> {
    let at = |i: usize| ((i as f64 + 0.5) / n as f64 - 0.5) * h;
    let mut v = Vec::with_capacity(n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                v.push(DVec3::new(at(i), at(j), at(k)));
            }
        }
    }
    v
}

/// The phase function's mean cosine `∫p(μ)·μ dω` (grey part: channel 0), by the
/// midpoint rule over μ.
pub(super) fn mean_cosine(vol: &Volume) -> f64 {
    let n = 2048;
    let mut s = 0.0;
    for i in 0..n {
        let mu = -1.0 + (i as f64 + 0.5) * 2.0 / n as f64;
        s += vol.phase.eval(mu).x * mu;
    }
    (s * 2.0 / n as f64 * 2.0 * std::f64::consts::PI).clamp(-0.99, 0.99)
}

/// `n` directions spread evenly over the sphere (a Fibonacci spiral), turned for order
/// `turn` by `turn` golden angles about an axis that itself walks over the sphere, so
/// successive orders use different sets.
pub(super) fn fibonacci_sphere(n: usize, turn: u32) -> Vec<DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let spiral = |i: f64, n: f64| {
        let z = 1.0 - (2.0 * i + 1.0) / n;
        let r = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(r * (golden * i).cos(), r * (golden * i).sin(), z)
    };
    let axis = spiral((turn % 61) as f64, 61.0);
    let rot = glam::DQuat::from_axis_angle(axis.normalize(), golden * turn as f64);
    (0..n).map(|i| rot * spiral(i as f64, n as f64)).collect()
}
