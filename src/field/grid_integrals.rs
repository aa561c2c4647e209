//! A [`VoxelGrid`] along rays: trilinear values at many points of a ray, the leaf of the
//! last remembered ([`VoxelGrid::sample_along`]); and exact integrals: the ray is cut at every voxel face
//! (Amanatides–Woo) and inside a voxel the trilinear reconstruction along the ray is a
//! cubic, which two-point Gauss–Legendre integrates exactly.
//!
//! Besides `∫ρ dt`, the deep shadow map needs how that integral changes when the ray is
//! moved sideways (see [`Sideways`]): the point at `t` moves by `a(t)` and `b(t)` per
//! unit of the two lateral coordinates, and by `c(t)` for both at once, all affine in
//! t. Then `∂/∂x ∫ρ = ∫∇ρ·a dt` and `∂²/∂x∂y ∫ρ = ∫(aᵀ(∇∇ρ)b + ∇ρ·c) dt`, cubic at most
//! in a voxel, so exact with the same two nodes. Inside a voxel the Hessian of a
//! trilinear function is its off-diagonal mixed terms; at a face across axis k the
//! gradient's k-th component jumps, and the jump adds `jump · a_k · b_k / |d_k|` (the ray
//! crosses the face at rate `|d_k|`).

use super::floor::floor_i32;
use super::grid::{LOOKUP_LIMIT, LeafCache, Stencil, VoxelGrid, trilinear, trilinear_f64};
use super::{GL2_HALF_OFFSET, IndexRay, Sideways, gauss_legendre_2};
use glam::{DVec3, IVec3};

/// The voxel cells a ray crosses over `[t0, t1]`, in order: each with the stretch of the
/// ray inside it and the axes whose faces the ray crossed to enter it.
struct CellWalk<'r> {
    ray: &'r IndexRay,
    cell: IVec3,
    step: IVec3,
    inv: DVec3,
    next: [f64; 3],
    entered: [bool; 3],
    t: f64,
    t1: f64,
    left: u64,
}

impl<'r> CellWalk<'r> {
    /// `None` when the stretch is too long to walk voxel by voxel (over 1e8 cells) or
    /// lies outside the lookup range.
    fn new(ray: &'r IndexRay, t0: f64, t1: f64) -> Option<Self> {
        let p = ray.at(t0);
        let d = ray.dir;
        let mut budget = 16.0;
        let mut start = [0i32; 3];
        if !(p.abs().max_element() < LOOKUP_LIMIT - 1e8) {
            return None;
        }
        for a in 0..3 {
            // Going down, a point on a face belongs to the cell below it: ⌈x⌉ − 1.
            start[a] = if d[a] < 0.0 {
                -floor_i32(-p[a]) - 1
            } else {
                floor_i32(p[a])
            };
            budget += (d[a] * (t1 - t0)).abs() + 1.0;
        }
        if !(budget < 1e8) {
            return None;
        }
        let mut walk = CellWalk {
            ray,
            cell: IVec3::from_array(start),
            step: IVec3::new(
                d.x.signum() as i32,
                d.y.signum() as i32,
                d.z.signum() as i32,
            ),
            inv: DVec3::ONE / d,
            next: [0.0; 3],
            entered: [false; 3],
            t: t0,
            t1,
            left: budget as u64,
        };
        walk.next = [0, 1, 2].map(|a| walk.face_t(a));
        Some(walk)
    }

    /// Where the ray leaves the current cell through its faces across axis `a`.
    fn face_t(&self, a: usize) -> f64 {
        let d = self.ray.dir[a];
        if d > 0.0 {
            (self.cell[a] as f64 + 1.0 - self.ray.origin[a]) * self.inv[a]
        } else if d < 0.0 {
            (self.cell[a] as f64 - self.ray.origin[a]) * self.inv[a]
        } else {
            f64::INFINITY
        }
    }
}

