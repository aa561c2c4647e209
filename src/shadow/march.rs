//! Shadow rays: `∫ρ ds` from a point toward a light, marched over the field's hierarchy.

use crate::accel::{IndexRay, Spans};
use crate::field::{Field, Quadrature};
use glam::DVec3;

/// How a shadow ray integrates density inside non-constant cells.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ShadowQuadrature {
    /// Midpoint rule on equal sub-steps of at most this many voxels (the field's exact
    /// integral where it is a closed form).
    Step(f64),
    /// The field's exact integral everywhere (per voxel for grids): the reference.
    Exact,
}

/// `∫ρ ds` (density × world distance) from `from` along the unit direction `toward`, up
/// to `max_dist`. Cells of constant density are integrated exactly; the others as
/// `quadrature` says. Stops once the integral exceeds `enough` (the caller's point of
/// zero transmittance).
pub fn density_integral(
    field: &dyn Field,
    from: DVec3,
    toward: DVec3,
    max_dist: f64,
    quadrature: ShadowQuadrature,
    enough: f64,
) -> f64 {
    let ray = IndexRay::new(field, from, toward);
    let speed = ray.index_speed();
    if !(speed > 0.0) || !speed.is_finite() {
        return 0.0;
    }
    let step = match quadrature {
        ShadowQuadrature::Step(s) if field.quadrature() != Quadrature::ClosedForm => {
            Some(s.max(1e-6) / speed)
        }
        _ => None,
    };
    let mut sum = 0.0;
    for span in Spans::new(field, ray, 0.0, max_dist) {
        let len = span.t1 - span.t0;
        if span.range.is_constant() {
            sum += span.range.max as f64 * len;
        } else if let Some(h) = step {
            let n = (len / h).ceil().clamp(1.0, 1e7);
            let ds = len / n;
            let mut acc = 0.0;
            for k in 0..n as u64 {
                acc += field.value_at_index(ray.at(span.t0 + (k as f64 + 0.5) * ds)) as f64;
            }
            sum += acc * ds;
        } else {
            sum += exact_integral(field, &ray, span.t0, span.t1);
        }
        if sum > enough {
            break;
        }
    }
    sum
}

/// `∫ρ dt` over `[t0, t1]` of a stretch inside one cell, as exactly as the field allows:
/// its own integral where that is exact, else two-point Gauss–Legendre on pieces of at
/// most one voxel.
pub fn exact_integral(field: &dyn Field, ray: &IndexRay, t0: f64, t1: f64) -> f64 {
    if field.quadrature() != Quadrature::Approximate {
        return field.integral(ray, t0, t1);
    }
    let len = t1 - t0;
    let n = (len * ray.index_speed()).ceil().clamp(1.0, 1e7);
    let ds = len / n;
    (0..n as u64)
        .map(|k| field.integral(ray, t0 + k as f64 * ds, t0 + (k + 1) as f64 * ds))
        .sum()
}
