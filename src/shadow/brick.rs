//! One brick of a deep shadow map: its levels of detail, the samples it holds in each of
//! its forms ([`BrickForm`]: Hermite, Linear, Constant) and how a lookup blends them
//! ([`reconstruct`], [`trilinear`], [`hermite`]). The map of bricks is [`super::map`].

use super::chart::LateralBlend;
use glam::DVec3;

/// Lattice steps per brick side.
pub const BRICK: i32 = 8;
/// The level whose samples are one lattice step (one voxel) apart.
pub const VOXEL_LEVEL: u8 = 3;
/// The finest level any brick may reach: a quarter lattice step. Which level a bake may
/// go to depends on its tolerance (see `BakeSettings::new`).
pub const MAX_LEVEL: u8 = VOXEL_LEVEL + 2;
/// Levels 0..=MAX_LEVEL.
pub const LEVELS: usize = MAX_LEVEL as usize + 1;

/// Samples along one side of a brick at `level`.
#[inline]
pub fn side(level: u8) -> usize {
    (1usize << level) + 1
}

/// Lattice steps between samples at `level`.
#[inline]
pub fn spacing(level: u8) -> f64 {
    BRICK as f64 / (1u32 << level) as f64
}

/// What a sample holds, in the order of [`BrickSamples::planes`].
pub const QUANTITIES: usize = 5;

/// The samples of one brick at its level: `side(level)³` of each quantity, x fastest,
/// then y, then z.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BrickSamples {
    /// `∫ρ ds` toward the light (world units).
    pub tau: Vec<f32>,
    /// Density at the sample: the slope of τ along the column per world unit.
    pub rho: Vec<f32>,
    /// `∂τ/∂x` and `∂τ/∂y` across the light, per lattice step.
    pub tau_x: Vec<f32>,
    pub tau_y: Vec<f32>,
    /// `∂²τ/∂x∂y`, per lattice step squared.
    pub tau_xy: Vec<f32>,
}

impl BrickSamples {
    /// `n` samples of zero.
    pub fn zeros(n: usize) -> Self {
        BrickSamples {
            tau: vec![0.0; n],
            rho: vec![0.0; n],
            tau_x: vec![0.0; n],
            tau_y: vec![0.0; n],
            tau_xy: vec![0.0; n],
        }
    }

    /// Room for `n` samples, none yet.
    pub fn with_capacity(n: usize) -> Self {
        let v = || Vec::with_capacity(n);
        BrickSamples {
            tau: v(),
            rho: v(),
            tau_x: v(),
            tau_y: v(),
            tau_xy: v(),
        }
    }

    pub fn len(&self) -> usize {
        self.tau.len()
    }

    pub fn is_empty(&self) -> bool {
        self.tau.is_empty()
    }

    /// τ, ρ, ∂τ/∂x, ∂τ/∂y, ∂²τ/∂x∂y.
    pub fn planes(&self) -> [&[f32]; QUANTITIES] {
        [&self.tau, &self.rho, &self.tau_x, &self.tau_y, &self.tau_xy]
    }

    fn planes_mut(&mut self) -> [&mut Vec<f32>; QUANTITIES] {
        [
            &mut self.tau,
            &mut self.rho,
            &mut self.tau_x,
            &mut self.tau_y,
            &mut self.tau_xy,
        ]
    }

    /// Appends sample `k` of `other`.
    pub fn push_sample(&mut self, other: &BrickSamples, k: usize) {
        for (to, from) in self.planes_mut().into_iter().zip(other.planes()) {
            to.push(from[k]);
        }
    }

    /// Every quantity holds `n` samples.
    pub(super) fn has_len(&self, n: usize) -> bool {
        self.planes().iter().all(|p| p.len() == n)
    }
}

/// Read access to a brick's samples: quantity `q` (in [`BrickSamples::planes`] order) of
/// sample `k`.
pub trait Samples {
    fn get(&self, q: usize, k: usize) -> f64;
}

impl Samples for [&[f32]; QUANTITIES] {
    #[inline(always)]
    fn get(&self, q: usize, k: usize) -> f64 {
        self[q][k] as f64
    }
}

