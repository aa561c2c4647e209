//! The phase function of water drops in colour: Lorenz–Mie theory ([`super::mie`]) at
//! [`WAVELENGTHS_NM`], averaged over a ±10 % spread of radii, weighted by the CIE 1931
//! matching functions into linear Rec.709 per-channel tables.
//!
//! # Tables
//! Each wavelength's phase function is tabulated at the nodes of an [`AngleGrid`]
//! (logarithmic near θ = 0 for the diffraction peak of big drops, whose width is
//! ~1/x ≈ 10⁻⁴ rad; uniform every 0.05° beyond 2.9°) and is linear in θ between nodes.
//! Integrated exactly under that interpolation it comes to 1 within the grid's error
//! ([`WaterDrop::mie_integral`]; checked against Mie's `Q_sca`), and is rescaled to 1.
//!
//! A channel `c` is `p_c(θ) = Σ_λ W_c(λ) p_λ(θ)`, with `W_c(λ) ∝ [M·x̄ȳz̄(λ)]_c Δλ`
//! (`M` the XYZ → linear Rec.709 matrix, an equal-energy spectrum) scaled so that
//! `Σ_λ W_c(λ) = 1`: a phase function flat in wavelength gives the same value in every
//! channel, so white light stays white. Spectral colours lie outside the Rec.709
//! gamut, so a channel can come out negative where one wavelength dominates (the bow's
//! edge); those values are clipped to 0 and the channel renormalised
//! ([`WaterDrop::clipped`] says by how much).
//!
//! # Sampling
//! A bin (pair of nodes) is drawn with probability `∫_bin p̄ dΩ`, `p̄` the mean of the
//! three channels, and the direction uniformly in solid angle within the bin: the pdf
//! is piecewise constant per bin, exactly what [`PhaseFunction::pdf`] returns, and the
//! weight `p_c/pdf` is within a few per cent of 1.
//!
//! # Cost and cache
//! Building the tables sums the Mie series (`N ≈ x` terms) at every node, for 17
//! wavelengths × 12 radii: about a second for 10 µm drops, tens of seconds at 500 µm.
//! [`WaterDrop::cached`] keeps every table built in this process (keyed by radius), so
//! a render builds it once and every integrator, tile and test shares it;
//! [`WaterDrop::for_render`] also keeps them on disk ([`disk_cache`]), so later renders
//! of the same radius load them in milliseconds.

use super::mie::{self, averaged_radii, water_refractive_index};
use super::{PhaseFunction, PhaseSample, frame_around};
use crate::integrate::blackbody::{cie_xyz_cmf, xyz_to_linear_rec709};
use glam::DVec3;
use rayon::prelude::*;
use std::collections::HashMap;
use std::f64::consts::PI;
use std::sync::{Arc, Mutex, OnceLock};

/// The wavelengths [nm] the phase function is computed at: 380, 405, …, 780.
pub const WAVELENGTHS_NM: [f64; 17] = {
    let mut w = [0.0; 17];
    let mut i = 0;
    while i < 17 {
        w[i] = 380.0 + 25.0 * i as f64;
        i += 1;
    }
    w
};

/// Smallest and largest drop radius [µm] accepted: the size parameter at 380 nm then
/// stays under [`mie::X_MAX`].
pub const RADIUS_RANGE_UM: (f64, f64) = (0.05, 1000.0);

/// Default drop radius [µm] for `--phase water-drop`: raindrops, bright sharp bows.
pub const DEFAULT_RADIUS_UM: f64 = 500.0;

/// A radius outside [`RADIUS_RANGE_UM`] (or not a number).
#[derive(Clone, Debug, thiserror::Error, PartialEq)]
#[error(
    "drop radius {0} µm is outside {min}–{max} µm",
    min = RADIUS_RANGE_UM.0,
    max = RADIUS_RANGE_UM.1
)]
pub struct RadiusError(pub f64);

