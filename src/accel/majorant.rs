//! A dense grid of majorants for free-flight sampling: the field's range over aligned
//! blocks of a few voxels, built once per render, crossed by a plain 3-D DDA.
//!
//! The tree's own cells ([`super::Spans`]) are 8³ leaves whose range takes in the whole
//! of their +x/+y/+z neighbour leaves (the trilinear stencil at leaf granularity), and
//! each step descends the tree; on the demo cloud the path tracer spent a quarter of its
//! time there and most of its density lookups on null collisions. A block here is the
//! closed cube `[o, o + s]³` of index points (`s` = 4 voxels unless the grid would be
//! too large) and its range is [`Field::tight_range_over`] — for a voxel grid the values
//! at exactly the points the trilinear reconstruction blends inside the cube — so the
//! majorant is tight to the block and a step costs an array read.

use super::hdda::clip_to_box;
use crate::field::{Field, IndexRay, ValueRange};
use glam::{DVec3, IVec3};

use super::blocks::nonzero_blocks;

/// Most blocks a grid may have (2²¹ ranges, 16 MiB; building reads up to 125 values
/// per non-empty 4-voxel block): coarser blocks beyond.
const MAX_BLOCKS: usize = 1 << 21;

/// The field's range over every block of its active bounds.
#[derive(Clone, Debug)]
pub struct MajorantGrid {
    /// Local index of block (0, 0, 0)'s lowest corner.
    origin: IVec3,
    /// Block edge in voxels.
    block: i32,
    dims: IVec3,
    ranges: Vec<ValueRange>,
    bounds: crate::field::IndexBox,
}

impl MajorantGrid {
    /// Blocks of `block` voxels (a power of two, doubled while the grid would hold more
    /// than [`MAX_BLOCKS`]). Blocks where the field is zero everywhere are zero.
    pub fn build(field: &dyn Field, block: i32) -> Self {
        let bounds = field.active_bounds();
        let mut s = block.max(1);
        if bounds.is_empty() {
            return MajorantGrid {
                origin: IVec3::ZERO,
                block: s,
                dims: IVec3::ZERO,
                ranges: Vec::new(),
                bounds,
            };
        }
        // Blocks covering the bounds and the stencil one voxel beyond.
        let span = |s: i32| {
            let lo = (bounds.min.floor().as_ivec3() - IVec3::ONE).div_euclid(IVec3::splat(s));
            let hi = (bounds.max.floor().as_ivec3() + IVec3::ONE).div_euclid(IVec3::splat(s));
            (lo, hi - lo + IVec3::ONE)
        };
        loop {
            let (_, dims) = span(s);
            let n = dims.as_i64vec3();
            if n.x * n.y * n.z <= MAX_BLOCKS as i64 || s >= 1 << 20 {
                break;
            }
            s *= 2;
        }
        let (lo, dims) = span(s);
        let origin = lo * s;
        let mut ranges = vec![ValueRange::ZERO; (dims.x * dims.y * dims.z).max(0) as usize];
        nonzero_blocks(field, s, usize::MAX, &mut |cube| {
            let b = cube.min.as_ivec3().div_euclid(IVec3::splat(s)) - lo;
            if b.cmpge(IVec3::ZERO).all() && b.cmplt(dims).all() {
                let mut r = field.tight_range_over(&cube);
                // The majorant bounds the sampled density, which is clamped at 0.
                r.min = r.min.max(0.0);
                r.max = r.max.max(0.0);
                ranges[((b.z * dims.y + b.y) * dims.x + b.x) as usize] = r;
            }
        });
        MajorantGrid {
            origin,
            block: s,
            dims,
            ranges,
            bounds,
        }
    }

    /// Block edge in voxels.
    pub fn block(&self) -> i32 {
        self.block
    }

    /// Local index of block (0, 0, 0)'s lowest corner, and the blocks along each axis.
    pub fn lattice(&self) -> (IVec3, IVec3) {
        (self.origin, self.dims)
    }