/// One sample as the map stores it: τ in f32, the other quantities (ρ, ∂τ/∂x, ∂τ/∂y,
/// ∂²τ/∂x∂y) as 16-bit integers scaled per brick and quantity (τ needs f32's digits; the
/// slopes enter the blend weighted by at most 0.15 of a sample step, where 1/65,534 of
/// their range is noise). The five sit together, so a lookup reads one cache line per
/// sample rather than one per quantity.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct PackedSample {
    pub(super) tau: f32,
    pub(super) rest: [i16; QUANTITIES - 1],
}

/// A brick's packed samples and the scales of their 16-bit quantities.
pub struct PackedBrick<'a> {
    pub(super) samples: &'a [PackedSample],
    pub(super) scales: [f32; QUANTITIES - 1],
}

impl Samples for PackedBrick<'_> {
    #[inline(always)]
    fn get(&self, q: usize, k: usize) -> f64 {
        let s = &self.samples[k];
        if q == 0 {
            s.tau as f64
        } else {
            s.rest[q - 1] as f64 * self.scales[q - 1] as f64
        }
    }
}

/// τ inside one cell of a brick's samples. `samples` are the brick's quantities (as
/// [`BrickSamples::planes`]), `m` its samples a side, `cell` the cell's lowest sample,
/// `f` ∈ [0, 1]³ the point's place in the cell, `h` the lattice steps between samples
/// and `unit` the world length of one step.
///
/// On each of the cell's four columns, τ is cubic Hermite in depth (τ and ρ at both
/// ends) and the lateral slopes and twist are linear in depth; across, bicubic Hermite
/// (or linear along an axis where `lateral` says so).
#[inline]
pub fn reconstruct(
    samples: &impl Samples,
    m: usize,
    cell: [usize; 3],
    f: DVec3,
    h: f64,
    unit: f64,
    lateral: [LateralBlend; 2],
) -> f64 {
    let base = cell[0] + m * (cell[1] + m * cell[2]);
    let depth = DepthBlend::new(f.z, h, unit);
    let column = |d: usize| depth.column(samples, base + d, m * m);
    blend_across(
        [column(0), column(1), column(m), column(m + 1)],
        f.x,
        f.y,
        lateral,
    )
}

/// The blend along one column of a cell at place `t` ∈ [0, 1] in depth, for
/// [`reconstruct`]: τ cubic Hermite (τ and ρ at both ends), the lateral slopes and twist
/// linear, each scaled for the blend across.
#[derive(Clone, Copy)]
pub struct DepthBlend {
    hermite: (f64, f64, f64, f64),
    t: f64,
    h: f64,
    /// Slope per unit of t along the column: density × world length of one sample step.
    step: f64,
}

impl DepthBlend {
    #[inline]
    pub fn new(t: f64, h: f64, unit: f64) -> Self {
        DepthBlend {
            hermite: hermite(t),
            t,
            h,
            step: h * unit,
        }
    }

    /// The column whose top sample is `a` (its bottom `a + dz`): τ there, and the lateral
    /// slopes and twist times the sample spacing.
    #[inline]
    pub fn column(&self, samples: &impl Samples, a: usize, dz: usize) -> [f64; 4] {
        let (z0, zs0, z1, zs1) = self.hermite;
        let (h, b) = (self.h, a + dz);
        let v = |q: usize, k: usize| samples.get(q, k);
        let lin = |q: usize| v(q, a) + (v(q, b) - v(q, a)) * self.t;
        [
            z0 * v(0, a) + z1 * v(0, b) + self.step * (zs0 * v(1, a) + zs1 * v(1, b)),
            h * lin(2),
            h * lin(3),
            h * h * lin(4),
        ]
    }
}