/// Scattering angles θ (radians) at which the tables are given: `θᵢ = θ₀(e^{iδ} − 1)`
/// for `i ≤ n_log` (fine near the forward peak), then uniform steps of `step` up to π.
#[derive(Clone, Debug)]
pub struct AngleGrid {
    theta0: f64,
    delta: f64,
    n_log: usize,
    theta_split: f64,
    step: f64,
    nodes: Vec<f64>,
}

impl AngleGrid {
    /// The grid used by [`WaterDrop`]: θ₀ = 10⁻⁴ rad, uniform 0.05° from ≈ 2.9°.
    pub fn standard() -> Self {
        let step = 0.05f64.to_radians();
        let theta0 = 1e-4;
        let split_target = 0.05;
        // The log segment's last step equals the uniform one: (θ₀ + θ) δ = step.
        let delta = step / (theta0 + split_target);
        let n_log = ((split_target / theta0).ln_1p() / delta).round() as usize;
        let theta_split = theta0 * (n_log as f64 * delta).exp_m1();
        let n_uni = ((PI - theta_split) / step).ceil() as usize;
        let step = (PI - theta_split) / n_uni as f64;
        let mut nodes: Vec<f64> = (0..=n_log)
            .map(|i| theta0 * (i as f64 * delta).exp_m1())
            .collect();
        nodes.extend((1..=n_uni).map(|i| theta_split + i as f64 * step));
        *nodes.last_mut().expect("grid has nodes") = PI;
        AngleGrid {
            theta0,
            delta,
            n_log,
            theta_split,
            step,
            nodes,
        }
    }

    /// The nodes, from 0 to π.
    pub fn nodes(&self) -> &[f64] {
        &self.nodes
    }

    /// The bin `i` (between nodes `i` and `i + 1`) holding `theta` and the fraction of
    /// the way across it; `theta` is clamped to [0, π].
    #[inline]
    pub fn locate(&self, theta: f64) -> (usize, f64) {
        let last = self.nodes.len() - 2;
        let i = if theta < self.theta_split {
            ((theta / self.theta0).ln_1p() / self.delta).max(0.0) as usize
        } else {
            self.n_log + ((theta - self.theta_split) / self.step) as usize
        }
        .min(last);
        let (a, b) = (self.nodes[i], self.nodes[i + 1]);
        (i, ((theta - a) / (b - a)).clamp(0.0, 1.0))
    }
}

/// `(w_a, w_b)` with `∫_a^b f(θ) sinθ dθ = f(a)·w_a + f(b)·w_b` for `f` linear in θ
/// on `[a, b]`, without cancellation for tiny bins.
fn bin_weights(a: f64, b: f64) -> (f64, f64) {
    let h = b - a;
    let (m, x) = (0.5 * (a + b), 0.5 * h);
    // 2 sin x − 2x cos x, by its series where it cancels.
    let g = if x < 0.05 {
        let x2 = x * x;
        x * x2 * (2.0 / 3.0 - x2 / 15.0 + x2 * x2 / 420.0)
    } else {
        2.0 * x.sin() - h * x.cos()
    };
    let total = 2.0 * m.sin() * x.sin(); // cos a − cos b
    let wb = (m.cos() * g + h * m.sin() * x.sin()) / h;
    (total - wb, wb)
}

/// `∫ f dΩ = 2π ∫ f sinθ dθ` of a table linear in θ between the nodes.
pub fn integrate_table(nodes: &[f64], values: &[f64]) -> f64 {
    let mut s = 0.0;
    for i in 0..nodes.len() - 1 {
        let (wa, wb) = bin_weights(nodes[i], nodes[i + 1]);
        s += values[i] * wa + values[i + 1] * wb;
    }
    2.0 * PI * s
}

