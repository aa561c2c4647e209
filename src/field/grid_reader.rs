//! A grid read at many nearby points: the 8³ block of the last lookup is kept, so a walk
//! over neighbouring voxels (a shadow cache's bricks) descends the tree once a block
//! instead of once a read. The values are the grid's own, bit for bit.

use super::VoxelGrid;
use super::grid::LeafCache;
use glam::{DVec3, IVec3};

pub struct GridReader<'g> {
    grid: &'g VoxelGrid,
    cache: LeafCache,
}

impl<'g> GridReader<'g> {
    pub fn new(grid: &'g VoxelGrid) -> Self {
        GridReader {
            grid,
            cache: LeafCache::new(),
        }
    }

    /// [`VoxelGrid::voxel_value`] of channel 0.
    #[inline]
    pub fn voxel(&mut self, global: IVec3) -> f32 {
        if self.grid.channels() == 0 {
            return 0.0;
        }
        self.grid.voxel_cached(global, 0, &mut self.cache)
    }

    /// [`VoxelGrid::sample_channel`] of channel 0 at a local index point.
    #[inline]
    pub fn sample(&mut self, p: DVec3) -> f32 {
        self.grid.sample_channel_cached(p, 0, &mut self.cache)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::Field;
    use glam::DMat4;

    /// Voxels over several leaves, with holes, some across the origin.
    fn test_grid() -> VoxelGrid {
        let mut voxels = Vec::new();
        for z in -9i32..14 {
            for y in -3..11 {
                for x in -12..20 {
                    let h = (x * 73 + y * 31 + z * 17).rem_euclid(11);
                    if h != 0 {
                        voxels.push((IVec3::new(x, y, z), h as f32 * 0.1));
                    }
                }
            }
        }
        VoxelGrid::from_voxels("d", voxels, DMat4::IDENTITY).unwrap()
    }

    /// Read through the kept block, every voxel and every point between voxels gives what
    /// the grid's own lookups give, across leaf and tile boundaries and outside.
    #[test]
    fn reads_what_the_grid_reads() {
        let grid = test_grid();
        let b = grid.active_bounds();
        let (lo, hi) = (b.min.floor().as_ivec3() - 3, b.max.ceil().as_ivec3() + 3);
        let origin = grid.transform().origin;
        let mut reader = GridReader::new(&grid);
        let mut n = 0;
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    let local = IVec3::new(x, y, z);
                    let g = local + origin;
                    assert_eq!(reader.voxel(g).to_bits(), grid.voxel_value(g, 0).to_bits());
                    let p = local.as_dvec3() + DVec3::new(0.3, 0.71, 0.5);
                    let want = grid.sample_channel(p, 0);
                    assert_eq!(reader.sample(p).to_bits(), want.to_bits(), "at {p}");
                    n += usize::from(want != 0.0);
                }
            }
        }
        assert!(n > 100, "the test grid has too few non-zero points: {n}");
    }
}
