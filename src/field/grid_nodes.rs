//! A [`VoxelGrid`]'s nodes as flat arrays, for a renderer that walks the tree itself (the
//! GPU backend): the root table, the 32³ and 16³ slot tables, leaf and tile values, and
//! beside every slot the range of the cell it is ([`Field::cell_at`]'s), so that a
//! traversal over these arrays skips the same empty space as the CPU's.

use super::grid::{CHILD, LOWER_SLOTS, RootIndex, UPPER_SLOTS, VoxelGrid};
use super::{Field, ValueRange};
use glam::IVec3;
use rayon::prelude::*;

/// The nodes of a one-channel grid. Slots hold a child index with [`GridNodes::CHILD`]
/// set, or a tile index (tile 0: the background).
#[derive(Clone, Debug)]
pub struct GridNodes {
    /// Global index = local index + `origin`.
    pub origin: IVec3,
    /// The root table: `root[((k.x − min.x)·dims.y + k.y − min.y)·dims.z + k.z − min.z]`
    /// for a 4096³ key `k = global >> 12` inside `min .. min + dims`; background elsewhere.
    /// It reaches one key past the grid's own table on every side, so that the background
    /// cells next to the data, whose trilinear stencil reaches into it, have their range.
    pub root_min: IVec3,
    pub root_dims: IVec3,
    pub root: Vec<u32>,
    /// 32³ slots per upper node, `((x >> 7) & 31) << 10 | ((y >> 7) & 31) << 5 | …`.
    pub upper: Vec<u32>,
    /// 16³ slots per lower node, `((x >> 3) & 15) << 8 | …`.
    pub lower: Vec<u32>,
    /// 512 values per leaf, `(x & 7) << 6 | (y & 7) << 3 | (z & 7)`.
    pub leaf_values: Vec<f32>,
    pub tile_values: Vec<f32>,
    /// The range of the cell each slot is, as `[min, max]`: per root entry, per upper
    /// slot and per lower slot (child slots of the upper and root tables hold nothing).
    pub root_cells: Vec<[f32; 2]>,
    pub upper_cells: Vec<[f32; 2]>,
    pub lower_cells: Vec<[f32; 2]>,
}

impl GridNodes {
    pub const CHILD: u32 = CHILD;
}

/// Why a grid's nodes cannot be flattened.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlatGridError {
    /// More than one channel.
    Channels,
    /// The root nodes lie too far apart for a dense table.
    SparseRoot,
}

impl VoxelGrid {
    /// Whether [`VoxelGrid::nodes`] can flatten the grid, without flattening it.
    pub fn nodes_check(&self) -> Result<(), FlatGridError> {
        if self.channels != 1 {
            return Err(FlatGridError::Channels);
        }
        match self.root {
            RootIndex::Dense { .. } => Ok(()),
            RootIndex::Sorted { .. } => Err(FlatGridError::SparseRoot),
        }
    }

    /// The grid's nodes as flat arrays with each slot's cell range.
    pub fn nodes(&self) -> Result<GridNodes, FlatGridError> {
        self.nodes_check()?;
        self.flatten(true)
    }

    /// The nodes of a grid of any number of channels (the values interleaved, as the
    /// grid holds them: `channels` a voxel and a tile), without the cells' ranges: for
    /// a field that is sampled and never traversed (a colour grid).
    pub fn nodes_unranged(&self) -> Result<GridNodes, FlatGridError> {
        self.flatten(false)
    }

    fn flatten(&self, ranges: bool) -> Result<GridNodes, FlatGridError> {
        let RootIndex::Dense { min, dims, entries } = &self.root else {
            return Err(FlatGridError::SparseRoot);
        };
        let origin = self.transform.origin;
        let range = |global: IVec3| -> [f32; 2] {
            let r: ValueRange = self.cell_at(global - origin).range;
            [r.min, r.max]
        };
        // The grid's table, padded by one key on every side.
        let (min, dims) = (*min - IVec3::ONE, *dims + IVec3::splat(2));
        let at = |d: IVec3, i: usize| {
            let i = i as i32;
            IVec3::new(i / (d.y * d.z), (i / d.z) % d.y, i % d.z)
        };
        let own = |k: IVec3| {
            let r = k - IVec3::ONE;
            let d = dims - IVec3::splat(2);
            if r.cmpge(IVec3::ZERO).all() && r.cmplt(d).all() {
                entries[((r.x * d.y + r.y) * d.z + r.z) as usize]
            } else {
                0
            }
        };
        let root: Vec<u32> = (0..(dims.x * dims.y * dims.z) as usize)
            .map(|i| own(at(dims, i)))
            .collect();
        // Global position of root entry i, and of upper slot `off` of a node at `base`.
        let root_at = |i: usize| (min + at(dims, i)) << 12;
        let slot_at = |off: usize, bits: u32, shift: u32| {
            let m = (1 << bits) - 1;
            let o = off as i32;
            IVec3::new(o >> (2 * bits), (o >> bits) & m, o & m) << shift
        };
        let root_cells: Vec<[f32; 2]> = (0..if ranges { root.len() } else { 0 })
            .into_par_iter()
            .map(|i| range(root_at(i)))
            .collect();
        // Each upper node's global corner, from the root entry that points at it.
        let mut upper_base = vec![IVec3::ZERO; self.upper_slots.len() / UPPER_SLOTS];
        for (i, &e) in root.iter().enumerate() {
            if e & CHILD != 0 {
                upper_base[(e & !CHILD) as usize] = root_at(i);
            }
        }
        let mut lower_base = vec![IVec3::ZERO; self.lower_slots.len() / LOWER_SLOTS];
        for (k, &e) in self.upper_slots.iter().enumerate() {
            if e & CHILD != 0 {
                let g = upper_base[k / UPPER_SLOTS] + slot_at(k % UPPER_SLOTS, 5, 7);
                lower_base[(e & !CHILD) as usize] = g;
            }
        }
        let upper_cells: Vec<[f32; 2]> = (0..if ranges { self.upper_slots.len() } else { 0 })
            .into_par_iter()
            .map(|k| match self.upper_slots[k] & CHILD {
                0 => range(upper_base[k / UPPER_SLOTS] + slot_at(k % UPPER_SLOTS, 5, 7)),
                _ => [0.0, 0.0],
            })
            .collect();
        let lower_cells: Vec<[f32; 2]> = (0..if ranges { self.lower_slots.len() } else { 0 })
            .into_par_iter()
            .map(|k| range(lower_base[k / LOWER_SLOTS] + slot_at(k % LOWER_SLOTS, 4, 3)))
            .collect();
        Ok(GridNodes {
            origin,
            root_min: min,
            root_dims: dims,
            root,
            upper: self.upper_slots.clone(),
            lower: self.lower_slots.clone(),
            leaf_values: self.leaf_values.clone(),
            tile_values: self.tile_values.clone(),
            root_cells,
            upper_cells,
            lower_cells,
        })
    }
}
