//! The bounds of where a field is non-zero, from its cell hierarchy: a dense cache whose
//! voxels are all active but mostly zero (an exported domain holding a small plume)
//! has active bounds many times the plume's; its zero cells say so without a voxel read.

use super::{Field, IndexBox};
use glam::IVec3;

/// Cells visited at most: past it the active bounds are returned as they are (a
/// field whose hierarchy is this fine over this large a box is framed whole).
const MAX_CELLS: usize = 4_000_000;

/// The local-index box of the cells over which `f` is not zero: within its active
/// bounds, cell by cell along x (a cell's size skips the rest of it), rows of leaf
/// height. Leaves' ranges include the stencil's +1 voxel layer, so the box holds every
/// point where the trilinear value is non-zero (to within the leaf before a non-zero
/// one); a tile counts by its own value.
pub fn nonzero_bounds(f: &dyn Field) -> IndexBox {
    let active = f.active_bounds();
    if active.is_empty() {
        return active;
    }
    let lo = active.min.floor().as_ivec3();
    let hi = active.max.ceil().as_ivec3();
    let (mut min, mut max) = (IVec3::MAX, IVec3::MIN);
    let mut visited = 0usize;
    let mut z = lo.z;
    while z <= hi.z {
        let mut z_step = i32::MAX;
        let mut y = lo.y;
        while y <= hi.y {
            let mut y_step = i32::MAX;
            let mut x = lo.x;
            while x <= hi.x {
                let c = f.cell_at(IVec3::new(x, y, z));
                visited += 1;
                if visited > MAX_CELLS {
                    return active;
                }
                let size = c.size.max(1);
                let end = c.origin + IVec3::splat(size);
                // A leaf counts when its range (with the stencil's layer) is not zero. A
                // coarser cell is a tile, constant inside: it counts when its own value
                // is not zero (its range also holds its neighbours', which count
                // themselves).
                let nonzero = if size <= 8 {
                    !c.range.is_zero()
                } else {
                    !c.range.is_zero() && f.value_at_index(c.origin.as_dvec3()) != 0.0
                };
                if nonzero {
                    min = min.min(c.origin);
                    max = max.max(end);
                }
                y_step = y_step.min(end.y - y);
                z_step = z_step.min(end.z - z);
                x = end.x.max(x + 1);
            }
            y += y_step.max(1);
        }
        z += z_step.max(1);
    }
    if min.cmpgt(max).any() {
        return IndexBox::EMPTY;
    }
    // Clip to the active bounds (a coarse cell can reach past them).
    IndexBox::new(min.as_vec3().max(active.min), max.as_vec3().min(active.max)).nonempty_or(active)
}

impl IndexBox {
    fn nonempty_or(self, other: IndexBox) -> IndexBox {
        if self.is_empty() { other } else { self }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::VoxelGrid;
    use glam::DMat4;

    #[test]
    fn a_small_plume_in_a_dense_zero_box_bounds_the_plume() {
        // 64×32×32 voxels all present (zeros), a plume at 40..44 × 10..13 × 20..22.
        let inside = |i: i32, j: i32, k: i32| {
            (40..=44).contains(&i) && (10..=13).contains(&j) && (20..=22).contains(&k)
        };
        let voxels = (0..64).flat_map(move |i| {
            (0..32).flat_map(move |j| {
                (0..32).map(move |k| (IVec3::new(i, j, k), if inside(i, j, k) { 1.0 } else { 0.0 }))
            })
        });
        let g = VoxelGrid::from_voxels("d", voxels, DMat4::IDENTITY).unwrap();
        assert_eq!(g.stats().active_voxels, 64 * 32 * 32);
        let origin = g.transform().origin.as_vec3();
        let b = nonzero_bounds(&g);
        let (bmin, bmax) = (b.min + origin, b.max + origin);
        // Leaf-aligned (8³ cells; a leaf's range holds its upper neighbours', so at most
        // one leaf more on the low side): around the plume, far inside the box.
        assert!(bmin.x >= 32.0 && bmax.x <= 48.0, "{bmin} {bmax}");
        assert!(bmin.y >= 0.0 && bmax.y <= 16.0, "{bmin} {bmax}");
        assert!(bmin.z >= 8.0 && bmax.z <= 24.0, "{bmin} {bmax}");
        assert!((bmax - bmin).max_element() <= 24.0);
        for (p, q) in [(40.0, 44.0), (10.0, 13.0), (20.0, 22.0)].iter().zip(0..3) {
            assert!(bmin[q] <= p.0 && bmax[q] >= p.1);
        }
    }
}
