//! Numerically stable pieces of the volume rendering integral.
//!
//! Along a ray `x(s) = o + s·ω` through a medium with extinction `σt(s)`, the
//! radiance reaching the camera is
//!
//! ```text
//! L = ∫₀^S T(s) · σs(s) · L_in(s) ds + T(S) · L_background,
//! T(s) = exp(−τ(s)),   τ(s) = ∫₀^s σt(u) du        (optical depth)
//! ```
//!
//! A ray march splits the ray into segments over which `σt` and the source are taken as
//! constant. For one segment of length `ds` starting at optical depth `τ₀` the exact
//! integral of a constant source `J` (e.g. `σs · L_in`) is
//!
//! ```text
//! ∫₀^ds e^{−(τ₀ + σt·u)} J du = T(τ₀) · J · (1 − e^{−σt·ds}) / σt
//!                             = T(τ₀) · J · ds · φ(σt·ds),
//! φ(x) = (1 − e^{−x}) / x
//! ```
//!
//! (this is the `(1 − dT) · T / κ` term of the classic ray-march formula). Written with
//! [`phi`] it stays exact for `σt → 0` (where it tends to `J·ds`) and for very dense
//! segments (where it tends to `J/σt`).
//!
//! Optical depth is accumulated as a **sum** ([`OpticalDepth`]) and exponentiated once,
//! instead of multiplying per-segment transmittances: the sum of a million tiny
//! segments keeps full relative precision, and `e^{−τ}` is evaluated only when needed.

use std::iter::Sum;
use std::ops::{Add, AddAssign, Mul};

/// Below this argument [`phi`] uses its Taylor series instead of `(1 − e^{−x})/x`.
///
/// At `x = 1e-3` the first omitted series term, `x⁶/7! ≈ 2e-22`, is far below one
/// ulp of `φ ≈ 1`, and the direct formula above the switch is accurate to ~2 ulp
/// (`exp_m1` is correctly rounded to within 1 ulp, the division adds ½ ulp), so the
/// two branches agree to a few ulp at the switch point.
pub const PHI_SERIES_LIMIT: f64 = 1e-3;

/// `1 − e^{−x}`, computed as `−expm1(−x)` so that it keeps full relative precision for
/// tiny `x` (where `1.0 − (−x).exp()` would cancel catastrophically).
///
/// `one_minus_exp(0) = 0`, `one_minus_exp(+∞) = 1`; NaN propagates.
#[inline]
pub fn one_minus_exp(x: f64) -> f64 {
    -(-x).exp_m1()
}

/// `φ(x) = (1 − e^{−x}) / x`, the fraction of a segment's length that is "seen"
/// through its own extinction, with `φ(0) = 1`.
///
/// For `|x| < `[`PHI_SERIES_LIMIT`] the Taylor series
/// `φ(x) = Σₙ (−x)ⁿ/(n+1)! = 1 − x/2 + x²/6 − x³/24 + x⁴/120 − x⁵/720 + …`
/// is used (in nested Horner form), otherwise [`one_minus_exp`]`(x) / x`. The result
/// is accurate to a few ulp for all `x ≥ 0`, decreases monotonically from 1 to 0, and
/// `φ(+∞) = 0`. The formula is also valid for negative `x` (φ > 1 there), but the
/// volume integral only uses `x ≥ 0`. NaN propagates.
#[inline]
pub fn phi(x: f64) -> f64 {
    if x.abs() < PHI_SERIES_LIMIT {
        // 1 − x/2·(1 − x/3·(1 − x/4·(1 − x/5·(1 − x/6))))
        1.0 - x / 2.0 * (1.0 - x / 3.0 * (1.0 - x / 4.0 * (1.0 - x / 5.0 * (1.0 - x / 6.0))))
    } else {
        one_minus_exp(x) / x
    }
}