impl Iterator for CellWalk<'_> {
    /// The cell, the stretch `[ta, tb]` inside it, and the axes crossed to enter it.
    type Item = (IVec3, f64, f64, [bool; 3]);

    fn next(&mut self) -> Option<Self::Item> {
        while self.left > 0 && self.t < self.t1 {
            self.left -= 1;
            let tn = self.next[0]
                .min(self.next[1])
                .min(self.next[2])
                .min(self.t1);
            let (cell, t, entered) = (self.cell, self.t, self.entered);
            let mut stepped = [false; 3];
            if tn < self.t1 {
                for (a, s) in stepped.iter_mut().enumerate() {
                    if self.next[a] <= tn {
                        self.cell[a] += self.step[a];
                        self.next[a] = self.face_t(a);
                        *s = true;
                    }
                }
            }
            self.t = tn.max(t);
            if tn > t {
                self.entered = stepped;
                return Some((cell, t, tn, entered));
            }
            // A zero-length cell (the ray through an edge): the next one inherits both
            // crossings.
            self.entered = [0, 1, 2].map(|a| entered[a] || stepped[a]);
        }
        if self.t < self.t1 {
            let item = (self.cell, self.t, self.t1, self.entered);
            self.t = self.t1;
            return Some(item);
        }
        None
    }
}

/// The trilinear blend of corners `v` (`v[k]` is corner `(k>>2 & 1, k>>1 & 1, k & 1)`)
/// at `t` ∈ [0, 1]³ (local index units): its value, gradient and the Hessian's
/// off-diagonal terms `[∂xy, ∂xz, ∂yz]` (its diagonal is 0), from one set of lerps
/// along z.
#[inline]
fn trilinear_jet(v: &[f64; 8], t: DVec3) -> (f64, DVec3, [f64; 3]) {
    let lerp = |a: f64, b: f64, s: f64| a + (b - a) * s;
    // Along z at each (x, y) edge, index (x << 1) | y: the values and their z-slopes.
    let z = [
        lerp(v[0], v[1], t.z),
        lerp(v[2], v[3], t.z),
        lerp(v[4], v[5], t.z),
        lerp(v[6], v[7], t.z),
    ];
    let dz = [v[1] - v[0], v[3] - v[2], v[5] - v[4], v[7] - v[6]];
    let (y0, y1) = (lerp(z[0], z[1], t.y), lerp(z[2], z[3], t.y));
    let (dz0, dz1) = (lerp(dz[0], dz[1], t.y), lerp(dz[2], dz[3], t.y));
    let value = lerp(y0, y1, t.x);
    let gradient = DVec3::new(
        y1 - y0,
        lerp(z[1] - z[0], z[3] - z[2], t.x),
        lerp(dz0, dz1, t.x),
    );
    let mixed = [
        (z[3] - z[2]) - (z[1] - z[0]),
        dz1 - dz0,
        lerp(dz[1] - dz[0], dz[3] - dz[2], t.x),
    ];
    (value, gradient, mixed)
}

impl VoxelGrid {
    /// [`VoxelGrid::sample_channel`] of channel 0 at `ray.at(t)` for each `t` of `ts`,
    /// the leaf of the previous point remembered.
    pub(super) fn sample_along(&self, ray: &IndexRay, ts: &[f64], out: &mut [f32]) {
        let mut cache = LeafCache::new();
        for (&t, o) in ts.iter().zip(out.iter_mut()) {
            let p = ray.at(t);
            *o = if p.abs().max_element() < LOOKUP_LIMIT {
                let i = IVec3::new(floor_i32(p.x), floor_i32(p.y), floor_i32(p.z));
                let stencil = match &self.dense {
                    Some(d) => d.stencil(i + self.transform.origin, p - i.as_dvec3()),
                    None => self.stencil_in(i, p - i.as_dvec3(), 0, &mut cache),
                };
                match stencil {
                    Stencil::Constant(v) => v,
                    Stencil::Corners(v, t) => trilinear(&v, t.as_vec3()),
                }
            } else {
                self.tile_values[0]
            };
        }
    }

    /// `∫ρ dt` over `[t0, t1]` of `ray`, exactly (see the module).
    pub(super) fn exact_integral(&self, ray: &IndexRay, t0: f64, t1: f64) -> f64 {
        if !(t1 > t0) || !t0.is_finite() || !t1.is_finite() {
            return 0.0;
        }
        let Some(walk) = CellWalk::new(ray, t0, t1) else {
            return gauss_legendre_2(|t| self.sample_channel_f64(ray.at(t), 0), t0, t1);
        };
        let mut sum = [0.0];
        self.integrate_pieces(walk, ray, &[t1], &mut sum);
        sum[0]
    }