/// The blend across a cell of its four columns' [`DepthBlend::column`]s (x low y low,
/// x high y low, x low y high, x high y high) at `(fx, fy)`: bicubic Hermite, or linear
/// along an axis where `lateral` says so.
#[inline]
pub fn blend_across(columns: [[f64; 4]; 4], fx: f64, fy: f64, lateral: [LateralBlend; 2]) -> f64 {
    let weights = |blend: LateralBlend, t: f64| match blend {
        LateralBlend::Hermite => hermite(t),
        LateralBlend::Linear => (1.0 - t, 0.0, t, 0.0),
    };
    let (x0, xs0, x1, xs1) = weights(lateral[0], fx);
    let (y0, ys0, y1, ys1) = weights(lateral[1], fy);
    let corner = |c: [f64; 4], (wx, wsx): (f64, f64), (wy, wsy): (f64, f64)| {
        c[0] * wx * wy + c[1] * wsx * wy + c[2] * wx * wsy + c[3] * wsx * wsy
    };
    let [c00, c10, c01, c11] = columns;
    corner(c00, (x0, xs0), (y0, ys0))
        + corner(c10, (x1, xs1), (y0, ys0))
        + corner(c01, (x0, xs0), (y1, ys1))
        + corner(c11, (x1, xs1), (y1, ys1))
}

/// How a brick holds its values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BrickForm {
    /// τ and its slopes at every sample, blended by [`reconstruct`] (12 bytes a sample).
    Hermite,
    /// τ alone at every sample as a 16-bit step above the brick's least τ, blended
    /// trilinearly (2 bytes a sample): where the bake found that blend within the
    /// tolerance at the brick's level.
    Linear,
    /// One τ for the whole brick, a lower bound: where the light left at the brick's top
    /// is already below the tolerance, whatever τ does below (no samples).
    Constant,
}

impl BrickForm {
    /// The number a shadow cache stores it as.
    pub fn code(self) -> u8 {
        match self {
            BrickForm::Hermite => 0,
            BrickForm::Linear => 1,
            BrickForm::Constant => 2,
        }
    }

    pub fn from_code(code: u8) -> Option<Self> {
        [BrickForm::Hermite, BrickForm::Linear, BrickForm::Constant]
            .into_iter()
            .find(|f| f.code() == code)
    }
}

/// τ's base and step for a Linear brick: its least value, and its range over 65,535.
pub(super) fn linear_scale(tau: &[f32]) -> (f32, f32) {
    let (lo, hi) = tau
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &t| {
            (lo.min(t), hi.max(t))
        });
    if !(lo.is_finite() && hi.is_finite()) {
        return (0.0, 0.0);
    }
    (lo, (hi - lo) / u16::MAX as f32)
}

/// `x.round().clamp(lo, hi)` (halves away from zero) as an integer, NaN as 0, for
/// bounds within ±2²⁴: the same numbers without the call into `roundf` that `f32::round`
/// is on x86-64's baseline instruction set (it has no rounding instruction before
/// SSE4.1), which took most of a brick's packing.
#[inline]
pub(super) fn round_clamped(x: f32, lo: f32, hi: f32) -> i32 {
    let v = x.clamp(lo, hi) as f64;
    // |v| ≤ 2²⁴: v + ½ is exact in f64, and `as` truncates toward zero.
    if v >= 0.0 {
        (v + 0.5) as i32
    } else {
        -((0.5 - v) as i32)
    }
}

#[inline]
pub(super) fn quantise(t: f32, base: f32, step: f32) -> u16 {
    if step > 0.0 {
        round_clamped((t - base) / step, 0.0, u16::MAX as f32) as u16
    } else {
        0
    }
}

/// The largest transmittance error a Linear brick's 16-bit τ adds, in any channel of
/// `sigmas` (ascending): half a step, where the light is at most `e^{−σ·base}`.
pub fn linear_rounding_error(tau: &[f32], sigmas: &[f64]) -> f64 {
    let (base, step) = linear_scale(tau);
    sigmas
        .iter()
        .map(|&s| s * 0.5 * step as f64 * (-s * base as f64).exp())
        .fold(0.0, f64::max)
}