    /// Every block's majorant (its range's largest value), x fastest, then y, then z.
    pub fn maxima(&self) -> impl Iterator<Item = f32> + '_ {
        self.ranges.iter().map(|r| r.max)
    }

    /// Every block's range's least value, in [`MajorantGrid::maxima`]'s order.
    pub fn minima(&self) -> impl Iterator<Item = f32> + '_ {
        self.ranges.iter().map(|r| r.min)
    }

    /// The non-zero blocks `ray` crosses within `[t_min, t_max]` and the field's active
    /// bounds, front to back.
    pub fn spans(&self, ray: IndexRay, t_min: f64, t_max: f64) -> MajorantSpans<'_> {
        let empty = MajorantSpans {
            grid: self,
            cell: IVec3::ZERO,
            step: IVec3::ZERO,
            next: DVec3::ZERO,
            delta: DVec3::ZERO,
            t: 0.0,
            t_end: 0.0,
        };
        if self.ranges.is_empty() {
            return empty;
        }
        let Some((t0, t1)) = clip_to_box(&ray, &self.bounds, t_min, t_max) else {
            return empty;
        };
        let s = self.block as f64;
        let o = self.origin.as_dvec3();
        let p = ray.at(t0);
        let rel = (p - o) / s;
        let mut cell = IVec3::ZERO;
        let mut step = IVec3::ZERO;
        let mut next = DVec3::splat(f64::INFINITY);
        let mut delta = DVec3::splat(f64::INFINITY);
        for a in 0..3 {
            let d = ray.dir[a];
            // On a face going down, the block below: ⌈x⌉ − 1.
            let c = if d < 0.0 {
                rel[a].ceil() - 1.0
            } else {
                rel[a].floor()
            };
            cell[a] = (c.clamp(-1.0, self.dims[a] as f64) as i32).clamp(0, self.dims[a] - 1);
            if d != 0.0 {
                step[a] = if d > 0.0 { 1 } else { -1 };
                let face = o[a] + s * (cell[a] + (d > 0.0) as i32) as f64;
                next[a] = (face - ray.origin[a]) / d;
                delta[a] = s / d.abs();
            }
        }
        MajorantSpans {
            grid: self,
            cell,
            step,
            next,
            delta,
            t: t0,
            t_end: t1,
        }
    }
}

/// A stretch `[t0, t1]` of a ray inside one block, with the field's range there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MajorantSpan {
    pub t0: f64,
    pub t1: f64,
    pub range: ValueRange,
}

/// Iterator over the non-zero blocks of a ray (Amanatides–Woo over the block lattice).
pub struct MajorantSpans<'a> {
    grid: &'a MajorantGrid,
    cell: IVec3,
    step: IVec3,
    /// Where the ray leaves the current block across each axis.
    next: DVec3,
    delta: DVec3,
    t: f64,
    t_end: f64,
}

