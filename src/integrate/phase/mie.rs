//! Lorenz–Mie scattering by a homogeneous sphere: the amplitude functions `S₁(θ)`,
//! `S₂(θ)` and the scattering efficiency, for a real refractive index and size
//! parameters up to ~2·10⁴; and the refractive index of water against wavelength.
//!
//! The series follows Bohren & Huffman, *Absorption and Scattering of Light by Small
//! Particles* (1983), §4.4 and their BHMIE program, with Wiscombe's numerical
//! safeguards (W. J. Wiscombe, "Improved Mie scattering algorithms", Appl. Opt. 19,
//! 1505–1509, 1980):
//!
//! - the series is summed to `N = x + 4.05·x^{1/3} + 2` terms (Wiscombe's criterion);
//! - the logarithmic derivative `Dₙ(mx) = ψₙ'(mx)/ψₙ(mx)` runs by **downward**
//!   recurrence `Dₙ₋₁ = n/(mx) − 1/(Dₙ + n/(mx))`, started at 0 from
//!   `max(N, |mx|) + 16·|mx|^{1/3} + 16` so the start's error has decayed past the
//!   turning point `n ≈ |mx|` — stable for any size (the upward one is not);
//! - the Riccati–Bessel functions `ψₙ(x) = x jₙ(x)`, `χₙ(x) = −x yₙ(x)` run upward,
//!   which is stable for `n ≤ N` (BHMIE does the same);
//! - `πₙ(cosθ)`, `τₙ(cosθ)` by their upward three-term recurrences.
//!
//! With `a₀…` the coefficients, `S₁ = Σ (2n+1)/(n(n+1)) (aₙπₙ + bₙτₙ)`,
//! `S₂ = Σ (2n+1)/(n(n+1)) (aₙτₙ + bₙπₙ)`, `Q_sca = 2/x² Σ (2n+1)(|aₙ|² + |bₙ|²)`, and
//! the phase function of unpolarised light normalised over the sphere is
//! `p(θ) = (|S₁|² + |S₂|²) / (2π x² Q_sca)` per steradian.
//!
//! Scattering angle θ as in the [module docs](super): θ = 0 is forward.

use std::f64::consts::PI;

/// Largest size parameter [`coefficients`] accepts (the series then has ~2·10⁴ terms).
pub const X_MAX: f64 = 2.5e4;

/// Refractive index of distilled water at 20.0 °C, wavelength `lambda_nm` in
/// nanometres (valid 182–1129 nm), from the four-term Sellmeier fit of M. Daimon and
/// A. Masumura, "Measurement of the refractive index of distilled water from the
/// near-infrared region to the ultraviolet region", Applied Optics 46(18), 3811–3820
/// (2007), Table 3 (20.0 °C):
///
/// ```text
/// n² − 1 = Σᵢ Bᵢ λ² / (λ² − Cᵢ),   λ in µm
/// B = 5.684027565e-1, 1.726177391e-1, 2.086189578e-2, 1.130748688e-1
/// C = 5.101829712e-3, 1.821153936e-2, 2.620722293e-2, 1.069792721e1   [µm²]
/// ```
///
/// It gives 1.33335 at 589.3 nm, 1.3456 at 380 nm and 1.3290 at 780 nm; the tests
/// compare it with the IAPWS formulation (Harvey et al. 1998) to 1e-5.
pub fn water_refractive_index(lambda_nm: f64) -> f64 {
    const B: [f64; 4] = [
        5.684_027_565e-1,
        1.726_177_391e-1,
        2.086_189_578e-2,
        1.130_748_688e-1,
    ];
    const C: [f64; 4] = [
        5.101_829_712e-3,
        1.821_153_936e-2,
        2.620_722_293e-2,
        1.069_792_721e1,
    ];
    let l2 = (lambda_nm * 1e-3).powi(2);
    let s: f64 = B.iter().zip(C).map(|(b, c)| b * l2 / (l2 - c)).sum();
    (1.0 + s).sqrt()
}

/// Number of terms of the Mie series for size parameter `x` (Wiscombe 1980, for
/// `8 ≤ x ≤ 4200`, and used beyond: `x + 4.05 x^{1/3} + 2`; `x + 4 x^{1/3} + 1` below 8
/// rounds to the same few terms).
pub fn n_terms(x: f64) -> usize {
    (x + 4.05 * x.cbrt() + 2.0).ceil() as usize
}

