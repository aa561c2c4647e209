//! A dense copy of a small single-channel grid's voxels, for the lookups along a ray that
//! `--max-error`'s sampled segment means make on a coarse density level
//! ([`VoxelGrid::sample_along`]): one array read per corner instead of a tree descent,
//! and none of the up to eight descents of a stencil that straddles leaves (a third of
//! the stencils on a level whose leaves span 8 of its voxels).
//!
//! The copy holds the same values as the tree, so a lookup through it returns the same
//! number to the bit; it is made only where the grid's background and tiles are zero
//! and its leaves' box holds at most [`DENSE_MAX_VOXELS`] voxels.

use super::grid::{DenseVoxels, Stencil, VoxelGrid};
use glam::{DVec3, IVec3};

/// The largest dense copy made, in voxels (64 MiB of f32).
pub const DENSE_MAX_VOXELS: usize = 1 << 24;

impl DenseVoxels {
    /// The copy of `leaves` (global origin, 512 values each), or `None` past the limit.
    pub(super) fn of<'a>(leaves: impl Iterator<Item = (IVec3, &'a [f32])> + Clone) -> Option<Self> {
        let (mut lo, mut hi) = (IVec3::MAX, IVec3::MIN);
        for (o, _) in leaves.clone() {
            lo = lo.min(o);
            hi = hi.max(o + 8);
        }
        if lo.x > hi.x {
            return None;
        }
        let base = lo - 1;
        let dims = hi - lo + 2;
        let n = i64::from(dims.x) * i64::from(dims.y) * i64::from(dims.z);
        if !(0..=DENSE_MAX_VOXELS as i64).contains(&n) {
            return None;
        }
        let mut values = vec![0f32; n as usize];
        for (o, v) in leaves {
            for (i, &x) in v.iter().enumerate() {
                let l = IVec3::new((i >> 6) as i32, ((i >> 3) & 7) as i32, (i & 7) as i32);
                let g = o + l - base;
                values[((g.x * dims.y + g.y) * dims.z + g.z) as usize] = x;
            }
        }
        Some(DenseVoxels { base, dims, values })
    }

    pub(super) fn memory_bytes(&self) -> usize {
        self.values.len() * 4
    }

    /// The trilinear stencil of voxel `g` (global index) at fraction `t`: the corners the
    /// tree would give (zero outside the leaves).
    #[inline]
    pub(super) fn stencil(&self, g: IVec3, t: DVec3) -> Stencil {
        let d = g - self.base;
        // Along an axis outside [0, dims − 2] both corners lie outside the leaves.
        let last = self.dims - 2;
        if d.x < 0 || d.y < 0 || d.z < 0 || d.x > last.x || d.y > last.y || d.z > last.z {
            return Stencil::Constant(0.0);
        }
        let (sy, sx) = (self.dims.z as usize, (self.dims.y * self.dims.z) as usize);
        let i = d.x as usize * sx + d.y as usize * sy + d.z as usize;
        let v = &self.values;
        Stencil::Corners(
            [
                v[i],
                v[i + 1],
                v[i + sy],
                v[i + sy + 1],
                v[i + sx],
                v[i + sx + 1],
                v[i + sx + sy],
                v[i + sx + sy + 1],
            ],
            t,
        )
    }
}

impl VoxelGrid {
    /// Keeps a dense copy of the voxels for lookups along rays (see the module) where the
    /// grid is small enough and has one channel and a zero background.
    pub(super) fn with_dense_copy(mut self) -> Self {
        if self.channels == 1 && self.tile_values.iter().all(|&v| v == 0.0) {
            self.dense = self
                .leaves()
                .and_then(|l| DenseVoxels::of(l.iter().copied()))
                .map(Box::new);
        }
        self
    }
}

#[cfg(test)]
mod tests {
    use crate::field::{IndexRay, VoxelGrid};
    use glam::{DMat4, DVec3, IVec3};

    /// Along rays through, beside and far from a sparse grid's leaves (gaps between them,
    /// negative indices, stencils straddling leaves), the dense copy gives the tree's
    /// values to the bit.
    #[test]
    fn lookups_through_the_copy_equal_the_trees() {
        let mut voxels = Vec::new();
        for x in -20i32..13 {
            for y in -5..11 {
                for z in 3i32..30 {
                    // Two blobs with a gap of absent leaves between them.
                    if (-4..2).contains(&z.rem_euclid(16)) {
                        continue;
                    }
                    let v = ((x * 7 + y * 13 + z * 3).rem_euclid(11)) as f32 * 0.1 + 0.05;
                    voxels.push((IVec3::new(x, y, z), v));
                }
            }
        }
        let m = DMat4::from_scale(DVec3::splat(0.1)) * DMat4::from_translation(DVec3::splat(0.3));
        let tree = VoxelGrid::from_voxels("density", voxels, m).unwrap();
        let dense = tree.clone().with_dense_copy();
        assert!(tree.dense.is_none() && dense.dense.is_some());
        let ts: Vec<f64> = (0..4000).map(|i| -1.0 + i as f64 * 1.3e-3).collect();
        let (mut a, mut b) = (vec![0f32; ts.len()], vec![0f32; ts.len()]);
        let mut nonzero = 0;
        for k in 0..40 {
            let k = f64::from(k);
            let o = DVec3::new(-2.5 + 0.11 * k, -0.9 + 0.05 * k, 0.1 + 0.07 * k);
            let d = DVec3::new(1.0, 0.3 - 0.01 * k, 0.5 + 0.02 * k).normalize();
            let ray = IndexRay::new(&tree, o, d);
            tree.sample_along(&ray, &ts, &mut a);
            dense.sample_along(&ray, &ts, &mut b);
            for (x, y) in a.iter().zip(&b) {
                assert_eq!(x.to_bits(), y.to_bits());
            }
            nonzero += a.iter().filter(|v| **v != 0.0).count();
        }
        assert!(nonzero > 10_000, "{nonzero}");
    }

    #[test]
    fn a_grid_past_the_limit_keeps_no_copy() {
        let far = 1 << 12;
        let voxels = [(IVec3::ZERO, 1.0), (IVec3::new(far, far, 0), 1.0)];
        let g = VoxelGrid::from_voxels("d", voxels, DMat4::IDENTITY).unwrap();
        assert!(g.with_dense_copy().dense.is_none());
    }
}
