//! Procedural density: improved Perlin noise, fBm, and a smooth spherical falloff.
//!
//! [`NoiseCloud`] is the "noise ball" of the heterogeneous-media chapter of
//! Scratchapixel's volume rendering lesson:
//!
//! ```text
//! q        = (p − centre) · frequency                       (object space, world units)
//! fbm(q)   = Σ_{i<octaves} gainⁱ · noise(q · lacunarityⁱ)
//! d        = |p − centre| / radius
//! falloff  = 1 − smoothstep(falloff_start, 1, d)            (0 for d ≥ 1)
//! density  = scale · max(0, fbm(q) + bias) · falloff
//! ```
//!
//! `noise` is Ken Perlin's *improved* noise (SIGGRAPH 2002, reference Java
//! implementation), with either Perlin's own permutation table or a seeded shuffle of
//! 0..=255 ([`PermutationTable`]).
//!
//! Like the analytic shapes, the cloud sits on a virtual voxel grid
//! (`IndexToWorld::uniform(voxel_size, IVec3::ZERO)`); [`Field::value_at_index`] is the
//! procedural value at the exact point (no interpolation) and [`Field::cell_at`] gives
//! 8³ cells with a conservative range derived from the fBm's amplitude bound
//! ([`NOISE_BOUND`]) and the falloff's extremes over the cell.

use super::random::SplitMix64;
use super::shapes::{index_box_outward, range_over_box, virtual_cell};
use super::{Cell, Field, IndexBox, IndexToWorld, ValueRange};
use glam::{DVec3, IVec3};
use serde::{Deserialize, Serialize};

/// A bound on `|noise(p)|` for improved Perlin noise in 3-D, used for the cells'
/// conservative ranges.
///
/// Justification: inside a lattice cell, noise is `Σ_c w_c(p) · (g_c · (p − c))` over the
/// 8 corners `c`, with fade weights `w_c ≥ 0`, `Σ w_c = 1`, and gradients `g_c` of the
/// form `(±1, ±1, 0)` up to permutation. So `|g_c · (p − c)|` is at most the sum of the
/// two largest `|p − c|` components, and
/// `|noise(p)| ≤ B(p) = Σ_c w_c(p) · (sum of the two largest |p − c| components)`,
/// whatever the permutation table. Maximising `B` over the unit cube numerically gives
/// `max B ≈ 1.036354` (at about `(0.5, 0.4815, 0.3553)` and its symmetric images; the
/// test `noise_bound_majorant_is_below_bound` re-derives it), and the bound is attained
/// for a suitable choice of gradients. 1.04 leaves margin for the search resolution and
/// floating-point rounding.
pub const NOISE_BOUND: f64 = 1.04;

/// Ken Perlin's reference permutation of 0..=255 (improved noise, 2002).
const PERLIN_PERMUTATION: [u8; 256] = [
    151, 160, 137, 91, 90, 15, 131, 13, 201, 95, 96, 53, 194, 233, 7, 225, 140, 36, 103, 30, 69,
    142, 8, 99, 37, 240, 21, 10, 23, 190, 6, 148, 247, 120, 234, 75, 0, 26, 197, 62, 94, 252, 219,
    203, 117, 35, 11, 32, 57, 177, 33, 88, 237, 149, 56, 87, 174, 20, 125, 136, 171, 168, 68, 175,
    74, 165, 71, 134, 139, 48, 27, 166, 77, 146, 158, 231, 83, 111, 229, 122, 60, 211, 133, 230,
    220, 105, 92, 41, 55, 46, 245, 40, 244, 102, 143, 54, 65, 25, 63, 161, 1, 216, 80, 73, 209, 76,
    132, 187, 208, 89, 18, 169, 200, 196, 135, 130, 116, 188, 159, 86, 164, 100, 109, 198, 173,
    186, 3, 64, 52, 217, 226, 250, 124, 123, 5, 202, 38, 147, 118, 126, 255, 82, 85, 212, 207, 206,
    59, 227, 47, 16, 58, 17, 182, 189, 28, 42, 223, 183, 170, 213, 119, 248, 152, 2, 44, 154, 163,
    70, 221, 153, 101, 155, 167, 43, 172, 9, 129, 22, 39, 253, 19, 98, 108, 110, 79, 113, 224, 232,
    178, 185, 112, 104, 218, 246, 97, 228, 251, 34, 242, 193, 238, 210, 144, 12, 191, 179, 162,
    241, 81, 51, 145, 235, 249, 14, 239, 107, 49, 192, 214, 31, 181, 199, 106, 157, 184, 84, 204,
    176, 115, 121, 50, 45, 127, 4, 150, 254, 138, 236, 205, 93, 222, 114, 67, 29, 24, 72, 243, 141,
    128, 195, 78, 66, 215, 61, 156, 180,
];

