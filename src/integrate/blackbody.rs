//! Blackbody emission colour, as pbrt-v4 and Cycles compute it.
//!
//! Planck's law gives the spectral radiance of a blackbody at temperature `T`:
//!
//! ```text
//! B_λ(λ, T) = 2hc² / λ⁵ · 1 / (exp(hc / (λ k T)) − 1)      [W · sr⁻¹ · m⁻² · m⁻¹]
//! ```
//!
//! Its CIE 1931 2° tristimulus values are `X = ∫ B_λ x̄ dλ` (likewise `Y`, `Z`), taken
//! here over 360–830 nm with the trapezoid rule at 5 nm. The colour matching functions
//! are the multi-lobe piecewise-Gaussian fit of Wyman, Sloan & Shirley, "Simple
//! Analytic Approximations to the CIE XYZ Color Matching Functions", JCGT 2(2), 2013
//! (their eq. 2). The resulting Planckian-locus chromaticities agree with the CIE 1931
//! ones to ~0.001 in `xy` above 2500 K and ~0.003 around 1500–2000 K; the fit's far-red
//! tails are poor (beyond ~680 nm x̄ falls off faster than ȳ), so the error grows to
//! ~0.01 near 1000 K and the colour would turn green below ~450 K — which is why the
//! normalised colour is pinned to pure red below [`PURE_RED_BELOW`] (where the true
//! colour is out of gamut and clips to pure red anyway). XYZ is then converted to linear
//! Rec.709 / sRGB primaries (D65 white) with the standard matrix.
//!
//! Two flavours:
//! - [`blackbody_rgb_normalized`]: colour only, scaled to luminance `Y = 1` — like
//!   Cycles' Blackbody node, and pbrt-v4's normalised `BlackbodySpectrum` up to the
//!   choice of normalisation (pbrt divides by the spectral peak; here luminance is 1 so
//!   the renderer's emission scale is a luminance);
//! - [`blackbody_radiance_rgb`]: absolute, luminance equal to `∫ B_λ ȳ dλ`.
//!
//! The renderer maps grid values to Kelvin as pbrt-v4's `temperaturescale` /
//! `temperatureoffset` do: `T = value · scale + offset` ([`grid_value_to_kelvin`]).
//!
//! Below about 1900 K the Planckian locus leaves the Rec.709 gamut (blue would go
//! negative, and below ~855 K green too): negative components are
//! clipped to 0 and the colour renormalised to `Y = 1` so emission never subtracts
//! light. [`blackbody_xyz`] gives the unclipped tristimulus values.
//!
//! Each evaluation integrates 95 spectral samples (a few microseconds); a renderer
//! evaluating it per ray-march sample should cache it, e.g. with [`BlackbodyTable`].

use std::sync::OnceLock;

/// Planck constant `h` [J·s] (exact, SI 2019).
pub const PLANCK_H: f64 = 6.626_070_15e-34;
/// Speed of light in vacuum `c` [m/s] (exact).
pub const SPEED_OF_LIGHT: f64 = 299_792_458.0;
/// Boltzmann constant `k` [J/K] (exact, SI 2019).
pub const BOLTZMANN_K: f64 = 1.380_649e-23;
/// First radiation constant for spectral radiance, `c₁L = 2hc²` [W·m²·sr⁻¹].
pub const C1L: f64 = 2.0 * PLANCK_H * SPEED_OF_LIGHT * SPEED_OF_LIGHT;
/// Second radiation constant `c₂ = hc/k` [m·K].
pub const C2: f64 = PLANCK_H * SPEED_OF_LIGHT / BOLTZMANN_K;
/// Maximum luminous efficacy [lm/W]: multiply a `Y` from [`blackbody_radiance_rgb`]
/// by this to get luminance in cd/m².
pub const LUMINOUS_EFFICACY: f64 = 683.002;

/// Stefan–Boltzmann constant `σ = 2π⁵k⁴/(15h³c²)` [W·m⁻²·K⁻⁴].
pub const STEFAN_BOLTZMANN: f64 = 5.670_374_419e-8;

/// Temperatures are clamped to `[T_MIN, T_MAX]` (positive finite inputs only). Below
/// 1 K the visible radiance underflows to 0 and the chromaticity has long converged to
/// its 830 nm limit; above 1e30 K the Rayleigh–Jeans regime holds (colour converged,
/// radiance ∝ T) and the clamp keeps the absolute values far from f64 overflow.
pub const T_MIN: f64 = 1.0;
/// See [`T_MIN`].
pub const T_MAX: f64 = 1e30;