/// Trilinear blend of the cell whose lowest sample is `v(0)`, in a brick `m` samples a
/// side, at `f` ∈ [0, 1]³.
#[inline]
pub fn trilinear(v: impl Fn(usize) -> f64, m: usize, f: DVec3) -> f64 {
    let dz = m * m;
    let row = |d: usize| v(d) + (v(d + 1) - v(d)) * f.x;
    let plane = |d: usize| row(d) + (row(d + m) - row(d)) * f.y;
    plane(0) + (plane(dz) - plane(0)) * f.z
}

/// The cubic Hermite basis at `t` ∈ [0, 1]: weights of (v0, slope0, v1, slope1).
#[inline]
pub fn hermite(t: f64) -> (f64, f64, f64, f64) {
    let (t2, t3) = (t * t, t * t * t);
    (
        2.0 * t3 - 3.0 * t2 + 1.0,
        t3 - 2.0 * t2 + t,
        -2.0 * t3 + 3.0 * t2,
        t3 - t2,
    )
}

/// One brick packed as a map stores it, apart from any map: its level and form, the
/// scales of its 16-bit quantities and its samples in its form's store.
#[derive(Clone, Debug, PartialEq)]
pub struct EncodedBrick {
    pub(super) level: u8,
    pub(super) form: BrickForm,
    pub(super) scales: [f32; QUANTITIES - 1],
    pub(super) hermite: Vec<PackedSample>,
    pub(super) linear: Vec<u16>,
}

impl EncodedBrick {
    /// Packs a finished brick: Hermite needs every quantity at all `side(level)³`
    /// samples, Linear τ alone, Constant one τ (the first); `None` where they lack.
    pub fn new(level: u8, form: BrickForm, samples: &BrickSamples) -> Option<Self> {
        let n = side(level).pow(3);
        let mut brick = EncodedBrick {
            level,
            form,
            scales: [0.0; QUANTITIES - 1],
            hermite: Vec::new(),
            linear: Vec::new(),
        };
        match form {
            BrickForm::Hermite => {
                if !samples.has_len(n) {
                    return None;
                }
                let planes = samples.planes();
                let scales: [f32; QUANTITIES - 1] = std::array::from_fn(|q| {
                    let max = planes[q + 1].iter().fold(0f32, |m, v| m.max(v.abs()));
                    if max > 0.0 && max.is_finite() {
                        max / i16::MAX as f32
                    } else {
                        1.0
                    }
                });
                let limit = i16::MAX as f32;
                let pack = |v: f32, scale: f32| round_clamped(v / scale, -limit, limit) as i16;
                brick.hermite = (0..n)
                    .map(|k| PackedSample {
                        tau: planes[0][k],
                        rest: std::array::from_fn(|q| pack(planes[q + 1][k], scales[q])),
                    })
                    .collect();
                brick.scales = scales;
            }
            BrickForm::Linear => {
                if samples.tau.len() != n {
                    return None;
                }
                let (base, step) = linear_scale(&samples.tau);
                brick.linear = samples
                    .tau
                    .iter()
                    .map(|&t| quantise(t, base, step))
                    .collect();
                brick.scales = [base, step, 0.0, 0.0];
            }
            BrickForm::Constant => brick.scales = [*samples.tau.first()?, 0.0, 0.0, 0.0],
        }
        Some(brick)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `round_clamped` is `f32::round` then `clamp` for the packers' bounds: over a
    /// spread of every f32 bit pattern (both signs, subnormals, infinities, NaN) and the
    /// halves where rounding turns.
    #[test]
    fn round_clamped_is_round_then_clamp() {
        let halves = [
            0.5,
            1.5,
            2.5,
            0.499_999_97,
            32_766.5,
            32_767.5,
            65_534.5,
            65_535.5,
            8_388_607.5,
        ];
        let spread = (0..u32::MAX / 61).map(|k| f32::from_bits(k * 61));
        let values = halves.iter().flat_map(|&h: &f32| [h, -h]).chain(spread);
        for x in values {
            for (lo, hi) in [
                (-(i16::MAX as f32), i16::MAX as f32),
                (0.0, u16::MAX as f32),
            ] {
                let want = x.round().clamp(lo, hi) as i32;
                assert_eq!(round_clamped(x, lo, hi), want, "{x:e} in [{lo}, {hi}]");
            }
        }
    }
}