/// Each wavelength's Mie phase function at `nodes` for drops of `radius_um` (averaged
/// over ±10 %), normalised to 1 by its exact integral under linear interpolation, and
/// that integral before normalising (by `Q_sca`: 1 up to the grid's error).
fn mie_tables(radius_um: f64, nodes: &[f64]) -> (Vec<Vec<f64>>, Vec<f64>) {
    let mu: Vec<f64> = nodes.iter().map(|t| t.cos()).collect();
    let radii = averaged_radii(radius_um * 1e3); // nm, like the wavelengths
    WAVELENGTHS_NM
        .par_iter()
        .map(|&l| {
            let p = mie::averaged_phase(water_refractive_index(l), l, &radii, &mu)
                .expect("radius range keeps x within mie::X_MAX");
            let integral = integrate_table(nodes, &p);
            (p.iter().map(|v| v / integral).collect(), integral)
        })
        .unzip()
}

/// The tabulated spectral phase function of water drops of one radius.
#[derive(Debug)]
pub struct WaterDrop {
    radius_um: f64,
    grid: AngleGrid,
    spectral: Vec<Vec<f64>>,
    mie_integral: Vec<f64>,
    rgb: Vec<DVec3>,
    clipped: [f64; 3],
    /// Cumulative probability at the start of each bin (and 1 at the end).
    cdf: Vec<f64>,
    /// The sampling density in each bin, per steradian.
    bin_pdf: Vec<f64>,
    /// `1 − cos θᵢ` at each node, accurate near θ = 0.
    one_minus_cos: Vec<f64>,
    max_value: f64,
}

/// Per-channel weights `W_c(λ)` over [`WAVELENGTHS_NM`], each channel summing to 1.
pub fn channel_weights() -> [[f64; 3]; WAVELENGTHS_NM.len()] {
    let n = WAVELENGTHS_NM.len();
    let mut w = [[0.0; 3]; WAVELENGTHS_NM.len()];
    let mut sum = [0.0; 3];
    for (j, &l) in WAVELENGTHS_NM.iter().enumerate() {
        let trapezoid = if j == 0 || j == n - 1 { 0.5 } else { 1.0 };
        let rgb = xyz_to_linear_rec709(cie_xyz_cmf(l));
        for c in 0..3 {
            w[j][c] = trapezoid * rgb[c];
            sum[c] += w[j][c];
        }
    }
    for row in &mut w {
        for c in 0..3 {
            row[c] /= sum[c];
        }
    }
    w
}

impl WaterDrop {
    /// Computes the tables for drops of radius `radius_um` micrometres (averaged over
    /// ±10 %). Takes from a fraction of a second to a minute: prefer [`Self::cached`].
    pub fn new(radius_um: f64) -> Result<Self, RadiusError> {
        if !(radius_um >= RADIUS_RANGE_UM.0 && radius_um <= RADIUS_RANGE_UM.1) {
            return Err(RadiusError(radius_um));
        }
        let grid = AngleGrid::standard();
        let (spectral, mie_integral) = mie_tables(radius_um, grid.nodes());
        Ok(Self::from_spectral(radius_um, grid, spectral, mie_integral))
    }