    /// `∫ρ dt` over each piece `[ends[i−1], ends[i]]` (`ends[−1] = t0`) into `out[i]`,
    /// exactly, in one walk: a voxel's corners are read once for every piece in it.
    pub(super) fn exact_piece_integrals(
        &self,
        ray: &IndexRay,
        t0: f64,
        ends: &[f64],
        out: &mut [f64],
    ) {
        let n = ends.len().min(out.len());
        let (ends, out) = (&ends[..n], &mut out[..n]);
        out.fill(0.0);
        let Some(&t1) = ends.last() else { return };
        let walk = if t0.is_finite() && t1.is_finite() && t1 > t0 {
            CellWalk::new(ray, t0, t1)
        } else {
            None
        };
        match walk {
            Some(walk) => self.integrate_pieces(walk, ray, ends, out),
            None => {
                // Too long to walk voxel by voxel: piece by piece.
                let mut a = t0;
                for (&b, o) in ends.iter().zip(out.iter_mut()) {
                    *o = self.exact_integral(ray, a, b);
                    a = b;
                }
            }
        }
    }

    /// Adds to `out[k]` the integral over the part of piece k (ending at `ends[k]`) in
    /// each cell of `walk`: two Gauss–Legendre nodes per cell and piece, the cell's
    /// eight corners read once.
    fn integrate_pieces(&self, walk: CellWalk, ray: &IndexRay, ends: &[f64], out: &mut [f64]) {
        let n = ends.len().min(out.len());
        let d = ray.dir;
        let mut cache = LeafCache::new();
        let mut k = 0;
        for (cell, a, b, _) in walk {
            while k < n && ends[k] <= a {
                k += 1;
            }
            if k == n {
                break;
            }
            let stencil = self.stencil_in(cell, DVec3::ZERO, 0, &mut cache);
            let mut lo = a;
            while lo < b && k < n {
                let hi = ends[k].min(b);
                out[k] += match &stencil {
                    Stencil::Constant(v) => *v as f64 * (hi - lo),
                    Stencil::Corners(v, _) => {
                        let t = ray.at(0.5 * (lo + hi)) - cell.as_dvec3();
                        let off = d * (GL2_HALF_OFFSET * (hi - lo));
                        0.5 * (hi - lo) * (trilinear_f64(v, t - off) + trilinear_f64(v, t + off))
                    }
                };
                if ends[k] <= b {
                    k += 1;
                }
                lo = hi;
            }
        }
    }