/// The exact weight of a constant source over a segment of a homogeneous medium:
///
/// ```text
/// w(σt, ds) = ∫₀^ds e^{−σt·u} du = (1 − e^{−σt·ds}) / σt = ds · φ(σt·ds)
/// ```
///
/// so that the segment contributes `T_before · J · w` (see the module docs). Computed
/// as `ds·φ(σt·ds)`, so `σt = 0` gives exactly `ds` and there is no `0/0`. For
/// `σt ≥ 0, ds ≥ 0` the result lies in `[0, ds]`, increases with `ds` and decreases
/// with `σt`, tending to `1/σt` for optically thick segments. If `σt·ds` overflows
/// while `σt` is finite the limit `1/σt` is returned.
#[inline]
pub fn segment_scatter_weight(sigma_t: f64, ds: f64) -> f64 {
    let x = sigma_t * ds;
    if x == f64::INFINITY && sigma_t.is_finite() && sigma_t > 0.0 {
        return 1.0 / sigma_t;
    }
    ds * phi(x)
}

/// Optical depth `τ = ∫ σt ds` (dimensionless), accumulated as a sum along a ray.
///
/// Add segments with [`OpticalDepth::add_segment`] or `+=`, and convert to a
/// transmittance `e^{−τ}` only when needed. Summing keeps relative precision where a
/// running product of per-segment transmittances would accumulate one rounding error
/// per segment. The value is expected to be `≥ 0` (non-negative extinction); a
/// negative value gives a transmittance above 1, NaN propagates — clamping densities is
/// the caller's decision.
#[derive(Clone, Copy, Debug, Default, PartialEq, PartialOrd)]
pub struct OpticalDepth(pub f64);

impl OpticalDepth {
    /// No attenuation: `τ = 0`, transmittance 1.
    pub const ZERO: OpticalDepth = OpticalDepth(0.0);

    /// The optical depth of a homogeneous segment: `τ = σt · ds`.
    #[inline]
    pub fn segment(sigma_t: f64, ds: f64) -> Self {
        OpticalDepth(sigma_t * ds)
    }

    /// Adds a homogeneous segment: `τ += σt · ds`.
    #[inline]
    pub fn add_segment(&mut self, sigma_t: f64, ds: f64) {
        self.0 += sigma_t * ds;
    }

    /// The dimensionless value `τ`.
    #[inline]
    pub fn value(self) -> f64 {
        self.0
    }

    /// Transmittance `T = e^{−τ}` (Beer–Lambert).
    #[inline]
    pub fn transmittance(self) -> f64 {
        (-self.0).exp()
    }

    /// Opacity `α = 1 − e^{−τ}`, accurate for tiny `τ` (see [`one_minus_exp`]).
    #[inline]
    pub fn opacity(self) -> f64 {
        one_minus_exp(self.0)
    }
}

impl Add for OpticalDepth {
    type Output = OpticalDepth;
    #[inline]
    fn add(self, o: OpticalDepth) -> OpticalDepth {
        OpticalDepth(self.0 + o.0)
    }
}

impl AddAssign for OpticalDepth {
    #[inline]
    fn add_assign(&mut self, o: OpticalDepth) {
        self.0 += o.0;
    }
}

impl Sum for OpticalDepth {
    fn sum<I: Iterator<Item = OpticalDepth>>(iter: I) -> OpticalDepth {
        iter.fold(OpticalDepth::ZERO, |a, b| a + b)
    }
}

impl From<OpticalDepth> for Transmittance {
    #[inline]
    fn from(tau: OpticalDepth) -> Transmittance {
        Transmittance(tau.transmittance())
    }
}

/// A transmittance `T = e^{−τ}` in `[0, 1]` (fraction of light that passes).
///
/// Prefer accumulating an [`OpticalDepth`] along a ray; use `Transmittance` for values
/// that come from elsewhere (a shadow-map lookup, a light's visibility) and combine
/// independent factors with `*` (`T_a · T_b = e^{−(τ_a + τ_b)}`).
#[derive(Clone, Copy, Debug, PartialEq, PartialOrd)]
pub struct Transmittance(pub f64);

impl Default for Transmittance {
    fn default() -> Self {
        Transmittance::ONE
    }
}

impl Transmittance {
    /// Fully transparent: `T = 1`.
    pub const ONE: Transmittance = Transmittance(1.0);
    /// Fully opaque: `T = 0`.
    pub const ZERO: Transmittance = Transmittance(0.0);

    /// `T = e^{−τ}`.
    #[inline]
    pub fn from_optical_depth(tau: OpticalDepth) -> Self {
        tau.into()
    }

    /// The value `T`.
    #[inline]
    pub fn value(self) -> f64 {
        self.0
    }

