//! Henyey–Greenstein: the one-parameter phase function of smoke and cloud renders.

use super::{ISOTROPIC, PhaseFunction, PhaseSample, frame_around};
use glam::DVec3;
#[cfg(test)]
use std::f64::consts::PI;

/// Largest `|g|` accepted by [`hg`]; larger values are clamped to keep the peak
/// (`(1+|g|)/(4π(1−|g|)²)`, ≈ 1.6e5 at 0.999) finite and integrable by a ray march.
pub const G_MAX: f64 = 0.999;

/// The Henyey–Greenstein phase function, normalised over the sphere (per steradian):
///
/// ```text
/// p_HG(θ; g) = 1/(4π) · (1 − g²) / (1 + g² − 2g·cosθ)^{3/2}
/// ```
///
/// with `∫ p dΩ = 1` and `∫ cosθ · p dΩ = g`. `cos_theta` is the cosine of the
/// scattering angle (module docs) and is clamped to `[−1, 1]`; `g` is clamped to
/// `±`[`G_MAX`] and a NaN `g` is treated as 0 (isotropic). `g = 0`
/// gives exactly [`ISOTROPIC`].
#[inline]
pub fn hg(cos_theta: f64, g: f64) -> f64 {
    let g = if g.is_nan() {
        0.0
    } else {
        g.clamp(-G_MAX, G_MAX)
    };
    let c = cos_theta.clamp(-1.0, 1.0);
    let g2 = g * g;
    // ≥ (1 − |g|)² ≥ 1e-6 > 0 thanks to the clamp on g.
    let denom = 1.0 + g2 - 2.0 * g * c;
    ISOTROPIC * (1.0 - g2) / (denom * denom.sqrt())
}

/// Henyey–Greenstein with asymmetry `g` (clamped to ±[`G_MAX`]; NaN is 0), sampled
/// exactly: the weight is 1 and the pdf is the phase function itself.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HenyeyGreenstein {
    g: f64,
}

impl HenyeyGreenstein {
    pub fn new(g: f64) -> Self {
        let g = if g.is_nan() {
            0.0
        } else {
            g.clamp(-G_MAX, G_MAX)
        };
        HenyeyGreenstein { g }
    }

    pub fn g(&self) -> f64 {
        self.g
    }

    /// The scattering-angle cosine whose cumulative probability is `xi` (the inverse
    /// of HG's CDF in cosθ; uniform below |g| = 1e-8, where the closed form cancels and
    /// the uniform one errs by less than |g|).
    pub fn inverse_cdf(&self, xi: f64) -> f64 {
        let g = self.g;
        if g.abs() < 1e-8 {
            return (2.0 * xi - 1.0).clamp(-1.0, 1.0);
        }
        let q = (1.0 - g * g) / (1.0 - g + 2.0 * g * xi);
        ((1.0 + g * g - q * q) / (2.0 * g)).clamp(-1.0, 1.0)
    }
}

impl PhaseFunction for HenyeyGreenstein {
    fn eval(&self, cos_theta: f64) -> DVec3 {
        DVec3::splat(hg(cos_theta, self.g))
    }
    fn sample(&self, incoming: DVec3, u: [f64; 2]) -> PhaseSample {
        let c = self.inverse_cdf(u[0]);
        PhaseSample {
            dir: frame_around(incoming, c, 2.0 * std::f64::consts::PI * u[1]),
            weight: DVec3::ONE,
            pdf: hg(c, self.g),
        }
    }
    fn pdf(&self, cos_theta: f64) -> f64 {
        hg(cos_theta, self.g)
    }
    fn max_value(&self) -> f64 {
        hg(1.0, self.g.abs())
    }
}

#[cfg(test)]
mod tests {
    use super::super::scattering_cosine;
    use super::*;

    /// ∫ f(μ) dμ over [−1, 1] by composite Simpson with `n` (even) intervals.
    fn simpson(f: impl Fn(f64) -> f64, n: usize) -> f64 {
        let h = 2.0 / n as f64;
        let mut s = f(-1.0) + f(1.0);
        for i in 1..n {
            let w = if i % 2 == 1 { 4.0 } else { 2.0 };
            s += w * f(-1.0 + i as f64 * h);
        }
        s * h / 3.0
    }

    const GS: [f64; 5] = [-0.9, -0.3, 0.0, 0.5, 0.95];

    #[test]
    fn integrates_to_one_over_the_sphere() {
        for g in GS {
            // ∫ p dΩ = 2π ∫_{−1}^{1} p(μ) dμ (azimuthal symmetry).
            let total = 2.0 * PI * simpson(|mu| hg(mu, g), 400_000);
            assert!((total - 1.0).abs() < 1e-8, "g={g}: {total}");
            // The mean cosine is g: this also pins the sign convention.
            let mean_cos = 2.0 * PI * simpson(|mu| mu * hg(mu, g), 400_000);
            assert!((mean_cos - g).abs() < 1e-8, "g={g}: {mean_cos}");
        }
    }

