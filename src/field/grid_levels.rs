//! A density grid one level coarser: each 2×2×2 block of voxels replaced by its mean, in a
//! voxel twice the size centred on the block (a mip pyramid's next level, as Arnold's
//! `density_level_N`). `--max-error` marches and bakes such a level where its pilot
//! measures that the image allows it (`scene::density_level`).
//!
//! The mean keeps the block's mass (∫ρ dV over the block's voxels), so the optical depth
//! through the coarse grid differs from the fine one's only by how the density varies
//! inside the blocks: zero where it is constant or linear, and over a whole ray a sum of
//! signed differences that largely cancel.

use super::grid::{CHILD, LEAF_VOXELS, LOWER_SLOTS, RootIndex, UPPER_SLOTS, VoxelGrid};
use super::grid_build::GridBuilder;
use crate::vdb::TreeSink;
use glam::{DMat4, DVec3, IVec3};
use std::collections::HashMap;

/// One leaf of the grid: its global origin and its 512 values.
type LeafRef<'a> = (IVec3, &'a [f32]);

impl VoxelGrid {
    /// The grid one level coarser (see the module), or `None` where it cannot be made:
    /// more than one channel, a background that is not zero, or an active tile (a
    /// constant region stored without voxels, which the mean would have to expand).
    pub fn coarser(&self) -> Option<VoxelGrid> {
        if self.channels != 1 || self.tile_values.iter().any(|&v| v != 0.0) {
            return None;
        }
        let leaves = self.leaves()?;
        // Coarse leaves (8³ coarse voxels: a 16³ block of fine voxels), summed into.
        let mut coarse: HashMap<[i32; 3], Box<[f32; LEAF_VOXELS]>> = HashMap::new();
        for (origin, values) in leaves {
            // A fine leaf falls inside one coarse leaf: its 8³ voxels onto 4³ coarse ones.
            let c_origin = (origin >> 1_i32) & !IVec3::splat(7);
            let at = (origin >> 1_i32) - c_origin;
            let dst = coarse
                .entry(c_origin.to_array())
                .or_insert_with(|| Box::new([0.0; LEAF_VOXELS]));
            for (i, &v) in values.iter().enumerate() {
                if v == 0.0 {
                    continue;
                }
                let l = IVec3::new((i >> 6) as i32, ((i >> 3) & 7) as i32, (i & 7) as i32);
                let c = at + (l >> 1_i32);
                dst[(c.x << 6 | c.y << 3 | c.z) as usize] += 0.125 * v;
            }
        }
        let mut keys: Vec<[i32; 3]> = coarse.keys().copied().collect();
        keys.sort();
        let mut b = GridBuilder::new();
        b.begin(1, &[0.0]).ok()?;
        for k in keys {
            let values = &coarse[&k];
            let mut mask = [0u64; 8];
            for (i, v) in values.iter().enumerate() {
                if *v != 0.0 {
                    mask[i >> 6] |= 1 << (i & 63);
                }
            }
            b.leaf(IVec3::from_array(k), &values[..], &mask).ok()?;
        }
        // Coarse voxel c is the mean of fine voxels 2c … 2c+1: it sits at fine 2c + ½.
        let half = DMat4::from_cols_array_2d(&[
            [2.0, 0.0, 0.0, 0.0],
            [0.0, 2.0, 0.0, 0.0],
            [0.0, 0.0, 2.0, 0.0],
            [0.5, 0.5, 0.5, 1.0],
        ]);
        let m = self.transform.matrix() * half;
        b.finish(&self.name, m).ok().map(VoxelGrid::with_dense_copy)
    }

    /// Every leaf with its global origin, or `None` where a slot holds a tile that is not
    /// the background.
    pub(super) fn leaves(&self) -> Option<Vec<LeafRef<'_>>> {
        let tile_ok = |e: u32| e & CHILD != 0 || self.tile_values[e as usize] == 0.0;
        let roots: Vec<(IVec3, u32)> = match &self.root {
            RootIndex::Dense { min, dims, entries } => entries
                .iter()
                .enumerate()
                .map(|(i, &e)| {
                    let i = i as i32;
                    let k = IVec3::new(i / (dims.y * dims.z), (i / dims.z) % dims.y, i % dims.z);
                    ((*min + k) << 12_i32, e)
                })
                .collect(),
            RootIndex::Sorted { keys, entries } => keys
                .iter()
                .zip(entries)
                .map(|(k, &e)| (IVec3::from_array(*k) << 12_i32, e))
                .collect(),
        };
        let slot = |off: usize, bits: u32, shift: u32| {
            let m = (1 << bits) - 1;
            let o = off as i32;
            IVec3::new(o >> (2 * bits), (o >> bits) & m, o & m) << shift as i32
        };
        let mut out = Vec::new();
        for (base, e) in roots {
            if !tile_ok(e) {
                return None;
            }
            if e & CHILD == 0 {
                continue;
            }
            let u = (e & !CHILD) as usize;
            let upper = &self.upper_slots[u * UPPER_SLOTS..(u + 1) * UPPER_SLOTS];
            for (upper_off, l) in self.child_slots(upper)? {
                let lower_base = base + slot(upper_off, 5, 7);
                let lower = &self.lower_slots[l * LOWER_SLOTS..(l + 1) * LOWER_SLOTS];
                for (lower_off, leaf) in self.child_slots(lower)? {
                    out.push((
                        lower_base + slot(lower_off, 4, 3),
                        &self.leaf_values[leaf * LEAF_VOXELS..(leaf + 1) * LEAF_VOXELS],
                    ));
                }
            }
        }
        Some(out)
    }

    /// A node's children as (slot offset, child index), or `None` where one of its slots
    /// holds a tile that is not the background.
    fn child_slots(&self, slots: &[u32]) -> Option<Vec<(usize, usize)>> {
        let mut children = Vec::new();
        for (off, &e) in slots.iter().enumerate() {
            if e & CHILD != 0 {
                children.push((off, (e & !CHILD) as usize));
            } else if self.tile_values[e as usize] != 0.0 {
                return None;
            }
        }
        Some(children)
    }

    /// The world size of one voxel along its shortest axis.
    pub fn smallest_voxel(&self) -> f64 {
        let v: DVec3 = self.transform.voxel_size();
        v.min_element()
    }
}