/// The Mie coefficients of a sphere, premultiplied by `(2n+1)/(n(n+1))`, for the
/// angular sums; and its scattering efficiency.
#[derive(Clone, Debug)]
pub struct Coefficients {
    /// `(2n+1)/(n(n+1)) · aₙ`, n = 1…N, as (re, im).
    pub a: Vec<(f64, f64)>,
    /// `(2n+1)/(n(n+1)) · bₙ`, n = 1…N, as (re, im).
    pub b: Vec<(f64, f64)>,
    /// Scattering efficiency `Q_sca = C_sca / (π r²)`.
    pub q_sca: f64,
    /// The size parameter `x = 2π r / λ`.
    pub x: f64,
}

/// `p / q` for complex numbers as (re, im) pairs (Smith's algorithm: no overflow for
/// the huge `ξₙ` of small spheres at large n).
#[inline]
fn cdiv(p: (f64, f64), q: (f64, f64)) -> (f64, f64) {
    if q.0.abs() >= q.1.abs() {
        let r = q.1 / q.0;
        let d = q.0 + q.1 * r;
        ((p.0 + p.1 * r) / d, (p.1 - p.0 * r) / d)
    } else {
        let r = q.0 / q.1;
        let d = q.0 * r + q.1;
        ((p.0 * r + p.1) / d, (p.1 * r - p.0) / d)
    }
}

/// The Mie coefficients for relative refractive index `m` (real, > 0, ≠ 1 allowed)
/// and size parameter `x` (`0 < x ≤` [`X_MAX`]). `None` for arguments outside that.
pub fn coefficients(m: f64, x: f64) -> Option<Coefficients> {
    if !(m > 0.0 && m.is_finite() && x > 0.0 && x <= X_MAX) {
        return None;
    }
    let n_max = n_terms(x);
    let mx = m * x;
    // Downward recurrence for Dₙ(mx), from well above both N and |mx|: for real mx
    // the start's error only decays once n is past the turning point n ≈ mx by a few
    // times (mx)^{1/3} (a mere +15 leaves a 2 % error in D₁ at x = 1551).
    let n_start = ((n_max as f64).max(mx.abs()) + 16.0 * mx.abs().cbrt()).ceil() as usize + 16;
    let mut d = vec![0.0f64; n_start + 1];
    for n in (1..=n_start).rev() {
        let q = n as f64 / mx;
        d[n - 1] = q - 1.0 / (d[n] + q);
    }
    // ψ₋₁ = cos x, ψ₀ = sin x; χ₋₁ = −sin x, χ₀ = cos x; ξ = ψ − iχ.
    let (mut psi_prev, mut psi) = (x.cos(), x.sin());
    let (mut chi_prev, mut chi) = (-x.sin(), x.cos());
    let mut a = Vec::with_capacity(n_max);
    let mut b = Vec::with_capacity(n_max);
    let mut q_sum = 0.0;
    for (i, &dn) in d[1..=n_max].iter().enumerate() {
        let nf = (i + 1) as f64;
        let f = (2.0 * nf - 1.0) / x;
        let psi_n = f * psi - psi_prev;
        let chi_n = f * chi - chi_prev;
        let xi_n = (psi_n, -chi_n);
        let xi_prev = (psi, -chi);
        let nx = nf / x;
        let da = dn / m + nx;
        let db = dn * m + nx;
        let an = cdiv(
            (da * psi_n - psi, 0.0),
            (da * xi_n.0 - xi_prev.0, da * xi_n.1 - xi_prev.1),
        );
        let bn = cdiv(
            (db * psi_n - psi, 0.0),
            (db * xi_n.0 - xi_prev.0, db * xi_n.1 - xi_prev.1),
        );
        let w = 2.0 * nf + 1.0;
        q_sum += w * (an.0 * an.0 + an.1 * an.1 + bn.0 * bn.0 + bn.1 * bn.1);
        let c = w / (nf * (nf + 1.0));
        a.push((c * an.0, c * an.1));
        b.push((c * bn.0, c * bn.1));
        (psi_prev, psi) = (psi, psi_n);
        (chi_prev, chi) = (chi, chi_n);
    }
    Some(Coefficients {
        a,
        b,
        q_sca: 2.0 * q_sum / (x * x),
        x,
    })
}

/// `|S₁|² + |S₂|²` at each cosine in `mu`, for every coefficient set in `spheres`
/// (same angles): `out[k][j]` for sphere `k`, angle `j`. The angular functions
/// `πₙ, τₙ` are computed once and shared by all spheres; angles go in blocks small
/// enough for every sphere's accumulators to stay in the L1 cache, and the inner loop
/// runs over a block's angles so it vectorises.
pub fn intensities(spheres: &[Coefficients], mu: &[f64]) -> Vec<Vec<f64>> {
    const BLOCK: usize = 64;
    let mut out = vec![vec![0.0f64; mu.len()]; spheres.len()];
    for (b, block) in mu.chunks(BLOCK).enumerate() {
        for (k, v) in intensities_block(spheres, block).into_iter().enumerate() {
            out[k][b * BLOCK..b * BLOCK + v.len()].copy_from_slice(&v);
        }
    }
    out
}

