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

use super::shapes::{index_box_outward, virtual_cell};
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

/// SplitMix64 (Steele, Lea & Flood 2014): a tiny, well-mixed deterministic generator.
#[derive(Clone, Debug)]
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
}

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
        if b.is_empty() {
            return ValueRange::ZERO;
        }
        self.range_of_box(b.min.as_dvec3(), b.max.as_dvec3())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// SplitMix64-based uniform numbers for the property tests.
    struct Rng(SplitMix64);
    impl Rng {
        fn new(seed: u64) -> Self {
            Rng(SplitMix64(seed))
        }
        fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
            lo + (hi - lo) * ((self.0.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
        }
        fn vec(&mut self, lo: f64, hi: f64) -> DVec3 {
            DVec3::new(
                self.uniform(lo, hi),
                self.uniform(lo, hi),
                self.uniform(lo, hi),
            )
        }
    }

    fn cloud(seed: Option<u64>) -> NoiseCloud {
        NoiseCloud::new(NoiseCloudParams {
            center: [0.3, -0.2, 0.1],
            radius: 0.8,
            frequency: 3.0,
            octaves: 4,
            lacunarity: 2.1,
            gain: 0.6,
            bias: 0.35,
            scale: 4.0,
            falloff_start: 0.6,
            seed,
            voxel_size: 1.0 / 40.0,
        })
        .unwrap()
    }

    #[test]
    #[allow(clippy::approx_constant)] // 3.14 is the reference test point, not π
    fn reference_permutation_and_value() {
        let t = PermutationTable::perlin();
        let mut sorted = t.permutation().to_vec();
        sorted.sort_unstable();
        assert!(sorted.iter().enumerate().all(|(i, v)| i == *v as usize));
        // Ken Perlin's Java reference implementation.
        let v = t.noise(DVec3::new(3.14, 42.0, 7.0));
        assert!((v - 0.136_919_958_784_000_12).abs() < 1e-15, "{v}");
        let v = t.noise(DVec3::new(-4.2, 10.0, 6.0));
        assert!((v - 0.142_080_000_000_000_43).abs() < 1e-15, "{v}");
    }

    #[test]
    fn seeded_tables_are_deterministic_permutations() {
        let a = PermutationTable::seeded(42);
        assert_eq!(a, PermutationTable::seeded(42));
        assert_ne!(a, PermutationTable::seeded(43));
        assert_ne!(a, PermutationTable::perlin());
        let mut sorted = a.permutation().to_vec();
        sorted.sort_unstable();
        assert!(sorted.iter().enumerate().all(|(i, v)| i == *v as usize));
        // Same seed, same cloud, bit for bit; different seed, different values.
        let (c1, c2, c3) = (cloud(Some(7)), cloud(Some(7)), cloud(Some(8)));
        let mut rng = Rng::new(5);
        let mut differ = 0;
        for _ in 0..1000 {
            let p = rng.vec(-20.0, 30.0).as_vec3();
            assert_eq!(
                c1.value_at_index(p.as_dvec3()).to_bits(),
                c2.value_at_index(p.as_dvec3()).to_bits()
            );
            differ += (c1.value_at_index(p.as_dvec3()) != c3.value_at_index(p.as_dvec3())) as u32;
        }
        assert!(differ > 100, "{differ}");
    }

    #[test]
    fn noise_is_zero_on_the_lattice() {
        for t in [PermutationTable::perlin(), PermutationTable::seeded(3)] {
            for x in -5..5 {
                for y in [-300, -1, 0, 2, 255, 256, 1000] {
                    for z in [-7, 0, 9] {
                        assert_eq!(t.noise(DVec3::new(x as f64, y as f64, z as f64)), 0.0);
                    }
                }
            }
            assert_eq!(t.noise(DVec3::new(f64::NAN, 0.5, 0.5)), 0.0);
            assert!(t.noise(DVec3::new(1e300, -1e300, 0.5)).is_finite());
        }
    }

    #[test]
    fn noise_is_continuous_and_bounded() {
        let t = PermutationTable::perlin();
        let mut rng = Rng::new(11);
        let mut max_abs: f64 = 0.0;
        for _ in 0..200_000 {
            let p = rng.vec(-50.0, 50.0);
            let n = t.noise(p);
            max_abs = max_abs.max(n.abs());
            // Lipschitz: the gradient of improved noise is bounded by a small constant.
            let dp = rng.vec(-1e-6, 1e-6);
            let n2 = t.noise(p + dp);
            assert!(
                (n2 - n).abs() <= 10.0 * dp.length() + 1e-15,
                "{p}: {n} {n2}"
            );
        }
        // Crossing lattice planes is continuous too.
        for k in -3..3 {
            let x = k as f64;
            let a = t.noise(DVec3::new(x - 1e-12, 0.3, 0.7));
            let b = t.noise(DVec3::new(x + 1e-12, 0.3, 0.7));
            assert!((a - b).abs() < 1e-10, "{a} {b}");
        }
        assert!(max_abs < 1.0364 && max_abs > 0.5, "{max_abs}");
    }

    #[test]
    fn noise_bound_majorant_is_below_bound() {
        // B(p) = Σ_c w_c(p) · (sum of two largest |p − c| components) bounds |noise|
        // for any gradient table (see NOISE_BOUND). Maximise it on a grid of the
        // fundamental domain [0, ½]³, then refine by pattern search.
        let b = |p: DVec3| -> f64 {
            let mut s = 0.0;
            for c in 0..8 {
                let corner =
                    DVec3::new((c & 1) as f64, ((c >> 1) & 1) as f64, ((c >> 2) & 1) as f64);
                let wt = |t: f64, ci: f64| if ci == 1.0 { fade(t) } else { 1.0 - fade(t) };
                let w = wt(p.x, corner.x) * wt(p.y, corner.y) * wt(p.z, corner.z);
                let d = (p - corner).abs();
                let two_largest = d.x + d.y + d.z - d.min_element();
                s += w * two_largest;
            }
            s
        };
        let n = 50;
        let mut best = (0.0, DVec3::ZERO);
        for i in 0..=n {
            for j in 0..=n {
                for k in 0..=n {
                    let p = DVec3::new(i as f64, j as f64, k as f64) * (0.5 / n as f64);
                    let v = b(p);
                    if v > best.0 {
                        best = (v, p);
                    }
                }
            }
        }
        let mut h = 0.5 / n as f64;
        while h > 1e-9 {
            let mut improved = false;
            for d in 0..27 {
                let off = DVec3::new(
                    (d % 3) as f64 - 1.0,
                    ((d / 3) % 3) as f64 - 1.0,
                    (d / 9) as f64 - 1.0,
                );
                let p = (best.1 + off * h).clamp(DVec3::ZERO, DVec3::ONE);
                let v = b(p);
                if v > best.0 {
                    best = (v, p);
                    improved = true;
                }
            }
            if !improved {
                h *= 0.5;
            }
        }
        assert!(best.0 > 1.036 && best.0 < 1.0364, "{best:?}");
        assert!(best.0 < NOISE_BOUND);
        // Sanity: B really bounds the noise pointwise.
        let t = PermutationTable::perlin();
        let mut rng = Rng::new(2);
        for _ in 0..10_000 {
            let p = rng.vec(-9.0, 9.0);
            let f = p - p.floor();
            assert!(t.noise(p).abs() <= b(f) + 1e-12);
        }
    }

    #[test]
    fn zero_outside_the_sphere() {
        let c = cloud(None);
        let center = DVec3::new(0.3, -0.2, 0.1);
        let mut rng = Rng::new(3);
        let mut nonzero_inside = 0;
        for _ in 0..20_000 {
            let p = center + rng.vec(-1.2, 1.2);
            let v = c.value_at_world(p);
            assert!(v >= 0.0 && v.is_finite());
            if (p - center).length() >= 0.8 + 1e-6 {
                assert_eq!(v, 0.0, "{p}");
            } else if v > 0.0 {
                nonzero_inside += 1;
                let pi = c.transform().world_to_index(p);
                assert!(c.active_bounds().contains(pi.as_vec3()));
            }
        }
        assert!(nonzero_inside > 1000, "{nonzero_inside}");
        // The formula, at a world point well inside the falloff-free core.
        let p = center + DVec3::new(0.1, 0.05, -0.2);
        let want = 4.0 * (c.fbm_at_world(p) + 0.35).max(0.0);
        let pi = c.transform().world_to_index(p);
        assert!((c.density_at_index_f64(pi) - want).abs() < 1e-12);
    }

    #[test]
    fn cell_ranges_are_never_exceeded() {
        for (seed, bias, scale) in [
            (None, 0.35, 4.0),
            (Some(99), 2.5, 1.0),
            (Some(5), -0.2, -2.0),
        ] {
            let c = NoiseCloud::new(NoiseCloudParams {
                bias,
                scale,
                seed,
                ..cloud(None).params().clone()
            })
            .unwrap();
            let mut rng = Rng::new(1234);
            let mut max_seen: f32 = 0.0;
            let mut zero_cells = 0;
            for _ in 0..100_000 {
                // Index space: the ball is centred at (12, −8, 4), radius 32 voxels.
                let p = rng.vec(-45.0, 55.0).as_vec3();
                let v = c.value_at_index(p.as_dvec3());
                let cell = c.cell_at(p.floor().as_ivec3());
                let (o, s) = (cell.origin.as_vec3(), cell.size as f32);
                assert!(
                    p.cmpge(o).all() && p.cmple(o + s).all(),
                    "{p} not in {cell:?}"
                );
                assert!(
                    cell.range.min <= v && v <= cell.range.max,
                    "{p}: {v} outside {cell:?}"
                );
                if cell.size > 8 {
                    assert_eq!(cell.range, ValueRange::ZERO);
                }
                zero_cells += cell.range.is_zero() as u32;
                let r = c.range_over(&IndexBox::new(
                    p - Vec3::splat(0.5),
                    p + Vec3::new(3.0, 0.25, 9.0),
                ));
                assert!(r.min <= v && v <= r.max, "{p}: {v} outside {r:?}");
                max_seen = max_seen.max(v.abs());
            }
            assert!(
                zero_cells > 10_000 && max_seen > 0.0,
                "{zero_cells} {max_seen}"
            );
            // A large bias makes the cloud solid in its core: the minorant is positive there.
            if bias > c.fbm_bound() {
                let core = c.cell_at(IVec3::new(8, -8, 0));
                assert!(core.range.min > 0.0, "{core:?}");
            }
        }
    }

    #[test]
    fn cells_outside_the_ball_are_zero_and_coarse() {
        let c = cloud(None);
        let far = c.cell_at(IVec3::new(-5000, 0, 0));
        assert_eq!((far.size, far.range), (4096, ValueRange::ZERO));
        let near = c.cell_at(IVec3::new(12, -8, 4));
        assert_eq!(near.size, 8);
        assert!(near.range.max > 0.0 && near.range.min == 0.0);
        // Upper bound: scale · (bias + F) at full falloff.
        let want = 4.0 * (0.35 + c.fbm_bound());
        assert!((near.range.max as f64 - want).abs() < 1e-5 * want);
        let expected_f = NOISE_BOUND * (1.0 + 0.6 + 0.36 + 0.216);
        assert!((c.fbm_bound() - expected_f).abs() < 1e-12);
        assert_eq!(c.range_over(&IndexBox::EMPTY), ValueRange::ZERO);
    }

    #[test]
    fn invalid_parameters_are_rejected() {
        let base = NoiseCloudParams::default();
        assert!(NoiseCloud::new(base.clone()).is_some());
        assert!(
            NoiseCloud::new(NoiseCloudParams {
                radius: 0.0,
                ..base.clone()
            })
            .is_none()
        );
        assert!(
            NoiseCloud::new(NoiseCloudParams {
                voxel_size: -1.0,
                ..base.clone()
            })
            .is_none()
        );
        assert!(
            NoiseCloud::new(NoiseCloudParams {
                gain: f64::NAN,
                ..base.clone()
            })
            .is_none()
        );
        assert!(
            NoiseCloud::new(NoiseCloudParams {
                frequency: -1.0,
                ..base.clone()
            })
            .is_none()
        );
        // Hard edge and zero octaves are fine.
        let hard = NoiseCloud::new(NoiseCloudParams {
            falloff_start: 3.0,
            octaves: 0,
            bias: 0.5,
            ..base
        })
        .unwrap();
        assert_eq!(hard.value_at_world(DVec3::new(0.99, 0.0, 0.0)), 0.5);
        assert_eq!(hard.value_at_world(DVec3::new(1.01, 0.0, 0.0)), 0.0);
    }
}