/// The hash of improved noise: a permutation of 0..=255, stored twice so that
/// `perm[perm[x] + y]` needs no wrap-around.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PermutationTable {
    perm: [u8; 512],
}

impl PermutationTable {
    fn from_256(p: &[u8; 256]) -> Self {
        let mut perm = [0u8; 512];
        perm[..256].copy_from_slice(p);
        perm[256..].copy_from_slice(p);
        PermutationTable { perm }
    }

    /// Ken Perlin's reference table, so that [`PermutationTable::noise`] reproduces his
    /// Java implementation (e.g. `noise(3.14, 42, 7) = 0.13691995878400012`).
    pub fn perlin() -> Self {
        Self::from_256(&PERLIN_PERMUTATION)
    }

    /// A Fisher–Yates shuffle of 0..=255 driven by SplitMix64 seeded with `seed`
    /// (index `j = next_u64() mod (i + 1)`; the modulo bias, < 2⁻⁵⁶, is irrelevant).
    /// Deterministic across platforms.
    pub fn seeded(seed: u64) -> Self {
        let mut p = [0u8; 256];
        for (i, v) in p.iter_mut().enumerate() {
            *v = i as u8;
        }
        let mut rng = SplitMix64(seed);
        for i in (1..256usize).rev() {
            let j = (rng.next_u64() % (i as u64 + 1)) as usize;
            p.swap(i, j);
        }
        Self::from_256(&p)
    }

    /// The 256-entry permutation.
    pub fn permutation(&self) -> &[u8] {
        &self.perm[..256]
    }

    /// Improved Perlin noise at `p`, in `[−NOISE_BOUND, NOISE_BOUND]` (in practice
    /// about ±1). Exactly 0 at integer lattice points; C² continuous. Non-finite input
    /// gives 0.
    pub fn noise(&self, p: DVec3) -> f64 {
        if !p.is_finite() {
            return 0.0;
        }
        let (fx, fy, fz) = (p.x.floor(), p.y.floor(), p.z.floor());
        // `as i64` saturates for huge coordinates (no UB, no panic); & 255 wraps like the
        // reference's `(int)floor(x) & 255`.
        let xi = (fx as i64 & 255) as usize;
        let yi = (fy as i64 & 255) as usize;
        let zi = (fz as i64 & 255) as usize;
        let (x, y, z) = (p.x - fx, p.y - fy, p.z - fz);
        let (u, v, w) = (fade(x), fade(y), fade(z));
        let h = &self.perm;
        let a = h[xi] as usize + yi;
        let aa = h[a] as usize + zi;
        let ab = h[a + 1] as usize + zi;
        let b = h[xi + 1] as usize + yi;
        let ba = h[b] as usize + zi;
        let bb = h[b + 1] as usize + zi;
        lerp(
            w,
            lerp(
                v,
                lerp(u, grad(h[aa], x, y, z), grad(h[ba], x - 1.0, y, z)),
                lerp(
                    u,
                    grad(h[ab], x, y - 1.0, z),
                    grad(h[bb], x - 1.0, y - 1.0, z),
                ),
            ),
            lerp(
                v,
                lerp(
                    u,
                    grad(h[aa + 1], x, y, z - 1.0),
                    grad(h[ba + 1], x - 1.0, y, z - 1.0),
                ),
                lerp(
                    u,
                    grad(h[ab + 1], x, y - 1.0, z - 1.0),
                    grad(h[bb + 1], x - 1.0, y - 1.0, z - 1.0),
                ),
            ),
        )
    }
}

/// Perlin's quintic fade `6t⁵ − 15t⁴ + 10t³`.
#[inline]
fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

#[inline]
fn lerp(t: f64, a: f64, b: f64) -> f64 {
    a + t * (b - a)
}

/// Dot product of `(x, y, z)` with one of the 12 edge gradients `(±1, ±1, 0)` and
/// permutations (16 cases, 4 repeated), selected by the low 4 bits of `hash`.
#[inline]
fn grad(hash: u8, x: f64, y: f64, z: f64) -> f64 {
    let h = hash & 15;
    let u = if h < 8 { x } else { y };
    let v = if h < 4 {
        y
    } else if h == 12 || h == 14 {
        x
    } else {
        z
    };
    (if h & 1 == 0 { u } else { -u }) + (if h & 2 == 0 { v } else { -v })
}