/// Below this temperature [K] the normalised colour is pure Rec.709 red ([`PURE_RED`]).
///
/// Physically the Planckian locus below ~850–900 K lies beyond the red primary on the
/// far side of the red–blue gamut edge, so gamut clipping leaves pure red (the computed
/// colour is already exactly `PURE_RED` from ~480 K to ~855 K). Below ~450 K the
/// Wyman–Sloan–Shirley fit's far-red tails (x̄ decays faster than ȳ beyond ~680 nm,
/// where the real ratio x̄/ȳ stays ≈ 2.8) would drift the colour towards green, so the
/// plateau is imposed from 700 K down. The visible radiance there is negligible
/// (`Y ≈ 2e-7` W·sr⁻¹·m⁻² at 700 K against ≈ 11 at 1500 K).
pub const PURE_RED_BELOW: f64 = 700.0;

/// Pure Rec.709 red with luminance 1: `[1/0.2126729, 0, 0]`.
pub const PURE_RED: [f64; 3] = [1.0 / 0.212_672_9, 0.0, 0.0];

const LAMBDA_MIN_NM: f64 = 360.0;
const LAMBDA_STEP_NM: f64 = 5.0;
const N_SAMPLES: usize = 95; // 360, 365, …, 830

/// `T = value · scale + offset`, the grid → Kelvin map of pbrt-v4's
/// `temperaturescale` / `temperatureoffset`.
#[inline]
pub fn grid_value_to_kelvin(value: f64, scale: f64, offset: f64) -> f64 {
    value * scale + offset
}

/// One lobe of the Wyman–Sloan–Shirley fit: a Gaussian with different widths left and
/// right of its mean.
#[inline]
fn piecewise_gaussian(lambda: f64, mu: f64, sigma_left: f64, sigma_right: f64) -> f64 {
    let s = if lambda < mu { sigma_left } else { sigma_right };
    let t = (lambda - mu) / s;
    (-0.5 * t * t).exp()
}

/// The CIE 1931 2° colour matching functions `[x̄, ȳ, z̄](λ)`, λ in nanometres, by the
/// Wyman–Sloan–Shirley (2013) multi-lobe fit:
///
/// ```text
/// x̄ = 1.056 g(λ; 599.8, 37.9, 31.0) + 0.362 g(λ; 442.0, 16.0, 26.7) − 0.065 g(λ; 501.1, 20.4, 26.2)
/// ȳ = 0.821 g(λ; 568.8, 46.9, 40.5) + 0.286 g(λ; 530.9, 16.3, 31.1)
/// z̄ = 1.217 g(λ; 437.0, 11.8, 36.0) + 0.681 g(λ; 459.0, 26.0, 13.8)
/// g(λ; μ, σ₁, σ₂) = exp(−½ (λ − μ)² / σ²),  σ = σ₁ for λ < μ, σ₂ otherwise.
/// ```
pub fn cie_xyz_cmf(lambda_nm: f64) -> [f64; 3] {
    let l = lambda_nm;
    let x = 1.056 * piecewise_gaussian(l, 599.8, 37.9, 31.0)
        + 0.362 * piecewise_gaussian(l, 442.0, 16.0, 26.7)
        - 0.065 * piecewise_gaussian(l, 501.1, 20.4, 26.2);
    let y = 0.821 * piecewise_gaussian(l, 568.8, 46.9, 40.5)
        + 0.286 * piecewise_gaussian(l, 530.9, 16.3, 31.1);
    let z = 1.217 * piecewise_gaussian(l, 437.0, 11.8, 36.0)
        + 0.681 * piecewise_gaussian(l, 459.0, 26.0, 13.8);
    [x, y, z]
}

/// Planck's spectral radiance `B_λ(λ, T)` in W·sr⁻¹·m⁻²·nm⁻¹ (λ in nanometres, T in
/// Kelvin). Returns 0 for `T ≤ 0`, non-finite `T`, or a non-positive/non-finite λ.
pub fn planck_spectral_radiance(lambda_nm: f64, t: f64) -> f64 {
    if !(t > 0.0 && t.is_finite() && lambda_nm > 0.0 && lambda_nm.is_finite()) {
        return 0.0;
    }
    let t = t.min(T_MAX);
    ln_planck(lambda_nm, t).exp()
}

