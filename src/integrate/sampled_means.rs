//! The march's segment means from two density samples each (`Volume::sampled_means`).

use crate::accel::IndexRay;
use crate::field::{Field, GL2_HALF_OFFSET};

/// `out[i] = ∫ρ dt` over `[ends[i−1], ends[i]]` (`ends[−1] = a`) by two-point
/// Gauss–Legendre: the density at two points of each segment, looked up along the ray in
/// one pass (`nodes` and `values` are the scratch for them).
pub(super) fn sampled_integrals(
    density: &dyn Field,
    ray: &IndexRay,
    a: f64,
    ends: &[f64],
    (nodes, values): (&mut Vec<f64>, &mut Vec<f32>),
    out: &mut [f64],
) {
    nodes.clear();
    let mut s = a;
    for &b in ends {
        let (mid, off) = (0.5 * (s + b), GL2_HALF_OFFSET * (b - s));
        nodes.extend([mid - off, mid + off]);
        s = b;
    }
    values.resize(nodes.len(), 0.0);
    density.values_along(ray, nodes, values);
    let mut s = a;
    for (i, (&b, o)) in ends.iter().zip(out.iter_mut()).enumerate() {
        *o = 0.5 * (b - s) * (f64::from(values[2 * i]) + f64::from(values[2 * i + 1]));
        s = b;
    }
}