    #[test]
    fn integrates_to_one_over_a_sphere_of_directions() {
        // A genuine 2-D quadrature over directions with a tilted light direction,
        // going through scattering_cosine.
        let light = DVec3::new(0.3, -0.5, 0.8);
        for g in [-0.3, 0.0, 0.5] {
            let (nt, np) = (400, 800);
            let mut total = 0.0;
            for i in 0..nt {
                let theta = (i as f64 + 0.5) * PI / nt as f64;
                for j in 0..np {
                    let ph = (j as f64 + 0.5) * 2.0 * PI / np as f64;
                    let dir =
                        DVec3::new(theta.sin() * ph.cos(), theta.sin() * ph.sin(), theta.cos());
                    let d_omega = theta.sin() * (PI / nt as f64) * (2.0 * PI / np as f64);
                    total += hg(scattering_cosine(light, dir), g) * d_omega;
                }
            }
            assert!((total - 1.0).abs() < 1e-4, "g={g}: {total}");
        }
    }

    #[test]
    fn isotropic_and_forward_peak() {
        for c in [-1.0, -0.2, 0.0, 0.7, 1.0] {
            assert_eq!(hg(c, 0.0), ISOTROPIC);
        }
        assert!((ISOTROPIC - 0.079_577_471_545_947_67).abs() < 1e-17);
        // g > 0 scatters forward: more light continues in the propagation direction.
        assert!(hg(1.0, 0.5) > hg(-1.0, 0.5));
        assert!(hg(1.0, -0.5) < hg(-1.0, -0.5));
        // Closed-form peak (1+g)/(4π(1−g)²).
        let g: f64 = 0.6;
        assert!((hg(1.0, g) - (1.0 + g) / (4.0 * PI * (1.0 - g).powi(2))).abs() < 1e-14);
        // Camera looking straight into the light through the medium: the camera ray
        // runs against the light's propagation, so the camera sees the forward peak.
        let prop = DVec3::new(0.0, 0.0, -1.0);
        let into_light = -prop;
        assert_eq!(scattering_cosine(prop, -into_light), 1.0);
        // Light behind the camera: the camera ray runs along the propagation → back.
        let along = prop * 3.0;
        assert_eq!(scattering_cosine(prop, -along), -1.0);
        // dot(to_light, view_dir) is the same number.
        let to_light = DVec3::new(0.2, 0.9, -0.1).normalize();
        let view_dir = DVec3::new(-0.4, 0.1, 0.7).normalize();
        let c = scattering_cosine(-to_light, -view_dir);
        assert!((c - to_light.dot(view_dir)).abs() < 1e-15);
        assert_eq!(scattering_cosine(DVec3::ZERO, prop), 0.0);
    }

    #[test]
    fn clamps_g_and_cos() {
        assert_eq!(hg(0.3, 1.5), hg(0.3, G_MAX));
        assert_eq!(hg(0.3, -7.0), hg(0.3, -G_MAX));
        assert_eq!(hg(0.3, f64::NAN), ISOTROPIC);
        assert_eq!(hg(1.5, 0.4), hg(1.0, 0.4));
        for g in [1.0, -1.0, f64::INFINITY, f64::NEG_INFINITY] {
            for c in [-1.0, 0.0, 1.0] {
                let v = hg(c, g);
                assert!(v.is_finite() && v > 0.0, "g={g} c={c}: {v}");
            }
        }
        // Still normalised at the clamp. The peak is ~1e-3 wide in θ but ~1e-6 in
        // cosθ, so integrate over θ: ∫ p dΩ = 2π ∫₀^π p(cosθ) sinθ dθ.
        let n = 1_000_000;
        let h = PI / n as f64;
        let f = |th: f64| hg(th.cos(), 1.0) * th.sin();
        let mut s = f(0.0) + f(PI);
        for i in 1..n {
            s += if i % 2 == 1 { 4.0 } else { 2.0 } * f(i as f64 * h);
        }
        let total = 2.0 * PI * s * h / 3.0;
        assert!((total - 1.0).abs() < 1e-5, "{total}");
    }

    #[test]
    fn sampling_follows_the_pdf() {
        // The inverse CDF maps quantiles to cosines whose CDF (integrated from hg in
        // closed form by Simpson) is that quantile; samples leave at that angle.
        for g in [-0.8, -0.2, 0.0, 3e-6, 0.4, 0.9] {
            let p = HenyeyGreenstein::new(g);
            for xi in [0.01, 0.2, 0.5, 0.77, 0.99] {
                let c = p.inverse_cdf(xi);
                let n = 20_000;
                let h = (c + 1.0) / n as f64;
                let mut cdf = hg(-1.0, g) + hg(c, g);
                for i in 1..n {
                    cdf += if i % 2 == 1 { 4.0 } else { 2.0 } * hg(-1.0 + i as f64 * h, g);
                }
                cdf *= 2.0 * PI * h / 3.0;
                assert!((cdf - xi).abs() < 1e-6, "g={g} xi={xi}: {cdf}");
                let incoming = DVec3::new(0.3, -0.4, 0.5).normalize();
                let s = p.sample(incoming, [xi, 0.37]);
                assert!((s.dir.length() - 1.0).abs() < 1e-12);
                assert!((s.dir.dot(incoming) - c).abs() < 1e-9, "g={g} xi={xi}");
                assert_eq!(s.weight, DVec3::ONE);
                assert!((s.pdf - p.pdf(c)).abs() < 1e-12 * s.pdf);
            }
        }
    }
}