    /// The colour tables and sampling data from per-wavelength tables (normalised to 1
    /// at the nodes of `grid`): milliseconds, where [`mie_tables`] takes seconds.
    fn from_spectral(
        radius_um: f64,
        grid: AngleGrid,
        spectral: Vec<Vec<f64>>,
        mie_integral: Vec<f64>,
    ) -> Self {
        let nodes = grid.nodes().to_vec();
        let weights = channel_weights();
        let mut channels = [
            vec![0.0; nodes.len()],
            vec![0.0; nodes.len()],
            vec![0.0; nodes.len()],
        ];
        let mut clipped = [0.0; 3];
        for (c, channel) in channels.iter_mut().enumerate() {
            for (i, v) in channel.iter_mut().enumerate() {
                *v = spectral
                    .iter()
                    .zip(&weights)
                    .map(|(p, w)| w[c] * p[i])
                    .sum::<f64>();
            }
            let negative: Vec<f64> = channel.iter().map(|v| v.min(0.0)).collect();
            clipped[c] = -integrate_table(&nodes, &negative);
            channel.iter_mut().for_each(|v| *v = v.max(0.0));
            let total = integrate_table(&nodes, channel);
            channel.iter_mut().for_each(|v| *v /= total);
        }
        let rgb: Vec<DVec3> = (0..nodes.len())
            .map(|i| DVec3::new(channels[0][i], channels[1][i], channels[2][i]))
            .collect();
        let one_minus_cos: Vec<f64> = nodes
            .iter()
            .map(|t| 2.0 * (0.5 * t).sin().powi(2))
            .collect();
        let mut cdf = Vec::with_capacity(nodes.len());
        let mut bin_pdf = Vec::with_capacity(nodes.len() - 1);
        cdf.push(0.0);
        let mut acc = 0.0;
        for i in 0..nodes.len() - 1 {
            let (wa, wb) = bin_weights(nodes[i], nodes[i + 1]);
            let mean = |v: DVec3| (v.x + v.y + v.z) / 3.0;
            let prob = 2.0 * PI * (mean(rgb[i]) * wa + mean(rgb[i + 1]) * wb);
            acc += prob;
            cdf.push(acc);
            let solid = 2.0 * PI * (one_minus_cos[i + 1] - one_minus_cos[i]);
            bin_pdf.push(prob / solid);
        }
        // acc is 1 up to rounding (each channel integrates to 1): make the ends exact.
        cdf.iter_mut().for_each(|c| *c /= acc);
        bin_pdf.iter_mut().for_each(|p| *p /= acc);
        let max_value = rgb.iter().map(|v| v.max_element()).fold(0.0, f64::max);
        WaterDrop {
            radius_um,
            grid,
            spectral,
            mie_integral,
            rgb,
            clipped,
            cdf,
            bin_pdf,
            one_minus_cos,
            max_value,
        }
    }

    /// The tables for `radius_um`, computed on first use in this process and shared
    /// afterwards (a process-wide map keyed by the radius's bits; never evicted — a
    /// table is ~0.6 MB).
    pub fn cached(radius_um: f64) -> Result<Arc<WaterDrop>, RadiusError> {
        Self::cached_with(radius_um, false)
    }

    /// [`Self::cached`], and on disk ([`disk_cache`]): what a render uses, so only the
    /// first render of a radius on a machine pays for the Mie sums.
    pub fn for_render(radius_um: f64) -> Result<Arc<WaterDrop>, RadiusError> {
        Self::cached_with(radius_um, true)
    }

    fn cached_with(radius_um: f64, disk: bool) -> Result<Arc<WaterDrop>, RadiusError> {
        type Slot = Arc<OnceLock<Result<Arc<WaterDrop>, RadiusError>>>;
        static CACHE: OnceLock<Mutex<HashMap<u64, Slot>>> = OnceLock::new();
        let slot = CACHE
            .get_or_init(|| Mutex::new(HashMap::new()))
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .entry(radius_um.to_bits())
            .or_default()
            .clone();
        // Built outside the map's lock (another radius need not wait); callers asking
        // for the same radius meanwhile wait for this one build.
        slot.get_or_init(|| {
            if !disk {
                return WaterDrop::new(radius_um).map(Arc::new);
            }
            Self::load_or_build(radius_um).map(Arc::new)
        })
        .clone()
    }

    fn load_or_build(radius_um: f64) -> Result<WaterDrop, RadiusError> {
        if !(radius_um >= RADIUS_RANGE_UM.0 && radius_um <= RADIUS_RANGE_UM.1) {
            return Err(RadiusError(radius_um));
        }
        let grid = AngleGrid::standard();
        let path = disk_cache::dir().map(|d| disk_cache::file(&d, radius_um, &grid));
        if let Some((spectral, integrals)) = path.as_ref().and_then(|p| disk_cache::load(p, &grid))
        {
            return Ok(Self::from_spectral(radius_um, grid, spectral, integrals));
        }
        let (spectral, integrals) = mie_tables(radius_um, grid.nodes());
        if let Some(p) = &path {
            disk_cache::store(p, &grid, &spectral, &integrals);
        }
        Ok(Self::from_spectral(radius_um, grid, spectral, integrals))
    }

