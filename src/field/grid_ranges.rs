//! Value ranges of a [`VoxelGrid`]: of a node at each level, of a cell with its
//! trilinear stencil, and over a box (from the tree's cells, or exactly from the voxels):
//! what empty-space skipping, majorants and the shadow bake's bounds read.

use super::grid::{CHILD, LOWER_SLOTS, UPPER_SLOTS, VoxelGrid, lower_offset, upper_offset};
use super::{Field, IndexBox, ValueRange};
use glam::IVec3;

impl VoxelGrid {
    /// Range of channel-combined values of the node at granularity `size` (8, 128,
    /// 4096) containing the global coordinate `g`.
    pub(super) fn own_range_at(&self, g: IVec3, size: i32) -> ValueRange {
        let tile = |t: u32| self.tile_range(t);
        let e = self.root.get(g >> 12);
        if e & CHILD == 0 {
            return tile(e);
        }
        let u = (e & !CHILD) as usize;
        if size >= 4096 {
            return self.upper_range[u];
        }
        let e = self.upper_slots[u * UPPER_SLOTS + upper_offset(g)];
        if e & CHILD == 0 {
            return tile(e);
        }
        let l = (e & !CHILD) as usize;
        if size >= 128 {
            return self.lower_range[l];
        }
        let e = self.lower_slots[l * LOWER_SLOTS + lower_offset(g)];
        if e & CHILD == 0 {
            tile(e)
        } else {
            self.leaf_range[(e & !CHILD) as usize]
        }
    }

    pub(super) fn tile_range(&self, t: u32) -> ValueRange {
        let ch = self.channels;
        let mut r = ValueRange::EMPTY;
        for v in &self.tile_values[t as usize * ch..(t as usize + 1) * ch] {
            r.include(*v);
        }
        r
    }

    /// Own range of a cell unioned with its +x/+y/+z neighbours at the same level: the
    /// range of the trilinear reconstruction over the cell.
    pub(super) fn stencil_range_pub(
        &self,
        own: ValueRange,
        origin: IVec3,
        size: i32,
    ) -> ValueRange {
        let mut r = own;
        for d in 1..8 {
            let n = origin + IVec3::new(d & 1, (d >> 1) & 1, (d >> 2) & 1) * size;
            r = r.union(&self.own_range_at(n, size));
        }
        r
    }

    /// [`VoxelGrid::stencil_range_pub`] of an 8³ tile cell of lower node `l` (global
    /// origin `origin`): a neighbour in the same lower node is read from its slot there,
    /// without descending the tree again from the root (the same range, fewer loads: an
    /// empty cell beside the cloud is what a camera ray crosses most).
    pub(super) fn stencil_range_in_lower(
        &self,
        own: ValueRange,
        origin: IVec3,
        l: usize,
    ) -> ValueRange {
        let mut r = own;
        let node = origin >> 7_i32;
        for d in 1..8 {
            let n = origin + IVec3::new(d & 1, (d >> 1) & 1, (d >> 2) & 1) * 8;
            let range = if n >> 7_i32 == node {
                let e = self.lower_slots[l * LOWER_SLOTS + lower_offset(n)];
                if e & CHILD == 0 {
                    self.tile_range(e)
                } else {
                    self.leaf_range[(e & !CHILD) as usize]
                }
            } else {
                self.own_range_at(n, 8)
            };
            r = r.union(&range);
        }
        r
    }

    /// The range of the voxel values at the box's integer points (exact; the tree's
    /// cells when there are more than 2¹⁵ of them): [`Field::tight_range_over`].
    pub(super) fn tight_range_of_box(&self, b: &IndexBox) -> ValueRange {
        let lo = b.min.floor().as_ivec3();
        let hi = b.max.ceil().as_ivec3();
        let points = (hi - lo + IVec3::ONE).max(IVec3::ZERO).as_i64vec3();
        if points.x * points.y * points.z > 1 << 15 {
            return self.range_of_box(b);
        }
        let o = self.transform.origin;
        let mut r = ValueRange::EMPTY;
        for x in lo.x..=hi.x {
            for y in lo.y..=hi.y {
                for z in lo.z..=hi.z {
                    r.include(self.voxel(IVec3::new(x, y, z) + o, 0));
                }
            }
        }
        r
    }

    /// The range over the box from the tree's cells: [`Field::range_over`].
    pub(super) fn range_of_box(&self, b: &IndexBox) -> ValueRange {
        let clipped = IndexBox::new(b.min.max(self.bounds.min), b.max.min(self.bounds.max));
        let outside = if b.min.cmplt(self.bounds.min).any() || b.max.cmpgt(self.bounds.max).any() {
            self.tile_range(0)
        } else {
            ValueRange::EMPTY
        };
        if clipped.is_empty() {
            return self.tile_range(0);
        }
        // Walk the cells covering the box, coarse where the tree is coarse.
        let lo = clipped.min.floor().as_ivec3();
        let hi = clipped.max.floor().as_ivec3();
        let mut r = outside;
        let mut x = lo.x;
        while x <= hi.x {
            let mut step_x = i32::MAX;
            let mut y = lo.y;
            while y <= hi.y {
                let mut step_y = i32::MAX;
                let mut z = lo.z;
                while z <= hi.z {
                    let c = self.cell_at(IVec3::new(x, y, z));
                    r = r.union(&c.range);
                    step_x = step_x.min(c.origin.x + c.size - x);
                    step_y = step_y.min(c.origin.y + c.size - y);
                    z = c.origin.z + c.size;
                }
                y += step_y.max(1);
            }
            x += step_x.max(1);
        }
        r
    }
}