/// Parameters of a [`NoiseCloud`]. All lengths in world units.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct NoiseCloudParams {
    /// Centre of the ball.
    pub center: [f64; 3],
    /// Radius of the ball; the density is 0 outside.
    pub radius: f64,
    /// Noise frequency of the first octave, in lattice cells per world unit.
    pub frequency: f64,
    /// Number of fBm octaves (0 gives `fbm = 0`).
    pub octaves: u32,
    /// Frequency multiplier between octaves.
    pub lacunarity: f64,
    /// Amplitude multiplier between octaves (`lacunarity^(−H)` in the reference text).
    pub gain: f64,
    /// Added to the fBm before clipping at 0 (positive: denser, fuller cloud).
    pub bias: f64,
    /// Overall density multiplier.
    pub scale: f64,
    /// Fraction of the radius where the smoothstep falloff starts (0.8 in the reference
    /// text); clamped to `[0, 1]`, and `1` is a hard edge.
    pub falloff_start: f64,
    /// `None`: Ken Perlin's reference permutation; `Some(s)`: [`PermutationTable::seeded`].
    pub seed: Option<u64>,
    /// Voxel size of the virtual grid the traversal steps on.
    pub voxel_size: f64,
}

impl Default for NoiseCloudParams {
    fn default() -> Self {
        NoiseCloudParams {
            center: [0.0; 3],
            radius: 1.0,
            frequency: 2.0,
            octaves: 5,
            lacunarity: 2.0,
            gain: 0.5,
            bias: 0.0,
            scale: 1.0,
            falloff_start: 0.8,
            seed: None,
            voxel_size: 1.0 / 64.0,
        }
    }
}

/// A procedural noise ball (see the module docs for the density formula).
#[derive(Clone, Debug)]
pub struct NoiseCloud {
    params: NoiseCloudParams,
    perm: PermutationTable,
    transform: IndexToWorld,
    center: DVec3,
    /// Centre and radius in local index space.
    index_center: DVec3,
    index_radius: f64,
    falloff_start: f64,
    /// `NOISE_BOUND · Σ_{i<octaves} |gain|ⁱ`: `|fbm| ≤ fbm_bound` everywhere.
    fbm_bound: f64,
}

impl NoiseCloud {
    /// Builds the cloud. `None` if a parameter is non-finite, `radius ≤ 0`,
    /// `voxel_size ≤ 0`, or `frequency`/`lacunarity` is negative.
    pub fn new(params: NoiseCloudParams) -> Option<Self> {
        let p = &params;
        let center = DVec3::from_array(p.center);
        let finite = center.is_finite()
            && [
                p.radius,
                p.frequency,
                p.lacunarity,
                p.gain,
                p.bias,
                p.scale,
                p.falloff_start,
                p.voxel_size,
            ]
            .iter()
            .all(|v| v.is_finite());
        if !finite
            || p.radius <= 0.0
            || p.voxel_size <= 0.0
            || p.frequency < 0.0
            || p.lacunarity < 0.0
        {
            return None;
        }
        let transform = IndexToWorld::new(
            glam::DMat4::from_scale(DVec3::splat(p.voxel_size)),
            IVec3::ZERO,
        )?;
        let index_center = transform.world_to_index(center);
        let index_radius = p.radius / p.voxel_size;
        let mut amp_sum = 0.0;
        let mut amp = 1.0;
        for _ in 0..p.octaves {
            amp_sum += amp;
            amp *= p.gain.abs();
        }
        let fbm_bound = NOISE_BOUND * amp_sum;
        if !(index_center.is_finite() && index_radius.is_finite() && fbm_bound.is_finite()) {
            return None;
        }
        let perm = match p.seed {
            Some(s) => PermutationTable::seeded(s),
            None => PermutationTable::perlin(),
        };
        let falloff_start = p.falloff_start.clamp(0.0, 1.0);
        Some(NoiseCloud {
            perm,
            transform,
            center,
            index_center,
            index_radius,
            falloff_start,
            fbm_bound,
            params,
        })
    }

    /// The parameters it was built from.
    pub fn params(&self) -> &NoiseCloudParams {
        &self.params
    }

    /// The permutation table in use.
    pub fn permutation_table(&self) -> &PermutationTable {
        &self.perm
    }

    /// `NOISE_BOUND · Σ |gain|ⁱ`, the bound on `|fbm|` the cell ranges use.
    pub fn fbm_bound(&self) -> f64 {
        self.fbm_bound
    }