fn intensities_block(spheres: &[Coefficients], mu: &[f64]) -> Vec<Vec<f64>> {
    let na = mu.len();
    let n_max = spheres.iter().map(|s| s.a.len()).max().unwrap_or(0);
    let mut pi_prev = vec![0.0f64; na]; // π₀ = 0
    let mut pi_cur = vec![1.0f64; na]; // π₁ = 1
    let mut tau = vec![0.0f64; na];
    // Accumulators per sphere: S1 re, S1 im, S2 re, S2 im.
    let mut acc: Vec<[Vec<f64>; 4]> = spheres
        .iter()
        .map(|_| std::array::from_fn(|_| vec![0.0f64; na]))
        .collect();
    for n in 1..=n_max {
        let nf = n as f64;
        for j in 0..na {
            tau[j] = nf * mu[j] * pi_cur[j] - (nf + 1.0) * pi_prev[j];
        }
        for (s, [s1r, s1i, s2r, s2i]) in spheres.iter().zip(acc.iter_mut()) {
            if n > s.a.len() {
                continue;
            }
            let (ar, ai) = s.a[n - 1];
            let (br, bi) = s.b[n - 1];
            for j in 0..na {
                let (p, t) = (pi_cur[j], tau[j]);
                s1r[j] += ar * p + br * t;
                s1i[j] += ai * p + bi * t;
                s2r[j] += ar * t + br * p;
                s2i[j] += ai * t + bi * p;
            }
        }
        // π_{n+1} = ((2n+1)/n) μ πₙ − ((n+1)/n) π_{n−1}
        let c1 = (2.0 * nf + 1.0) / nf;
        let c2 = (nf + 1.0) / nf;
        for j in 0..na {
            let next = c1 * mu[j] * pi_cur[j] - c2 * pi_prev[j];
            pi_prev[j] = pi_cur[j];
            pi_cur[j] = next;
        }
    }
    acc.into_iter()
        .map(|[s1r, s1i, s2r, s2i]| {
            (0..na)
                .map(|j| s1r[j] * s1r[j] + s1i[j] * s1i[j] + s2r[j] * s2r[j] + s2i[j] * s2i[j])
                .collect()
        })
        .collect()
}

/// The relative spread of drop radii the phase function is averaged over: radii are
/// uniform in `r₀·[1 − RADIUS_SPREAD, 1 + RADIUS_SPREAD]`.
pub const RADIUS_SPREAD: f64 = 0.1;

/// How many radii sample that spread (midpoints of equal sub-intervals).
pub const RADIUS_SAMPLES: usize = 12;

/// The radii (same unit as `r0`) the average runs over: the midpoints of
/// [`RADIUS_SAMPLES`] equal sub-intervals of `r0·[1 − s, 1 + s]`, `s =`
/// [`RADIUS_SPREAD`]; each stands for the same number of drops.
/// `scripts/mie_reference.py` uses the same ones.
pub fn averaged_radii(r0: f64) -> Vec<f64> {
    let k = RADIUS_SAMPLES as f64;
    (0..RADIUS_SAMPLES)
        .map(|i| r0 * (1.0 + RADIUS_SPREAD * (2.0 * (i as f64 + 0.5) / k - 1.0)))
        .collect()
}

/// The phase function (per steradian, normalised over the sphere) of unpolarised
/// light of wavelength `lambda` scattered by water-like spheres of refractive index
/// `m`, averaged over the radii `radii` (same length unit as `lambda`), each standing
/// for the same number of drops: each drop contributes in proportion to its
/// scattering cross-section,
///
/// ```text
/// p(θ) = Σₖ (|S₁|² + |S₂|²)ₖ / (2π Σₖ xₖ² Q_sca,k)
/// ```
///
/// at the cosines `mu`. `None` when a size parameter is out of range.
pub fn averaged_phase(m: f64, lambda: f64, radii: &[f64], mu: &[f64]) -> Option<Vec<f64>> {
    let spheres = radii
        .iter()
        .map(|r| coefficients(m, 2.0 * PI * r / lambda))
        .collect::<Option<Vec<_>>>()?;
    let norm: f64 = spheres.iter().map(|s| s.x * s.x * s.q_sca).sum::<f64>() * 2.0 * PI;
    let per_sphere = intensities(&spheres, mu);
    Some(
        (0..mu.len())
            .map(|j| per_sphere.iter().map(|v| v[j]).sum::<f64>() / norm)
            .collect(),
    )
}

#[cfg(test)]
mod tests;
