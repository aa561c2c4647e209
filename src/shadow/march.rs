//! Shadow rays: `∫ρ ds` from a point toward a light, marched over the field's hierarchy.

use crate::accel::{IndexRay, Spans};
use crate::field::Field;
use glam::DVec3;

/// `∫ρ ds` (density × world distance) from `from` along the unit direction `toward`, up
/// to `max_dist`. Cells of constant density are integrated exactly, the others with the
/// field's own [`Field::integral`] — exact for voxel grids and the analytic shapes, and
/// on sub-steps of at most `step_voxels` for other fields. Stops early once the integral
/// exceeds `enough` (the caller's point of zero transmittance).
pub fn density_integral(
    field: &dyn Field,
    from: DVec3,
    toward: DVec3,
    max_dist: f64,
    step_voxels: f64,
    enough: f64,
) -> f64 {
    let ray = IndexRay::new(field, from, toward);
    let speed = ray.index_speed();
    if !(speed > 0.0) || !speed.is_finite() {
        return 0.0;
    }
    let h = step_voxels.max(1e-6) / speed;
    let mut sum = 0.0;
    for span in Spans::new(field, ray, 0.0, max_dist) {
        let len = span.t1 - span.t0;
        if span.range.is_constant() {
            sum += span.range.max as f64 * len;
        } else if field.integral_is_exact() {
            sum += field.integral(&ray, span.t0, span.t1);
        } else {
            let n = (len / h).ceil().clamp(1.0, 1e7);
            let ds = len / n;
            for k in 0..n as u64 {
                sum += field.integral(&ray, span.t0 + k as f64 * ds, span.t0 + (k + 1) as f64 * ds);
            }
        }
        if sum > enough {
            break;
        }
    }
    sum
}