    pub fn radius_um(&self) -> f64 {
        self.radius_um
    }

    /// The angle grid (radians) of the tables.
    pub fn angles(&self) -> &[f64] {
        self.grid.nodes()
    }

    /// The per-channel table at the nodes of [`Self::angles`].
    pub fn rgb_table(&self) -> &[DVec3] {
        &self.rgb
    }

    /// The phase function at wavelength [`WAVELENGTHS_NM`]`[j]`, at the nodes,
    /// normalised over the sphere.
    pub fn spectral_table(&self, j: usize) -> &[f64] {
        &self.spectral[j]
    }

    /// `∫ p dΩ` of each wavelength's Mie table (normalised by `Q_sca`) before it was
    /// rescaled to 1: how well the grid resolves the phase function.
    pub fn mie_integral(&self) -> &[f64] {
        &self.mie_integral
    }

    /// Per channel, the integral of the negative part clipped away (before
    /// renormalisation), as a fraction of the channel's total 1.
    pub fn clipped(&self) -> [f64; 3] {
        self.clipped
    }

    /// The phase function at wavelength index `j`, at scattering angle `theta`.
    pub fn eval_spectral(&self, j: usize, theta: f64) -> f64 {
        let (i, f) = self.grid.locate(theta);
        let t = &self.spectral[j];
        t[i] + (t[i + 1] - t[i]) * f
    }

    /// The bin of the scattering-angle cosine `cos_theta`.
    #[inline]
    fn bin_of(&self, cos_theta: f64) -> (usize, f64) {
        self.grid.locate(cos_theta.clamp(-1.0, 1.0).acos())
    }
}

impl PhaseFunction for WaterDrop {
    #[inline]
    fn eval(&self, cos_theta: f64) -> DVec3 {
        let (i, f) = self.bin_of(cos_theta);
        self.rgb[i].lerp(self.rgb[i + 1], f)
    }

    fn sample(&self, incoming: DVec3, u: [f64; 2]) -> PhaseSample {
        let xi = u[0].clamp(0.0, 1.0);
        // The last bin whose start is ≤ xi, skipping empty bins.
        let i = (self.cdf.partition_point(|&c| c <= xi).max(1) - 1).min(self.bin_pdf.len() - 1);
        let width = self.cdf[i + 1] - self.cdf[i];
        let v = if width > 0.0 {
            ((xi - self.cdf[i]) / width).clamp(0.0, 1.0)
        } else {
            0.5
        };
        let omc = self.one_minus_cos[i] + v * (self.one_minus_cos[i + 1] - self.one_minus_cos[i]);
        let cos_theta = (1.0 - omc).clamp(-1.0, 1.0);
        let pdf = self.bin_pdf[i];
        let value = self.eval(cos_theta);
        PhaseSample {
            dir: frame_around(incoming, cos_theta, 2.0 * PI * u[1]),
            weight: if pdf > 0.0 { value / pdf } else { DVec3::ZERO },
            pdf,
        }
    }

    fn pdf(&self, cos_theta: f64) -> f64 {
        self.bin_pdf[self.bin_of(cos_theta).0]
    }

    fn is_grey(&self) -> bool {
        false
    }

    fn max_value(&self) -> f64 {
        self.max_value
    }

    fn table(&self) -> Option<super::PhaseTable<'_>> {
        let g = &self.grid;
        Some(super::PhaseTable {
            theta0: g.theta0,
            delta: g.delta,
            n_log: g.n_log,
            theta_split: g.theta_split,
            step: g.step,
            nodes: &g.nodes,
            values: &self.rgb,
            cdf: &self.cdf,
            one_minus_cos: &self.one_minus_cos,
            bin_pdf: &self.bin_pdf,
        })
    }
}

pub mod disk_cache;
#[cfg(test)]
mod tests;