/// `ln B_λ(λ, T)` with `B_λ` in W·sr⁻¹·m⁻²·nm⁻¹, stable for every `T > 0`:
/// `ln(e^a − 1)` is evaluated as `a + ln(1 − e^{−a})` for large `a = c₂/(λT)` (no
/// overflow at low T) and as `ln(expm1(a))` for small `a` (no cancellation at high T).
#[inline]
fn ln_planck(lambda_nm: f64, t: f64) -> f64 {
    let lambda_m = lambda_nm * 1e-9;
    let a = C2 / (lambda_m * t);
    let ln_expm1 = if a > 1.0 {
        a + (-(-a).exp()).ln_1p()
    } else {
        a.exp_m1().ln()
    };
    // per metre → per nanometre: × 1e-9
    C1L.ln() - 5.0 * lambda_m.ln() - ln_expm1 + 1e-9f64.ln()
}

/// The 5 nm CMF table with trapezoid weights folded in: `(λ, Δλ·wᵢ·[x̄, ȳ, z̄])`.
fn cmf_table() -> &'static [(f64, [f64; 3]); N_SAMPLES] {
    static TABLE: OnceLock<[(f64, [f64; 3]); N_SAMPLES]> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = [(0.0, [0.0; 3]); N_SAMPLES];
        for (i, e) in t.iter_mut().enumerate() {
            let l = LAMBDA_MIN_NM + LAMBDA_STEP_NM * i as f64;
            let w = if i == 0 || i == N_SAMPLES - 1 {
                0.5 * LAMBDA_STEP_NM
            } else {
                LAMBDA_STEP_NM
            };
            let c = cie_xyz_cmf(l);
            *e = (l, [w * c[0], w * c[1], w * c[2]]);
        }
        t
    })
}

/// Tristimulus values as `(ln scale, xyz)` with the true XYZ = `e^{ln scale} · xyz`;
/// `xyz` is of order 1 so neither low nor high temperatures under- or overflow.
/// `t` must be positive and finite (callers clamp it).
fn xyz_scaled(t: f64) -> (f64, [f64; 3]) {
    let table = cmf_table();
    let mut ln_b = [0.0; N_SAMPLES];
    let mut m = f64::NEG_INFINITY;
    for (lb, (l, _)) in ln_b.iter_mut().zip(table.iter()) {
        *lb = ln_planck(*l, t);
        m = m.max(*lb);
    }
    let mut xyz = [0.0; 3];
    for (lb, (_, c)) in ln_b.iter().zip(table.iter()) {
        let w = (lb - m).exp();
        xyz[0] += w * c[0];
        xyz[1] += w * c[1];
        xyz[2] += w * c[2];
    }
    (m, xyz)
}

/// Clamps a valid temperature into `[T_MIN, T_MAX]`; `None` for `T ≤ 0` or non-finite.
#[inline]
fn valid_temperature(t: f64) -> Option<f64> {
    if t > 0.0 && t.is_finite() {
        Some(t.clamp(T_MIN, T_MAX))
    } else {
        None
    }
}

/// Absolute CIE 1931 XYZ of a blackbody at `t` Kelvin: `∫₃₆₀⁸³⁰ B_λ(λ, T) · [x̄, ȳ, z̄] dλ`
/// in W·sr⁻¹·m⁻² (`Y · 683 lm/W` is the luminance in cd/m²). Not gamut-clipped.
/// Returns zeros for `T ≤ 0` or non-finite `T`.
pub fn blackbody_xyz(t: f64) -> [f64; 3] {
    let Some(t) = valid_temperature(t) else {
        return [0.0; 3];
    };
    let (ln_s, xyz) = xyz_scaled(t);
    let s = ln_s.exp();
    [s * xyz[0], s * xyz[1], s * xyz[2]]
}

/// CIE XYZ → linear Rec.709 (sRGB primaries, D65 white), the standard matrix
/// (IEC 61966-2-1). Its inverse's middle row is the luminance
/// `Y = 0.2126729 R + 0.7151522 G + 0.0721750 B`.
#[inline]
pub fn xyz_to_linear_rec709(xyz: [f64; 3]) -> [f64; 3] {
    let [x, y, z] = xyz;
    [
        3.240_454_2 * x - 1.537_138_5 * y - 0.498_531_4 * z,
        -0.969_266_0 * x + 1.876_010_8 * y + 0.041_556_0 * z,
        0.055_643_4 * x - 0.204_025_9 * y + 1.057_225_2 * z,
    ]
}

/// Luminance of linear Rec.709 RGB (the `Y` row of the RGB → XYZ matrix).
#[inline]
pub fn rec709_luminance(rgb: [f64; 3]) -> f64 {
    0.212_672_9 * rgb[0] + 0.715_152_2 * rgb[1] + 0.072_175_0 * rgb[2]
}

