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

    /// What [`BlackbodyTable::rgb_normalized_clamped`] interpolates, for a renderer
    /// that looks it up elsewhere (the GPU): `1/t_max`, `1 / Δ(1/T)` and the normalised
    /// colour at each sample, in increasing `1/T`; no samples for an empty table.
    pub fn rgb_samples(&self) -> (f64, f64, Vec<[f64; 3]>) {
        let rgb = self.entries.iter().map(|e| e.0).collect();
        (self.u_min, self.inv_du, rgb)
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

    /// [`BlackbodyTable::rgb_normalized`] with the colour held at the table's ends
    /// outside its range: the renderer's lookup, never the exact spectral integral per
    /// sample (which cost 15 µs a sample: a Blender cache read as Kelvin, all below
    /// 200 K, rendered 14× slower). The colour changes little past the ends, and what is
    /// emitted there (brightness ∝ K⁴) is below what an image shows at 200 K.
    #[inline]
    pub fn rgb_normalized_clamped(&self, t: f64) -> [f64; 3] {
        if self.entries.len() < 2 || !t.is_finite() {
            return self.rgb_normalized(t);
        }
        self.rgb_normalized(t.clamp(self.t_min, self.t_max))
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
mod tests;