    /// The optical depth `τ = −ln T` (`+∞` for `T = 0`).
    #[inline]
    pub fn optical_depth(self) -> OpticalDepth {
        OpticalDepth(-self.0.ln())
    }

    /// Opacity `1 − T`. Loses relative precision when `T ≈ 1`; when the optical depth
    /// is known use [`OpticalDepth::opacity`] instead.
    #[inline]
    pub fn opacity(self) -> f64 {
        1.0 - self.0
    }
}

impl Mul for Transmittance {
    type Output = Transmittance;
    #[inline]
    fn mul(self, o: Transmittance) -> Transmittance {
        Transmittance(self.0 * o.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(a: f64, b: f64) -> f64 {
        if a == b {
            0.0
        } else {
            (a - b).abs() / b.abs().max(f64::MIN_POSITIVE)
        }
    }

    /// log-spaced values from 10^lo to 10^hi, `per_decade` per decade.
    fn logspace(lo: i32, hi: i32, per_decade: i32) -> Vec<f64> {
        (0..=(hi - lo) * per_decade)
            .map(|i| 10f64.powf(lo as f64 + i as f64 / per_decade as f64))
            .collect()
    }

    #[test]
    fn one_minus_exp_matches_closed_form() {
        assert_eq!(one_minus_exp(0.0), 0.0);
        assert_eq!(one_minus_exp(f64::INFINITY), 1.0);
        // For tiny x, 1 − e^{−x} = x − x²/2 + x³/6 exactly enough.
        for x in [1e-300, 1e-20, 1e-12, 1e-8] {
            let want = x - x * x / 2.0 + x * x * x / 6.0;
            assert!(rel(one_minus_exp(x), want) < 1e-15, "{x}");
        }
        // For moderate x the naive formula is accurate.
        for x in [0.5, 1.0, 3.0, 20.0] {
            assert!(rel(one_minus_exp(x), 1.0 - (-x).exp()) < 1e-15, "{x}");
        }
        assert!(one_minus_exp(f64::NAN).is_nan());
    }

    #[test]
    fn phi_limits_and_series() {
        assert_eq!(phi(0.0), 1.0);
        assert_eq!(phi(f64::INFINITY), 0.0);
        assert!(phi(f64::NAN).is_nan());
        // Series region: compare with the series taken to many more terms.
        for x in logspace(-12, -4, 8).into_iter().chain([0.0, 5e-4, 9.99e-4]) {
            let mut want = 0.0;
            let mut term = 1.0;
            for n in 0..20 {
                want += term;
                term *= -x / (n as f64 + 2.0);
            }
            assert!(
                rel(phi(x), want) <= 2.0 * f64::EPSILON,
                "{x}: {} vs {want}",
                phi(x)
            );
        }
        // Large x: φ(x) = (1 − e^{−x})/x → 1/x.
        for x in [30.0, 1e3, 1e6, 1e100, 1e300] {
            assert!(rel(phi(x), (1.0 - (-x).exp()) / x) < 1e-15, "{x}");
        }
        assert!(rel(phi(1.0), 1.0 - (-1.0f64).exp()) < 1e-15);
    }

    #[test]
    fn phi_is_continuous_at_the_series_switch() {
        let s = PHI_SERIES_LIMIT;
        let below = phi(s.next_down());
        let at = phi(s);
        // Both branches at the same point.
        let direct = one_minus_exp(s) / s;
        let series_formula =
            1.0 - s / 2.0 * (1.0 - s / 3.0 * (1.0 - s / 4.0 * (1.0 - s / 5.0 * (1.0 - s / 6.0))));
        assert!(
            rel(direct, series_formula) <= 4.0 * f64::EPSILON,
            "{direct} {series_formula}"
        );
        // The jump across the switch is no larger than the slope (−1/2) times one ulp of
        // the argument plus a few ulp of rounding.
        assert!((below - at).abs() <= 4.0 * f64::EPSILON, "{below} {at}");
    }

    #[test]
    fn phi_is_monotone_decreasing() {
        let xs = logspace(-10, 6, 40);
        for w in xs.windows(2) {
            assert!(phi(w[1]) <= phi(w[0]), "{} {}", w[0], w[1]);
        }
    }

    #[test]
    fn segment_weight_matches_closed_form_across_optical_depths() {
        for ds in [1e-3, 0.37, 1.0, 250.0] {
            let mut prev = f64::INFINITY;
            for x in logspace(-10, 6, 20) {
                let sigma_t = x / ds;
                let w = segment_scatter_weight(sigma_t, ds);
                assert!(w.is_finite() && w >= 0.0 && w <= ds, "x={x} ds={ds} w={w}");
                // Monotone: decreasing in σt at fixed ds.
                assert!(w <= prev, "not monotone at x={x}");
                prev = w;
                // Closed form, evaluated where it is accurate.
                let want = if x < 1e-4 {
                    ds * (1.0 - x / 2.0 + x * x / 6.0 - x * x * x / 24.0)
                } else {
                    (1.0 - (-x).exp()) / sigma_t
                };
                // 1 − e^{−x} loses ~1e-16/x relative in the naive form for small x;
                // above 1e-4 that is ≤ 1e-12.
                let tol = if x < 1e-4 { 4.0 * f64::EPSILON } else { 1e-12 };
                assert!(rel(w, want) < tol, "x={x} ds={ds}: {w} vs {want}");
            }
        }
    }

    #[test]
    fn segment_weight_edge_cases() {
        assert_eq!(segment_scatter_weight(0.0, 2.5), 2.5);
        assert_eq!(segment_scatter_weight(3.0, 0.0), 0.0);
        // Thick: → 1/σt.
        assert!(rel(segment_scatter_weight(1e6, 1.0), 1e-6) < 1e-15);
        // Overflowing σt·ds: the limit 1/σt.
        assert_eq!(segment_scatter_weight(1e200, 1e200), 1e-200);
        assert_eq!(segment_scatter_weight(f64::INFINITY, 1.0), 0.0);
        // Increasing in ds at fixed σt.
        // (Up to rounding: once e^{−x} underflows, ds·φ(x) = ds/(σt·ds) is flat.)
        let mut prev = 0.0;
        for ds in logspace(-8, 4, 10) {
            let w = segment_scatter_weight(2.0, ds);
            assert!(w >= prev * (1.0 - 2.0 * f64::EPSILON), "{ds}: {w} < {prev}");
            prev = w;
        }
        assert!(rel(prev, 0.5) < 1e-15);
    }

    #[test]
    fn summed_optical_depth_keeps_precision() {
        let mut tau = OpticalDepth::ZERO;
        for _ in 0..1_000_000 {
            tau.add_segment(1e-8, 1.0);
        }
        let want = (-0.01f64).exp();
        assert!(
            rel(tau.transmittance(), want) < 1e-12,
            "{} vs {want}",
            tau.transmittance()
        );
        // The sum's own error is ≤ n·ε·τ ≈ 1e-12 absolute, i.e. ≲ 1e-10 relative to τ,
        // and it enters T as an absolute error in the exponent: ≲ 1e-12 relative.
        assert!(rel(tau.value(), 0.01) < 1e-10);
        // Opacity of a tiny depth is exact, not 0.
        assert!(rel(OpticalDepth(1e-18).opacity(), 1e-18) < 1e-15);
        // Sum and From work like the loop.
        let s: OpticalDepth = (0..1000).map(|_| OpticalDepth::segment(0.5, 0.002)).sum();
        assert!(rel(s.value(), 1.0) < 1e-13);
        let t = Transmittance::from(s);
        assert!(rel(t.value(), (-1.0f64).exp()) < 1e-13);
        assert!(rel(t.optical_depth().value(), 1.0) < 1e-13);
    }

    #[test]
    fn transmittance_combines_multiplicatively() {
        let a = Transmittance::from_optical_depth(OpticalDepth(0.3));
        let b = Transmittance::from_optical_depth(OpticalDepth(1.2));
        assert!(rel((a * b).value(), (-1.5f64).exp()) < 1e-15);
        assert_eq!(Transmittance::default(), Transmittance::ONE);
        assert_eq!(Transmittance::ZERO.optical_depth().value(), f64::INFINITY);
        assert_eq!(OpticalDepth(f64::INFINITY).transmittance(), 0.0);
        assert!((Transmittance(0.25).opacity() - 0.75).abs() < 1e-16);
    }
}