/// The colour of a blackbody at `t` Kelvin in linear Rec.709, normalised to luminance
/// `Y = 1` (chromaticity only; the analogue of Cycles' Blackbody node). Components that
/// fall outside the gamut (negative — at low temperatures) are clipped to 0 and the
/// result renormalised to `Y = 1`. Returns `[0, 0, 0]` for `T ≤ 0` or non-finite `T`.
pub fn blackbody_rgb_normalized(t: f64) -> [f64; 3] {
    let Some(t) = valid_temperature(t) else {
        return [0.0; 3];
    };
    let (_, xyz) = xyz_scaled(t);
    normalize_rgb(t, xyz)
}

/// Gamut-clipped, luminance-normalised RGB from (scaled) XYZ at temperature `t`
/// (pure red below [`PURE_RED_BELOW`]).
fn normalize_rgb(t: f64, xyz: [f64; 3]) -> [f64; 3] {
    if t < PURE_RED_BELOW {
        return PURE_RED;
    }
    let rgb = xyz_to_linear_rec709(xyz).map(|c| c.max(0.0));
    let y = rec709_luminance(rgb);
    if y > 0.0 && y.is_finite() {
        rgb.map(|c| c / y)
    } else {
        [0.0; 3]
    }
}

/// Absolute emitted radiance of a blackbody at `t` Kelvin, in linear Rec.709: the
/// colour of [`blackbody_rgb_normalized`] scaled so that its luminance `Y` equals the
/// photopically weighted radiance `∫₃₆₀⁸³⁰ B_λ ȳ dλ` in W·sr⁻¹·m⁻² (multiply by
/// [`LUMINOUS_EFFICACY`] for cd/m²).
///
/// It grows steeply and monotonically with `T` — like `e^{−c₂/(λT)}` (Wien) when the
/// visible band is far above the peak, approaching `∝ T` (Rayleigh–Jeans) at very high
/// `T`; it is *not* `σT⁴`, which is the integral over all wavelengths. Values are huge
/// in scene units (≈ 11 at 1500 K, ≈ 7e2 at 2000 K, ≈ 4.5e6 at
/// 6500 K): the renderer applies an
/// emission scale. Returns zeros for `T ≤ 0` or non-finite `T`; finite for all others.
pub fn blackbody_radiance_rgb(t: f64) -> [f64; 3] {
    let Some(t) = valid_temperature(t) else {
        return [0.0; 3];
    };
    let (ln_s, xyz) = xyz_scaled(t);
    let y = ln_s.exp() * xyz[1];
    normalize_rgb(t, xyz).map(|c| c * y)
}

/// Total (all-wavelength) radiance of a blackbody, `∫₀^∞ B_λ dλ = σT⁴/π` in
/// W·m⁻²·sr⁻¹; 0 for `T ≤ 0` or non-finite `T`.
///
/// This is the brightness Cycles' Principled Volume gives blackbody emission: there the
/// emitted colour is the luminance-normalised blackbody colour times
/// `σT⁴/π · 1e-6` (for "Blackbody Intensity" 1), i.e.
/// `blackbody_rgb_normalized(T) · total_radiance(T) · 1e-6`. Unlike
/// [`blackbody_radiance_rgb`] it counts the (invisible) infrared too.
pub fn total_radiance(t: f64) -> f64 {
    if !(t > 0.0 && t.is_finite()) {
        return 0.0;
    }
    let t = t.min(T_MAX);
    STEFAN_BOLTZMANN * (t * t) * (t * t) / std::f64::consts::PI
}

/// A lookup table of [`blackbody_rgb_normalized`] and [`blackbody_radiance_rgb`] over
/// a temperature range, for per-sample use in a renderer (a lookup is a few
/// multiplications instead of ~200 transcendental calls).
///
/// Samples are uniform in `1/T` over `[t_min, t_max]` — dense at low temperatures,
/// where the colour changes fastest, sparse at high ones, where it has converged. Colour
/// is interpolated linearly in `1/T` and the absolute luminance log-linearly (`ln Y` is
/// close to `c − a/T`, i.e. almost linear in `1/T`).
/// Temperatures outside the range are evaluated exactly (slow path); `T ≤ 0` and
/// non-finite give zeros as in the direct functions.
#[derive(Clone, Debug)]
pub struct BlackbodyTable {
    t_min: f64,
    t_max: f64,
    /// `1/t_max`, the first sample's abscissa.
    u_min: f64,
    /// `1 / Δ(1/T)`.
    inv_du: f64,
    /// Per sample, in increasing `1/T` (decreasing `T`): normalised RGB and `ln Y` of
    /// the absolute radiance.
    entries: Vec<([f64; 3], f64)>,
}