impl Iterator for MajorantSpans<'_> {
    type Item = MajorantSpan;

    #[inline]
    fn next(&mut self) -> Option<MajorantSpan> {
        let g = self.grid;
        while self.t < self.t_end {
            let c = self.cell;
            let r = g.ranges[((c.z * g.dims.y + c.y) * g.dims.x + c.x) as usize];
            let a = if self.next.x <= self.next.y && self.next.x <= self.next.z {
                0
            } else if self.next.y <= self.next.z {
                1
            } else {
                2
            };
            let t1 = self.next[a].min(self.t_end).max(self.t);
            let t0 = self.t;
            self.t = t1;
            self.cell[a] += self.step[a];
            self.next[a] += self.delta[a];
            if self.cell[a] < 0 || self.cell[a] >= g.dims[a] {
                // Left the grid.
                self.t_end = self.t;
            }
            if r.max > 0.0 && t1 > t0 {
                return Some(MajorantSpan { t0, t1, range: r });
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::grid_build::GridBuilder;
    use crate::field::shapes::ConstantSphere;
    use crate::field::{Field, VoxelGrid};
    use crate::vdb::TreeSink;
    use glam::DMat4;

    /// A grid of a few leaves with values that vary voxel to voxel, one far from others.
    fn grid() -> VoxelGrid {
        let mut b = GridBuilder::new();
        b.begin(1, &[0.0]).unwrap();
        let mut vals = vec![0f32; 512];
        for (i, v) in vals.iter_mut().enumerate() {
            *v = ((i * 37) % 11) as f32 * 0.1 * ((i % 3 != 0) as i32 as f32);
        }
        let mask = [u64::MAX; 8];
        for o in [IVec3::ZERO, IVec3::new(8, 0, 0), IVec3::new(40, 16, 8)] {
            b.leaf(IVec3::new(-24, 8, 16) + o, &vals, &mask).unwrap();
        }
        b.finish(
            "t",
            DMat4::from_scale(glam::DVec3::new(0.1, 0.2, 0.1)) * DMat4::from_rotation_y(0.4),
        )
        .unwrap()
    }

    fn rng(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Every point of random rays (axis-parallel ones included) where the field is not
    /// zero lies in a span whose range bounds it, the spans are in order, and they are
    /// tight: on the voxel grid the majorant is the largest value at the block's points,
    /// so somewhere on the block's corner points the field reaches it.
    fn check(field: &dyn Field, block: i32) {
        let g = MajorantGrid::build(field, block);
        let b = field.active_bounds();
        let mut s = 11u64;
        let mut dirs = vec![
            glam::DVec3::X,
            glam::DVec3::NEG_Y,
            glam::DVec3::new(0.0, -0.0, 1.0),
        ];
        for _ in 0..150 {
            dirs.push(
                glam::DVec3::new(rng(&mut s) - 0.5, rng(&mut s) - 0.5, rng(&mut s) - 0.5)
                    .normalize(),
            );
        }
        let mut checked = 0;
        for (k, d) in dirs.iter().enumerate() {
            let lo = b.min.as_dvec3();
            let ext = b.extent().as_dvec3();
            let mut oi = lo + ext * glam::DVec3::new(rng(&mut s), rng(&mut s), rng(&mut s));
            if k < 3 {
                oi = oi.round();
            }
            let o = field.transform().index_to_world(oi) - *d * 30.0 * (k % 2) as f64;
            let ray = IndexRay::new(field, o, *d);
            let spans: Vec<MajorantSpan> = g.spans(ray, 0.0, 1e3).collect();
            for w in spans.windows(2) {
                assert!(w[0].t1 <= w[1].t0 + 1e-9, "out of order");
            }
            for i in 0..6000 {
                let t = i as f64 * 0.01;
                let v = field.value_at_index(ray.at(t));
                if v > 0.0 {
                    checked += 1;
                    let sp = spans
                        .iter()
                        .find(|sp| sp.t0 - 1e-9 <= t && t <= sp.t1 + 1e-9)
                        .unwrap_or_else(|| panic!("ray {k}: {v} at {t} outside every span"));
                    assert!(v <= sp.range.max + 1e-6, "ray {k}: {v} > {:?}", sp.range);
                }
            }
        }
        assert!(checked > 2_000, "{checked}");
    }

    #[test]
    fn spans_bound_the_grid_and_the_sphere() {
        check(&grid(), 4);
        check(&grid(), 2);
        let sphere = ConstantSphere::new(glam::DVec3::new(0.3, -0.2, 0.1), 1.0, 2.0, 0.05).unwrap();
        check(&sphere, 4);
    }

    /// The voxel grid's block range is the range of its values at the block's points:
    /// tighter than the tree's leaf cells, which take in whole neighbour leaves.
    #[test]
    fn block_ranges_are_the_values_at_the_blocks_points() {
        let g = grid();
        let m = MajorantGrid::build(&g, 4);
        let mut tighter = 0;
        for (i, r) in m.ranges.iter().enumerate() {
            let i = i as i32;
            let b = IVec3::new(
                i % m.dims.x,
                (i / m.dims.x) % m.dims.y,
                i / (m.dims.x * m.dims.y),
            );
            let o = m.origin + b * m.block;
            let mut want = ValueRange::EMPTY;
            for x in 0..=m.block {
                for y in 0..=m.block {
                    for z in 0..=m.block {
                        let p = (o + IVec3::new(x, y, z)).as_dvec3();
                        want.include(g.value_at_index(p).max(0.0));
                    }
                }
            }
            if want.max > 0.0 {
                assert_eq!(r.max, want.max, "block {b}");
                let leaf = g.cell_at(o).range.max;
                tighter += (r.max < leaf) as i32;
            } else {
                assert_eq!(r.max, 0.0, "block {b}");
            }
        }
        assert!(tighter > 10, "{tighter}");
    }
}
