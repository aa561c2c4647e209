//! `floor` without a libm call: the baseline x86-64 target has no SSE4.1 rounding
//! instruction, so `f64::floor` is a function call, and the samplers and the shadow map
//! floor several coordinates per lookup.

use glam::DVec3;

/// `floor` as an integer. For |x| < 2^30; NaN gives 0.
#[inline]
pub fn floor_i32(x: f64) -> i32 {
    let i = x as i32;
    i - ((x < i as f64) as i32)
}

/// `x.floor()` without a libm call (see [`floor_i32`]), for any `x`: beyond 2^52 every
/// f64 is an integer already, and NaN stays NaN.
#[inline]
pub fn floor_f64(x: f64) -> f64 {
    if !(x.abs() < 4.5e15) {
        return x;
    }
    let i = x as i64 as f64;
    if x < i { i - 1.0 } else { i }
}

/// [`floor_f64`] of each component.
#[inline]
pub fn floor_dvec3(p: DVec3) -> DVec3 {
    DVec3::new(floor_f64(p.x), floor_f64(p.y), floor_f64(p.z))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Agrees with libm's floor on integers, halves, values just off integers, both
    /// signs, the edges of the fast path, and beyond it; NaN stays NaN.
    #[test]
    fn matches_libm_floor() {
        let mut xs = vec![0.0, -0.0, 4.5e15, -4.5e15, 1e300, -1e300, f64::INFINITY];
        for k in [-3.0f64, -1.0, 0.0, 1.0, 7.0, 2f64.powi(40)] {
            for d in [0.0, 0.5, 1e-12, -1e-12, 0.999_999] {
                xs.push(k + d);
            }
        }
        xs.push(f64::NEG_INFINITY);
        for x in xs {
            assert_eq!(floor_f64(x), x.floor(), "{x}");
            if x.abs() < 2f64.powi(30) {
                assert_eq!(floor_i32(x), x.floor() as i32, "{x}");
            }
        }
        assert!(floor_f64(f64::NAN).is_nan());
        assert_eq!(
            floor_dvec3(DVec3::new(-0.5, 2.0, 3.7)),
            DVec3::new(-1.0, 2.0, 3.0)
        );
    }
}