impl BlackbodyTable {
    /// Tabulates `[t_min, t_max]` (Kelvin) with `n ≥ 2` samples. Invalid input (non-finite
    /// or non-positive bounds, `t_max ≤ t_min`) yields an empty table whose lookups all
    /// take the exact path.
    pub fn new(t_min: f64, t_max: f64, n: usize) -> Self {
        let valid =
            t_min > 0.0 && t_min.is_finite() && t_max.is_finite() && t_max > t_min && n >= 2;
        if !valid {
            return BlackbodyTable {
                t_min: 0.0,
                t_max: 0.0,
                u_min: 0.0,
                inv_du: 0.0,
                entries: Vec::new(),
            };
        }
        let (u_min, u_max) = (1.0 / t_max, 1.0 / t_min);
        let du = (u_max - u_min) / (n - 1) as f64;
        let entries = (0..n)
            .map(|i| {
                let t = match i {
                    0 => t_max,
                    i if i == n - 1 => t_min,
                    i => 1.0 / (u_min + du * i as f64),
                };
                let t = t.clamp(T_MIN, T_MAX);
                let (ln_s, xyz) = xyz_scaled(t);
                (normalize_rgb(t, xyz), ln_s + xyz[1].ln())
            })
            .collect();
        BlackbodyTable {
            t_min,
            t_max,
            u_min,
            inv_du: 1.0 / du,
            entries,
        }
    }

    /// The tabulated range `(t_min, t_max)`.
    pub fn range(&self) -> (f64, f64) {
        (self.t_min, self.t_max)
    }

    /// Index and fraction of `t` in the table, if inside the range.
    #[inline]
    fn locate(&self, t: f64) -> Option<(usize, f64)> {
        if self.entries.len() < 2 || !(t >= self.t_min && t <= self.t_max) {
            return None;
        }
        let x = (1.0 / t - self.u_min) * self.inv_du;
        let i = (x.max(0.0).floor() as usize).min(self.entries.len() - 2);
        Some((i, (x - i as f64).clamp(0.0, 1.0)))
    }

    /// [`blackbody_rgb_normalized`], interpolated.
    pub fn rgb_normalized(&self, t: f64) -> [f64; 3] {
        match self.locate(t) {
            Some((i, f)) => lerp3(self.entries[i].0, self.entries[i + 1].0, f),
            None => blackbody_rgb_normalized(t),
        }
    }

    /// [`blackbody_radiance_rgb`], interpolated.
    pub fn radiance_rgb(&self, t: f64) -> [f64; 3] {
        match self.locate(t) {
            Some((i, f)) => {
                let (c0, l0) = self.entries[i];
                let (c1, l1) = self.entries[i + 1];
                let y = (l0 + (l1 - l0) * f).exp();
                lerp3(c0, c1, f).map(|c| c * y)
            }
            None => blackbody_radiance_rgb(t),
        }
    }
}