    /// Along `ray` from `t0` to each of `targets` (ascending): `[∫ρ, ∫∇ρ·a, ∫∇ρ·b,
    /// ∫(aᵀ(∇∇ρ)b + ∇ρ·c)]` dt, pushed to `out`. `false` (nothing pushed) when the
    /// stretch is too long to walk voxel by voxel.
    pub(super) fn slopes_along(
        &self,
        ray: &IndexRay,
        t0: f64,
        targets: &[f64],
        side: &Sideways,
        out: &mut Vec<[f64; 4]>,
    ) -> bool {
        let t_end = targets.last().copied().unwrap_or(t0).max(t0);
        if !(t0.is_finite() && t_end.is_finite()) {
            return false;
        }
        let Some(walk) = CellWalk::new(ray, t0, t_end) else {
            return false;
        };
        let d = ray.dir;
        let mut cache = LeafCache::new();
        let mut acc = [0.0f64; 4];
        let mut k = 0;
        while k < targets.len() && targets[k] <= t0 {
            out.push(acc);
            k += 1;
        }
        // The previous cell's corners, for the gradient's jump at a face.
        let mut prev: Option<(IVec3, [f64; 8])> = None;
        for (cell, ta, tb, entered) in walk {
            let mid = ray.at(0.5 * (ta + tb));
            let corners = match self.stencil_in(cell, mid - cell.as_dvec3(), 0, &mut cache) {
                Stencil::Constant(v) => [v; 8],
                Stencil::Corners(v, _) => v,
            };
            let wide = corners.map(f64::from);
            if entered.iter().any(|e| *e) {
                let pe = ray.at(ta);
                let (a, b) = (side.a.at(ta), side.b.at(ta));
                let g_new = trilinear_jet(&wide, pe - cell.as_dvec3()).1;
                let g_old =
                    prev.map_or(DVec3::ZERO, |(c, v)| trilinear_jet(&v, pe - c.as_dvec3()).1);
                for axis in 0..3 {
                    if entered[axis] && d[axis] != 0.0 {
                        acc[3] += (g_new[axis] - g_old[axis]) * a[axis] * b[axis] / d[axis].abs();
                    }
                }
            }
            // The cell's stretch, cut at the targets in it.
            let mut u = ta;
            loop {
                let w = if k < targets.len() && targets[k] <= tb {
                    targets[k]
                } else {
                    tb
                };
                if w > u {
                    let (tm, off) = (0.5 * (u + w), GL2_HALF_OFFSET * (w - u));
                    let half = 0.5 * (w - u);
                    for tn in [tm - off, tm + off] {
                        let t = ray.at(tn) - cell.as_dvec3();
                        let (f, g, [hxy, hxz, hyz]) = trilinear_jet(&wide, t);
                        let (a, b) = (side.a.at(tn), side.b.at(tn));
                        let mixed = hxy * (a.x * b.y + a.y * b.x)
                            + hxz * (a.x * b.z + a.z * b.x)
                            + hyz * (a.y * b.z + a.z * b.y);
                        acc[0] += half * f;
                        acc[1] += half * g.dot(a);
                        acc[2] += half * g.dot(b);
                        acc[3] += half * (mixed + g.dot(side.c.at(tn)));
                    }
                }
                u = w;
                if k < targets.len() && targets[k] <= tb {
                    out.push(acc);
                    k += 1;
                } else {
                    break;
                }
            }
            prev = Some((cell, wide));
        }
        while k < targets.len() {
            out.push(acc);
            k += 1;
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::random::SplitMix64;
    use crate::field::{Affine, Field};
    use glam::DMat4;

    /// A 12³ block of random values in [0, 1].
    fn random_grid() -> VoxelGrid {
        let mut rng = SplitMix64(3);
        let mut voxels = Vec::new();
        for z in 0..12 {
            for y in 0..12 {
                for x in 0..12 {
                    voxels.push((IVec3::new(x, y, z), rng.next_f64() as f32));
                }
            }
        }
        VoxelGrid::from_voxels("density", voxels, DMat4::IDENTITY).unwrap()
    }

    /// Values along a ray with the last leaf remembered are the values looked up one by
    /// one, to the bit: points within a leaf, across leaves and their +1 stencil layer,
    /// out of the grid, back into it, and beyond the lookup range.
    #[test]
    fn values_along_match_value_at_index() {
        let g = random_grid();
        let centre = DVec3::splat(6.0) - g.transform.origin.as_dvec3();
        let mut rng = SplitMix64(8);
        for _ in 0..200 {
            let dir = DVec3::new(
                rng.next_f64() - 0.5,
                rng.next_f64() - 0.5,
                rng.next_f64() - 0.5,
            )
            .normalize();
            let ray = IndexRay {
                origin: centre - dir * 12.0,
                dir,
            };
            let mut ts: Vec<f64> = (0..60)
                .map(|k| k as f64 * 0.4 + rng.next_f64() * 0.3)
                .collect();
            ts.push(1e12);
            let mut out = vec![f32::NAN; ts.len()];
            g.values_along(&ray, &ts, &mut out);
            for (&t, &v) in ts.iter().zip(&out) {
                let want = g.value_at_index(ray.at(t));
                assert_eq!(v.to_bits(), want.to_bits(), "t {t}: {v} against {want}");
            }
            assert!(out.iter().any(|&v| v > 0.0) && out.contains(&0.0));
        }
    }

    /// The jet's value is the blend's, and its gradient and mixed second derivatives
    /// are the blend's central differences (exact for a trilinear function, whose
    /// second differences along one axis vanish), at random corners and points.
    #[test]
    fn trilinear_jet_matches_differences_of_the_blend() {
        let mut rng = SplitMix64(5);
        let f = |v: &[f64; 8], t: DVec3| trilinear_f64(&v.map(|x| x as f32), t);
        for _ in 0..200 {
            let v: [f64; 8] = std::array::from_fn(|_| (rng.next_f64() * 4.0 - 2.0) as f32 as f64);
            let t = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64());
            let (value, g, [hxy, hxz, hyz]) = trilinear_jet(&v, t);
            assert!((value - f(&v, t)).abs() < 1e-12);
            let h = 1e-3;
            let e = [DVec3::X, DVec3::Y, DVec3::Z];
            for (axis, de) in e.iter().enumerate() {
                let d = (f(&v, t + *de * h) - f(&v, t - *de * h)) / (2.0 * h);
                assert!(
                    (g[axis] - d).abs() < 1e-9,
                    "axis {axis}: {} against {d}",
                    g[axis]
                );
            }
            let mixed = |a: DVec3, b: DVec3| {
                (f(&v, t + (a + b) * h) - f(&v, t + (a - b) * h) - f(&v, t + (b - a) * h)
                    + f(&v, t - (a + b) * h))
                    / (4.0 * h * h)
            };
            for (got, (a, b)) in [hxy, hxz, hyz].into_iter().zip([(0, 1), (0, 2), (1, 2)]) {
                let want = mixed(e[a], e[b]);
                assert!((got - want).abs() < 1e-6, "{a}{b}: {got} against {want}");
            }
        }
    }

    /// One walk for many pieces gives what a walk per piece gives: pieces inside one
    /// voxel, across several, ending exactly on voxel faces, of zero length, and the
    /// whole ray split into pieces sums to its integral.
    #[test]
    fn piece_integrals_match_an_integral_per_piece() {
        let g = random_grid();
        // Local index coordinates of the block's centre.
        let centre = DVec3::splat(6.0) - g.transform.origin.as_dvec3();
        let mut rng = SplitMix64(21);
        for n in 0..40 {
            let dir = DVec3::new(rng.next_f64() - 0.5, rng.next_f64() - 0.5, 0.3).normalize();
            // Every fourth ray runs along x through voxel faces exactly.
            let (origin, dir) = if n % 4 == 0 {
                (centre + DVec3::new(-7.0, -1.0, 0.0), DVec3::X)
            } else {
                (centre - dir * 7.0 + DVec3::splat(rng.next_f64()), dir)
            };
            let ray = IndexRay { origin, dir };
            let t0 = rng.next_f64();
            let mut ends = Vec::new();
            let mut t = t0;
            for k in 0..30 {
                t += match k % 5 {
                    0 => 0.0,
                    1 => 0.13 * rng.next_f64(),
                    _ => 2.0 * rng.next_f64(),
                };
                // Integer ends on the axis-aligned ray are voxel faces.
                ends.push(if n % 4 == 0 { t.round().max(t0) } else { t });
                t = *ends.last().unwrap();
            }
            let mut out = vec![f64::NAN; ends.len()];
            g.exact_piece_integrals(&ray, t0, &ends, &mut out);
            let mut a = t0;
            for (&b, &v) in ends.iter().zip(&out) {
                let want = g.exact_integral(&ray, a, b);
                assert!(
                    (v - want).abs() <= 1e-12 * (1.0 + want.abs()),
                    "[{a}, {b}]: {v} vs {want}"
                );
                a = b;
            }
            let whole = g.exact_integral(&ray, t0, t);
            let sum: f64 = out.iter().sum();
            assert!(
                whole > 1.0,
                "ray {n} crosses the block: {whole} over [{t0}, {t}]"
            );
            assert!((sum - whole).abs() <= 1e-12 * whole, "{sum} vs {whole}");
        }
    }

    /// The slopes and twist are the derivatives of the integral under moving the ray:
    /// they match central differences of `exact_integral` on rays offset by ±ε·a, ±ε·b.
    #[test]
    fn slopes_are_the_derivatives_of_the_integral() {
        let g = random_grid();
        let dir = DVec3::new(0.31, 0.83, 0.46).normalize();
        let a = dir.cross(DVec3::X).normalize() * 0.7;
        let b = dir.cross(a).normalize() * 1.3;
        let targets = [2.0, 5.5, 9.25];
        let mut rng = SplitMix64(9);
        for _ in 0..20 {
            let origin = DVec3::new(3.0, 0.5, 3.0)
                + DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 4.0;
            let ray = |o: DVec3| IndexRay { origin: o, dir };
            let mut out = Vec::new();
            let side = Sideways::parallel(a, b);
            assert!(g.slopes_along(&ray(origin), 0.0, &targets, &side, &mut out));
            let e = 1e-4;
            for (n, &t) in targets.iter().enumerate() {
                let tau = |o: DVec3| g.exact_integral(&ray(o), 0.0, t);
                let dx = (tau(origin + a * e) - tau(origin - a * e)) / (2.0 * e);
                let dy = (tau(origin + b * e) - tau(origin - b * e)) / (2.0 * e);
                let dxy = (tau(origin + (a + b) * e)
                    - tau(origin + (a - b) * e)
                    - tau(origin + (b - a) * e)
                    + tau(origin - (a + b) * e))
                    / (4.0 * e * e);
                let [v, vx, vy, vxy] = out[n];
                assert!((v - tau(origin)).abs() < 1e-12, "{v} vs {}", tau(origin));
                assert!((vx - dx).abs() < 1e-6, "∂x {vx} vs {dx}");
                assert!((vy - dy).abs() < 1e-6, "∂y {vy} vs {dy}");
                assert!(
                    (vxy - dxy).abs() < 1e-3 * (1.0 + dxy.abs()),
                    "∂xy {vxy} vs {dxy}"
                );
            }
        }
    }

    /// Rays fanning out from a point, `origin + t·D(x, y)` with `D = normalize(v0 + x·vx +
    /// y·vy)`: the slopes with `a = t·∂D/∂x`, `b = t·∂D/∂y`, `c = t·∂²D/∂x∂y` match
    /// differences of the exact integral over the fanned rays.
    #[test]
    fn slopes_of_a_fan_of_rays_are_its_derivatives() {
        let g = random_grid();
        let origin = DVec3::new(0.5, 0.7, 0.3);
        let (v0, vx, vy) = (
            DVec3::new(0.6, 0.5, 0.62),
            DVec3::new(0.05, -0.02, 0.01),
            DVec3::new(-0.01, 0.04, 0.03),
        );
        let dir = |x: f64, y: f64| (v0 + vx * x + vy * y).normalize();
        let tau = |x: f64, y: f64, t: f64| {
            g.exact_integral(
                &IndexRay {
                    origin,
                    dir: dir(x, y),
                },
                0.0,
                t,
            )
        };
        let (d, n) = (dir(0.0, 0.0), v0.length());
        let dx = (vx - d * d.dot(vx)) / n;
        let dy = (vy - d * d.dot(vy)) / n;
        let dxy = -(dy * d.dot(vx) + d * dy.dot(vx)) / n - dx * d.dot(vy) / n;
        let side = Sideways {
            a: Affine::new(DVec3::ZERO, dx),
            b: Affine::new(DVec3::ZERO, dy),
            c: Affine::new(DVec3::ZERO, dxy),
        };
        let targets = [4.0, 9.0, 14.0];
        let mut out = Vec::new();
        assert!(g.slopes_along(&IndexRay { origin, dir: d }, 0.0, &targets, &side, &mut out));
        let e = 1e-4;
        for (k, &t) in targets.iter().enumerate() {
            let fx = (tau(e, 0.0, t) - tau(-e, 0.0, t)) / (2.0 * e);
            let fy = (tau(0.0, e, t) - tau(0.0, -e, t)) / (2.0 * e);
            let fxy =
                (tau(e, e, t) - tau(e, -e, t) - tau(-e, e, t) + tau(-e, -e, t)) / (4.0 * e * e);
            let [v, vx_, vy_, vxy] = out[k];
            assert!((v - tau(0.0, 0.0, t)).abs() < 1e-12);
            assert!(
                (vx_ - fx).abs() < 1e-6 * (1.0 + fx.abs()),
                "∂x {vx_} vs {fx}"
            );
            assert!(
                (vy_ - fy).abs() < 1e-6 * (1.0 + fy.abs()),
                "∂y {vy_} vs {fy}"
            );
            assert!(
                (vxy - fxy).abs() < 1e-3 * (1.0 + fxy.abs()),
                "∂xy {vxy} vs {fxy}"
            );
        }
    }
}