#[cfg(test)]
mod tests {
    use crate::field::{Field, VoxelGrid};
    use glam::{DMat4, DVec3, IVec3};

    fn grid(voxels: impl IntoIterator<Item = (IVec3, f32)>, voxel: f64) -> VoxelGrid {
        VoxelGrid::from_voxels("density", voxels, DMat4::from_scale(DVec3::splat(voxel))).unwrap()
    }

    /// Each coarse voxel is the mean of its 2³ block, at the block's centre in the world,
    /// and the grid's mass (values × voxel volume) is kept, across leaves and signs of the
    /// index.
    #[test]
    fn a_coarse_voxel_is_its_blocks_mean_at_its_centre() {
        let mut voxels = Vec::new();
        let mut mass = 0.0;
        for x in -12i32..20 {
            for y in -3..9 {
                for z in 5..11 {
                    let v = ((x * 7 + y * 13 + z * 3).rem_euclid(11)) as f32 * 0.1;
                    voxels.push((IVec3::new(x, y, z), v));
                    mass += v as f64;
                }
            }
        }
        let fine = grid(voxels, 0.1);
        let coarse = fine.coarser().expect("a plain grid has a coarser level");
        assert_eq!(coarse.smallest_voxel(), 0.2);
        let mut coarse_mass = 0.0;
        for cx in -6..10 {
            for cy in -2..5 {
                for cz in 2..6 {
                    let c = IVec3::new(cx, cy, cz);
                    let mut mean = 0.0;
                    for d in 0..8 {
                        let f = 2 * c + IVec3::new(d & 1, (d >> 1) & 1, d >> 2);
                        mean += fine.voxel_value(f, 0) as f64 / 8.0;
                    }
                    let got = coarse.voxel_value(c, 0) as f64;
                    assert!((got - mean).abs() < 1e-6, "{c}: {got} vs {mean}");
                    coarse_mass += got * 8.0;
                    // At the block's centre in the world.
                    let world = (2 * c).as_dvec3() * 0.1 + DVec3::splat(0.05);
                    assert!((coarse.value_at_world(world) as f64 - mean).abs() < 1e-5);
                }
            }
        }
        assert!(
            (coarse_mass - mass).abs() < 1e-3 * mass,
            "{coarse_mass} vs {mass}"
        );
    }

    /// A constant region stays constant inside (the mean of equal values), and the
    /// integral through it along a ray is the fine grid's.
    #[test]
    fn a_constant_block_integrates_the_same() {
        let mut voxels = Vec::new();
        for x in 0..32 {
            for y in 0..32 {
                for z in 0..32 {
                    voxels.push((IVec3::new(x, y, z), 1.5));
                }
            }
        }
        let fine = grid(voxels, 0.05);
        let coarse = fine.coarser().unwrap();
        let (o, d) = (DVec3::new(0.3, 0.8, -1.0), DVec3::Z);
        let fr = crate::field::IndexRay::new(&fine, o, d);
        let cr = crate::field::IndexRay::new(&coarse, o, d);
        // From inside the block's first voxel to its last: 1.5 over the length.
        let (t0, t1) = (1.1, 2.4);
        let a = fine.integral(&fr, t0, t1);
        let b = coarse.integral(&cr, t0, t1);
        assert!((a - 1.5 * 1.3).abs() < 1e-9, "{a}");
        assert!((b - a).abs() < 1e-9, "{b} vs {a}");
    }

    #[test]
    fn an_active_tile_has_no_coarser_level() {
        use crate::vdb::TreeSink;
        let mut b = crate::field::grid_build::GridBuilder::new();
        b.begin(1, &[0.0]).unwrap();
        b.tile(IVec3::ZERO, 128, &[1.0], true).unwrap();
        let g = b.finish("d", DMat4::IDENTITY).unwrap();
        assert!(g.coarser().is_none());
    }
}