    /// The fBm at a world point (object-space, scaled by `frequency`), without bias,
    /// clipping or falloff.
    pub fn fbm_at_world(&self, p: DVec3) -> f64 {
        let mut q = (p - self.center) * self.params.frequency;
        let mut amp = 1.0;
        let mut sum = 0.0;
        for _ in 0..self.params.octaves {
            sum += amp * self.perm.noise(q);
            q *= self.params.lacunarity;
            amp *= self.params.gain;
        }
        sum
    }

    /// The falloff `1 − smoothstep(s, 1, d)` for a normalised distance `d`, `s` =
    /// `falloff_start`: 1 for `d ≤ s`, 0 for `d ≥ 1` (and NaN), a hard step at 1 when
    /// `s = 1`.
    ///
    /// Evaluated in the mirrored form `u²(3 − 2u)`, `u = min(1, (1 − d)/(1 − s))` (as
    /// `1 − smoothstep(t) = smoothstep(1 − t)`): it has no `1 − (≈1)` cancellation, is
    /// exactly 0 only for `d ≥ 1`, and is non-increasing in `d` up to relative rounding,
    /// which the cell ranges' slack absorbs.
    #[inline]
    fn falloff(&self, d: f64) -> f64 {
        if d.is_nan() || d >= 1.0 {
            return 0.0;
        }
        let width = 1.0 - self.falloff_start;
        if width <= 0.0 {
            return 1.0;
        }
        let u = ((1.0 - d) / width).min(1.0);
        u * u * (3.0 - 2.0 * u)
    }

    /// Normalised distance to the centre of a local-index point (computed in index
    /// space; the same operations as the cell bounds, so they stay consistent).
    #[inline]
    fn normalized_distance(&self, p: DVec3) -> f64 {
        (p - self.index_center).length() / self.index_radius
    }

    /// Density at a local index point given in f64.
    pub fn density_at_index_f64(&self, p: DVec3) -> f64 {
        let w = self.falloff(self.normalized_distance(p));
        if w <= 0.0 || w.is_nan() {
            return 0.0;
        }
        let f = self.fbm_at_world(self.transform.index_to_world(p));
        self.params.scale * (f + self.params.bias).max(0.0) * w
    }

    /// Conservative range of the density over the closed local-index box `[lo, hi]`.
    fn range_of_box(&self, lo: DVec3, hi: DVec3) -> ValueRange {
        let c = self.index_center;
        let near = c.max(lo).min(hi);
        let d_min = (near - c).length() / self.index_radius;
        let w_max = self.falloff(d_min);
        if w_max <= 0.0 {
            return ValueRange::ZERO;
        }
        let far = (c - lo).abs().max((hi - c).abs());
        let w_min = self.falloff(far.length() / self.index_radius);
        // max(0, fbm + bias) ∈ [max(0, bias − F), max(0, bias + F)].
        let a_lo = (self.params.bias - self.fbm_bound).max(0.0) * w_min;
        let a_hi = (self.params.bias + self.fbm_bound).max(0.0) * w_max;
        let s = self.params.scale;
        let (lo_v, hi_v) = if s >= 0.0 {
            (s * a_lo, s * a_hi)
        } else {
            (s * a_hi, s * a_lo)
        };
        // Widen by a relative 1e-9 and round outward to f32 so that rounding in the
        // point evaluation (and its conversion to f32) can never escape the range.
        const SLACK: f64 = 1e-9;
        let widen_down = |v: f64| {
            if v > 0.0 {
                v * (1.0 - SLACK)
            } else {
                v * (1.0 + SLACK)
            }
        };
        let widen_up = |v: f64| {
            if v > 0.0 {
                v * (1.0 + SLACK)
            } else {
                v * (1.0 - SLACK)
            }
        };
        let b = index_box_outward(DVec3::splat(widen_down(lo_v)), DVec3::splat(widen_up(hi_v)));
        ValueRange {
            min: b.min.x,
            max: b.max.x,
        }
    }
}

impl Field for NoiseCloud {
    /// The procedural density at the exact point (no interpolation).
    fn value_at_index(&self, p: DVec3) -> f32 {
        self.density_at_index_f64(p) as f32
    }

    fn transform(&self) -> &IndexToWorld {
        &self.transform
    }

    fn active_bounds(&self) -> IndexBox {
        let r = DVec3::splat(self.index_radius);
        index_box_outward(self.index_center - r, self.index_center + r)
    }

    fn cell_at(&self, ijk: IVec3) -> Cell {
        virtual_cell(ijk, |lo, hi| self.range_of_box(lo, hi))
    }

    fn range_over(&self, b: &IndexBox) -> ValueRange {
        range_over_box(b, |lo, hi| self.range_of_box(lo, hi))
    }
}

#[cfg(test)]
mod tests;