#[inline]
fn lerp3(a: [f64; 3], b: [f64; 3], f: f64) -> [f64; 3] {
    [
        a[0] + (b[0] - a[0]) * f,
        a[1] + (b[1] - a[1]) * f,
        a[2] + (b[2] - a[2]) * f,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chromaticity(xyz: [f64; 3]) -> (f64, f64) {
        let s = xyz[0] + xyz[1] + xyz[2];
        (xyz[0] / s, xyz[1] / s)
    }

    /// Kim et al. (2002) cubic-spline approximation of the CIE 1931 Planckian locus,
    /// valid 1667–25000 K, an independent reference for the chromaticities.
    fn planckian_locus_kim(t: f64) -> (f64, f64) {
        let (t1, t2, t3) = (1e3 / t, 1e6 / (t * t), 1e9 / (t * t * t));
        let x = if t <= 4000.0 {
            -0.266_123_9 * t3 - 0.234_358_9 * t2 + 0.877_695_6 * t1 + 0.179_910
        } else {
            -3.025_846_9 * t3 + 2.107_037_9 * t2 + 0.222_634_7 * t1 + 0.240_390
        };
        let y = if t <= 2222.0 {
            -1.106_381_4 * x.powi(3) - 1.348_110_20 * x * x + 2.185_558_32 * x - 0.202_196_83
        } else if t <= 4000.0 {
            -0.954_947_6 * x.powi(3) - 1.374_185_93 * x * x + 2.091_370_15 * x - 0.167_488_67
        } else {
            3.081_758_0 * x.powi(3) - 5.873_386_70 * x * x + 3.751_129_97 * x - 0.370_014_83
        };
        (x, y)
    }

    #[test]
    fn cmf_fit_shape() {
        // ȳ peaks near 555 nm at ≈ 1; the fit's known values there.
        let y555 = cie_xyz_cmf(555.0)[1];
        assert!((y555 - 1.0).abs() < 0.01, "{y555}");
        // Equal-energy white has x ≈ y ≈ 1/3 (each CMF integrates to ~106.9 nm).
        let mut s = [0.0; 3];
        for (_, c) in cmf_table() {
            for k in 0..3 {
                s[k] += c[k];
            }
        }
        for k in 0..3 {
            assert!((s[k] - 106.86).abs() < 1.0, "{s:?}");
        }
        let (x, y) = chromaticity(s);
        assert!(
            (x - 1.0 / 3.0).abs() < 0.003 && (y - 1.0 / 3.0).abs() < 0.003,
            "{x} {y}"
        );
    }

    #[test]
    fn planck_matches_closed_form_and_wien() {
        // Direct evaluation at a moderate point.
        let (l, t): (f64, f64) = (500.0, 5000.0);
        let lm = l * 1e-9;
        let direct = C1L / lm.powi(5) / ((C2 / (lm * t)).exp() - 1.0) * 1e-9;
        assert!((planck_spectral_radiance(l, t) / direct - 1.0).abs() < 1e-13);
        // Sun-like 5778 K peaks near Wien's λ = 2.8978e-3/T ≈ 501.5 nm.
        let t = 5778.0;
        let peak = (400..700).map(|l| l as f64).max_by(|a, b| {
            planck_spectral_radiance(*a, t).total_cmp(&planck_spectral_radiance(*b, t))
        });
        assert_eq!(peak, Some(502.0));
        assert_eq!(planck_spectral_radiance(500.0, 0.0), 0.0);
        assert_eq!(planck_spectral_radiance(500.0, f64::NAN), 0.0);
        assert!(planck_spectral_radiance(500.0, 1e9).is_finite());
    }

    #[test]
    fn planck_integrates_to_stefan_boltzmann() {
        // σ from the exact constants.
        let pi = std::f64::consts::PI;
        let sigma = 2.0 * pi.powi(5) * BOLTZMANN_K.powi(4)
            / (15.0 * PLANCK_H.powi(3) * SPEED_OF_LIGHT.powi(2));
        assert!((sigma / STEFAN_BOLTZMANN - 1.0).abs() < 1e-9, "{sigma}");
        // ∫ B_λ dλ over all wavelengths, in x = ln λ (trapezoid on a wide log grid).
        for t in [300.0, 1500.0, 6000.0] {
            let (lo, hi, n) = ((1.0f64).ln(), (1e7f64).ln(), 20_000);
            let h = (hi - lo) / n as f64;
            let total: f64 = (0..=n)
                .map(|i| {
                    let l = (lo + h * i as f64).exp();
                    let w = if i == 0 || i == n { 0.5 } else { 1.0 };
                    w * planck_spectral_radiance(l, t) * l * h
                })
                .sum();
            assert!(
                (total / total_radiance(t) - 1.0).abs() < 1e-6,
                "T={t}: {total} vs {}",
                total_radiance(t)
            );
        }
        assert_eq!(total_radiance(-5.0), 0.0);
        assert_eq!(total_radiance(f64::NAN), 0.0);
        assert!(total_radiance(f64::MAX).is_finite());
    }

    #[test]
    fn chromaticity_follows_the_planckian_locus() {
        for t in [
            1700.0, 2000.0, 2856.0, 4000.0, 5000.0, 6504.0, 10000.0, 20000.0,
        ] {
            let (x, y) = chromaticity(blackbody_xyz(t));
            let (kx, ky) = planckian_locus_kim(t);
            // The WSS fit drifts by ~0.003 at the red end, ≤ 0.0015 above 2500 K.
            let tol = if t < 2500.0 { 0.004 } else { 0.0015 };
            assert!(
                (x - kx).abs() < tol && (y - ky).abs() < tol,
                "T={t}: ({x}, {y}) vs ({kx}, {ky})"
            );
        }
        // CIE illuminant A (2856 K Planckian): (0.44757, 0.40745).
        let (x, y) = chromaticity(blackbody_xyz(2856.0));
        assert!(
            (x - 0.44757).abs() < 0.002 && (y - 0.40745).abs() < 0.002,
            "A: {x} {y}"
        );
    }

    #[test]
    fn integration_step_is_converged() {
        // 5 nm trapezoid vs 0.5 nm on the same fit.
        for t in [800.0, 1500.0, 6504.0, 30000.0] {
            let mut fine = [0.0; 3];
            let n = 941;
            for i in 0..n {
                let l = 360.0 + 0.5 * i as f64;
                let w = if i == 0 || i == n - 1 { 0.25 } else { 0.5 };
                let b = planck_spectral_radiance(l, t);
                let c = cie_xyz_cmf(l);
                for k in 0..3 {
                    fine[k] += w * b * c[k];
                }
            }
            let coarse = blackbody_xyz(t);
            for k in 0..3 {
                assert!(
                    (coarse[k] / fine[k] - 1.0).abs() < 2e-3,
                    "T={t} k={k}: {coarse:?} {fine:?}"
                );
            }
        }
    }

    #[test]
    fn d65_temperature_is_near_white() {
        // A 6504 K blackbody is not D65 (D65 lies ~0.003 Δuv above the Planckian locus,
        // towards green), so in Rec.709 it comes out slightly magenta: G is the
        // smallest channel, and all three lie within ~5% of 1 after Y-normalisation.
        let c = blackbody_rgb_normalized(6504.0);
        let y = rec709_luminance(c);
        assert!((y - 1.0).abs() < 1e-12, "{y}");
        for ch in c {
            assert!((ch - 1.0).abs() < 0.06, "{c:?}");
        }
        assert!(c[1] < c[0] && c[1] < c[2], "{c:?}");
        let spread =
            c.iter().cloned().fold(f64::MIN, f64::max) / c.iter().cloned().fold(f64::MAX, f64::min);
        assert!(spread < 1.1, "{c:?}");
    }

    #[test]
    fn low_temperatures_are_red_high_are_blue() {
        let c = blackbody_rgb_normalized(1500.0);
        assert!(c[0] > c[1] && c[1] > c[2], "{c:?}");
        assert!(c[0] > 2.0 * c[1], "{c:?}");
        let c = blackbody_rgb_normalized(15000.0);
        assert!(c[2] > c[0], "{c:?}");
        assert!(c[2] > c[1], "{c:?}");
        // Monotone hue: the blue/red ratio rises with temperature (where both > 0).
        let mut prev = 0.0;
        for i in 0..60 {
            let t = 2000.0 + 500.0 * i as f64;
            let c = blackbody_rgb_normalized(t);
            let r = c[2] / c[0];
            assert!(r > prev, "T={t}: {c:?}");
            prev = r;
        }
        // Below the gamut edge blue is clipped to zero, never negative.
        for t in [500.0, 900.0, 1200.0] {
            let c = blackbody_rgb_normalized(t);
            assert!(c.iter().all(|v| *v >= 0.0), "{c:?}");
            assert!((rec709_luminance(c) - 1.0).abs() < 1e-12);
        }
        let raw = xyz_to_linear_rec709(blackbody_xyz(1200.0));
        assert!(raw[2] < 0.0, "1200 K is outside Rec.709: {raw:?}");
    }

    #[test]
    fn low_temperatures_plateau_at_pure_red() {
        // The computed colour is already pure red just above the imposed plateau...
        for t in [PURE_RED_BELOW, 750.0, 800.0, 850.0] {
            assert_eq!(blackbody_rgb_normalized(t)[1..], [0.0, 0.0], "{t}");
            assert!((blackbody_rgb_normalized(t)[0] - PURE_RED[0]).abs() < 1e-12);
        }
        // ...and stays so below it, where the CMF fit's tails would drift to green.
        for t in [1e-9, 1.0, 50.0, 200.0, 400.0, 699.0] {
            assert_eq!(blackbody_rgb_normalized(t), PURE_RED, "{t}");
            let a = blackbody_radiance_rgb(t);
            assert!(
                a[1] == 0.0 && a[2] == 0.0 && a[0] >= 0.0 && a[0].is_finite(),
                "{t}: {a:?}"
            );
        }
        assert!((rec709_luminance(PURE_RED) - 1.0).abs() < 1e-15);
        // Green appears continuously above ~855 K.
        let g = |t: f64| blackbody_rgb_normalized(t)[1];
        assert!(g(860.0) > 0.0 && g(860.0) < 0.01 && g(1000.0) > g(900.0));
    }

    #[test]
    fn absolute_radiance_increases_with_temperature() {
        let mut prev = 0.0;
        let mut t = 300.0;
        while t < 1e8 {
            let y = rec709_luminance(blackbody_radiance_rgb(t));
            assert!(y > prev, "T={t}: {y} <= {prev}");
            // Luminance of the radiance is ∫ B ȳ dλ.
            let want = blackbody_xyz(t)[1];
            assert!((y / want - 1.0).abs() < 1e-12, "T={t}");
            prev = y;
            t *= 1.1;
        }
        // Orders of magnitude: ∫ B ȳ over the visible band.
        let y1500 = blackbody_xyz(1500.0)[1];
        let y6500 = blackbody_xyz(6500.0)[1];
        assert!(y1500 > 5.0 && y1500 < 30.0, "{y1500}");
        assert!(y6500 > 1e6 && y6500 < 1e7, "{y6500}");
        // Rayleigh–Jeans regime: doubling T doubles the visible radiance.
        let r = blackbody_xyz(2e9)[1] / blackbody_xyz(1e9)[1];
        assert!((r - 2.0).abs() < 1e-4, "{r}");
        // Wien regime (visible band far above the peak): Y(2T)/Y(T) is enormous.
        assert!(blackbody_xyz(1000.0)[1] / blackbody_xyz(500.0)[1] > 1e5);
    }

    #[test]
    fn degenerate_temperatures() {
        for t in [0.0, -1.0, -1e9, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert_eq!(blackbody_rgb_normalized(t), [0.0; 3], "{t}");
            assert_eq!(blackbody_radiance_rgb(t), [0.0; 3], "{t}");
            assert_eq!(blackbody_xyz(t), [0.0; 3], "{t}");
        }
        for t in [1e-300, 1e-3, 0.5, 1.0, 10.0, 1e5, 1e9, 1e20, 1e40, f64::MAX] {
            let n = blackbody_rgb_normalized(t);
            let a = blackbody_radiance_rgb(t);
            assert!(
                n.iter().chain(a.iter()).all(|v| v.is_finite() && *v >= 0.0),
                "T={t}: {n:?} {a:?}"
            );
            assert!((rec709_luminance(n) - 1.0).abs() < 1e-12, "T={t}: {n:?}");
        }
        // Huge temperatures converge to the Rayleigh–Jeans colour (bluish).
        let a = blackbody_rgb_normalized(1e5);
        let b = blackbody_rgb_normalized(1e9);
        assert!(b[2] > b[0] && a[2] > a[0]);
        let c = blackbody_rgb_normalized(1e7);
        assert!((0..3).all(|k| (a[k] - b[k]).abs() < 0.1), "{a:?} {b:?}");
        assert!((0..3).all(|k| (c[k] - b[k]).abs() < 1e-3), "{c:?} {b:?}");
        assert_eq!(grid_value_to_kelvin(2.0, 1000.0, 300.0), 2300.0);
    }

    #[test]
    fn table_matches_direct_evaluation() {
        // (range, samples, tolerance): the largest errors sit at the ~855 K kink where
        // green re-enters the gamut.
        for (lo, hi, n, tol) in [(500.0, 6000.0, 4096, 3e-4), (200.0, 40000.0, 2048, 2e-3)] {
            let table = BlackbodyTable::new(lo, hi, n);
            assert_eq!(table.range(), (lo, hi));
            let mut t = lo;
            while t <= hi {
                let (d, l) = (blackbody_radiance_rgb(t), table.radiance_rgb(t));
                let (dn, ln) = (blackbody_rgb_normalized(t), table.rgb_normalized(t));
                let scale = d.iter().cloned().fold(0.0, f64::max);
                for k in 0..3 {
                    assert!((d[k] - l[k]).abs() <= tol * scale, "T={t}: {d:?} {l:?}");
                    assert!((dn[k] - ln[k]).abs() <= tol, "T={t}: {dn:?} {ln:?}");
                }
                t *= 1.0007;
            }
            assert_eq!(table.rgb_normalized(hi), blackbody_rgb_normalized(hi));
        }
        let table = BlackbodyTable::new(500.0, 6000.0, 4096);
        // Outside the range and degenerate input fall back to the exact functions.
        assert_eq!(table.radiance_rgb(9000.0), blackbody_radiance_rgb(9000.0));
        assert_eq!(table.rgb_normalized(-3.0), [0.0; 3]);
        let empty = BlackbodyTable::new(10.0, 5.0, 100);
        assert_eq!(
            empty.rgb_normalized(3000.0),
            blackbody_rgb_normalized(3000.0)
        );
    }
}
