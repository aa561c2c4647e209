//! [`VoxelGrid`]: the read-only render structure a VDB grid is converted into.
//!
//! The same 5-4-3 hierarchy as OpenVDB, flattened for sampling speed: a root index of
//! 4096³ nodes (a dense array, or a sorted list when the nodes are far apart), then
//! 32³ and 16³ slot tables as flat `u32` arrays, then 8³ leaf bricks in one flat `f32`
//! array. A slot holds either a child index (high bit set) or a tile-value index, so
//! tiles stay tiles at every level. Each leaf and node keeps the range of its values;
//! leaves also keep the range over the +1 voxel layer the trilinear stencil reaches, so
//! the traversal can use them as majorants directly.

use super::floor::floor_i32;
use super::{Cell, Field, IndexBox, IndexRay, IndexToWorld, ValueRange};
use glam::{DVec3, IVec3, Vec3};

pub(super) const CHILD: u32 = 1 << 31;
pub(super) const LEAF_VOXELS: usize = 512;
pub(super) const LOWER_SLOTS: usize = 4096;
pub(super) const UPPER_SLOTS: usize = 32768;

/// Largest local index magnitude looked up; beyond it everything is background.
pub(super) const LOOKUP_LIMIT: f64 = (1 << 30) as f64;

/// Maps a 4096³ node key (`global >> 12`) to a root slot.
#[derive(Clone, Debug)]
pub(super) enum RootIndex {
    /// Every key in a box: `entries[x][y][z]`.
    Dense {
        min: IVec3,
        dims: IVec3,
        entries: Vec<u32>,
    },
    /// Sorted keys, binary searched (nodes too far apart for a dense table).
    Sorted {
        keys: Vec<[i32; 3]>,
        entries: Vec<u32>,
    },
}

impl RootIndex {
    #[inline]
    pub(super) fn get(&self, key: IVec3) -> u32 {
        match self {
            RootIndex::Dense { min, dims, entries } => {
                let r = key - *min;
                if r.x < 0 || r.y < 0 || r.z < 0 || r.x >= dims.x || r.y >= dims.y || r.z >= dims.z
                {
                    return 0;
                }
                entries[((r.x * dims.y + r.y) * dims.z + r.z) as usize]
            }
            RootIndex::Sorted { keys, entries } => match keys.binary_search(&key.to_array()) {
                Ok(i) => entries[i],
                Err(_) => 0,
            },
        }
    }
}

/// Counts made while building: what the file held and what was sanitised.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct GridStats {
    pub active_voxels: u64,
    pub leaves: u64,
    /// Active tiles by level: `[8³ tiles, 128³ tiles, 4096³ root tiles]`.
    pub active_tiles_by_level: [u64; 3],
    /// Minimum, maximum and sum of the finite active values (per channel), before
    /// sanitising. Empty when there are no active values.
    pub min: Vec<f64>,
    pub max: Vec<f64>,
    pub sum: Vec<f64>,
    /// Values replaced by 0 at build time (tiles count every voxel they cover).
    pub nan: u64,
    pub inf: u64,
    pub negative: u64,
    /// Inclusive bounding box of the active voxels, in file index space.
    pub active_index_bbox: Option<([i32; 3], [i32; 3])>,
}

impl GridStats {
    pub fn active_tiles(&self) -> u64 {
        self.active_tiles_by_level.iter().sum()
    }
    pub fn sanitised(&self) -> u64 {
        self.nan + self.inf + self.negative
    }
    pub fn mean(&self) -> Vec<f64> {
        self.sum
            .iter()
            .map(|s| {
                if self.active_voxels > 0 {
                    s / self.active_voxels as f64
                } else {
                    0.0
                }
            })
            .collect()
    }
}

/// A sparse voxel grid ready for sampling. Built by [`super::grid_build::GridBuilder`].
#[derive(Clone, Debug)]
pub struct VoxelGrid {
    pub(super) name: String,
    pub(super) channels: usize,
    pub(super) transform: IndexToWorld,
    pub(super) root: RootIndex,
    pub(super) upper_slots: Vec<u32>,
    pub(super) upper_range: Vec<ValueRange>,
    pub(super) lower_slots: Vec<u32>,
    pub(super) lower_range: Vec<ValueRange>,
    pub(super) leaf_values: Vec<f32>,
    pub(super) leaf_range: Vec<ValueRange>,
    pub(super) leaf_stencil: Vec<ValueRange>,
    /// `channels` values per tile; tile 0 is the background.
    pub(super) tile_values: Vec<f32>,
    pub(super) bounds: IndexBox,
    pub(super) stats: GridStats,
    /// A dense copy of the voxels for lookups along rays, kept for density levels
    /// (`grid_dense`).
    pub(super) dense: Option<Box<DenseVoxels>>,
}

/// Voxels of `[min − 1, max + 1)` along each axis in x-major order (`max` exclusive: one
/// past the last leaf voxel), the ring around the leaves zero; made and read in
/// `grid_dense`.
#[derive(Clone, Debug)]
pub(super) struct DenseVoxels {
    /// The copy's first voxel (global index), one before the leaves' box.
    pub(super) base: IVec3,
    pub(super) dims: IVec3,
    pub(super) values: Vec<f32>,
}

/// Where a voxel lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Slot {
    Tile(u32),
    Leaf(u32),
}

#[inline]
pub(super) fn upper_offset(g: IVec3) -> usize {
    ((((g.x >> 7) & 31) << 10) | (((g.y >> 7) & 31) << 5) | ((g.z >> 7) & 31)) as usize
}
#[inline]
pub(super) fn lower_offset(g: IVec3) -> usize {
    ((((g.x >> 3) & 15) << 8) | (((g.y >> 3) & 15) << 4) | ((g.z >> 3) & 15)) as usize
}
#[inline]
pub(super) fn leaf_offset(g: IVec3) -> usize {
    (((g.x & 7) << 6) | ((g.y & 7) << 3) | (g.z & 7)) as usize
}

impl VoxelGrid {
    /// A 64-bit fingerprint of what the grid renders as: its transform, topology and
    /// values (not its name). Equal grids give equal hashes on every machine.
    pub fn content_hash(&self) -> u64 {
        use super::random::mix64;
        let mut h: u64 = 0x6d75_726b_0000_0001;
        let mut eat = |v: u64| h = mix64(h ^ v).wrapping_add(0x9E37_79B9_7F4A_7C15);
        eat(self.channels as u64);
        for c in self.transform.matrix().to_cols_array() {
            eat(c.to_bits());
        }
        for c in self.transform.origin.to_array() {
            eat(c as u32 as u64);
        }
        for list in [&self.upper_slots, &self.lower_slots] {
            eat(list.len() as u64);
            list.iter().for_each(|v| eat(*v as u64));
        }
        for list in [&self.leaf_values, &self.tile_values] {
            eat(list.len() as u64);
            list.iter().for_each(|v| eat(v.to_bits() as u64));
        }
        match &self.root {
            RootIndex::Dense { min, dims, entries } => {
                eat(min.x as u32 as u64 | (min.y as u32 as u64) << 32);
                eat(min.z as u32 as u64 | (dims.x as u32 as u64) << 32);
                eat(dims.y as u32 as u64 | (dims.z as u32 as u64) << 32);
                entries.iter().for_each(|v| eat(*v as u64));
            }
            RootIndex::Sorted { keys, entries } => {
                for (k, e) in keys.iter().zip(entries) {
                    eat(k[0] as u32 as u64 | (k[1] as u32 as u64) << 32);
                    eat(k[2] as u32 as u64 | (*e as u64) << 32);
                }
            }
        }
        h
    }

    pub fn name(&self) -> &str {
        &self.name
    }
    pub fn channels(&self) -> usize {
        self.channels
    }
    pub fn stats(&self) -> &GridStats {
        &self.stats
    }
    pub fn leaf_count(&self) -> usize {
        self.leaf_range.len()
    }
    /// The background value (channel 0), after sanitising.
    pub fn background(&self) -> f32 {
        self.tile_values.first().copied().unwrap_or(0.0)
    }

    /// Bytes held by the render structure.
    pub fn memory_bytes(&self) -> usize {
        use std::mem::size_of;
        let root = match &self.root {
            RootIndex::Dense { entries, .. } => entries.len() * 4,
            RootIndex::Sorted { keys, entries } => keys.len() * 12 + entries.len() * 4,
        };
        root + (self.upper_slots.len() + self.lower_slots.len()) * 4
            + (self.leaf_values.len() + self.tile_values.len()) * 4
            + (self.upper_range.len()
                + self.lower_range.len()
                + self.leaf_range.len()
                + self.leaf_stencil.len())
                * size_of::<ValueRange>()
            + self.dense.as_ref().map_or(0, |d| d.memory_bytes())
            + size_of::<Self>()
    }

    #[inline]
    fn lookup(&self, g: IVec3) -> Slot {
        let e = self.root.get(g >> 12);
        if e & CHILD == 0 {
            return Slot::Tile(e);
        }
        let u = (e & !CHILD) as usize;
        let e = self.upper_slots[u * UPPER_SLOTS + upper_offset(g)];
        if e & CHILD == 0 {
            return Slot::Tile(e);
        }
        let l = (e & !CHILD) as usize;
        let e = self.lower_slots[l * LOWER_SLOTS + lower_offset(g)];
        if e & CHILD == 0 {
            Slot::Tile(e)
        } else {
            Slot::Leaf(e & !CHILD)
        }
    }

    /// The stored value of channel `c` at a global index coordinate.
    #[inline]
    pub(super) fn voxel(&self, g: IVec3, c: usize) -> f32 {
        self.slot_value(self.lookup(g), g, c)
    }

    /// [`VoxelGrid::voxel`], its block looked up through `cache`.
    #[inline]
    pub(super) fn voxel_cached(&self, g: IVec3, c: usize, cache: &mut LeafCache) -> f32 {
        self.slot_value(self.lookup_cached(g, cache), g, c)
    }

    #[inline(always)]
    fn slot_value(&self, slot: Slot, g: IVec3, c: usize) -> f32 {
        match slot {
            Slot::Tile(t) => self.tile_values[t as usize * self.channels + c],
            Slot::Leaf(l) => {
                self.leaf_values[(l as usize * LEAF_VOXELS + leaf_offset(g)) * self.channels + c]
            }
        }
    }

    /// The stored (sanitised) value of channel `c` at a voxel in file index space.
    pub fn voxel_value(&self, global: IVec3, c: usize) -> f32 {
        if c >= self.channels {
            return 0.0;
        }
        self.voxel(global, c)
    }

    /// Trilinear value of channel `c` at a local index point, as OpenVDB's BoxSampler:
    /// values sit at integer points and blend with the weights of the fractional part.
    #[inline]
    pub fn sample_channel(&self, p: DVec3, c: usize) -> f32 {
        self.sample_channel_cached(p, c, &mut LeafCache::new())
    }

    /// [`VoxelGrid::sample_channel`], its blocks looked up through `cache`.
    #[inline(always)]
    pub(super) fn sample_channel_cached(&self, p: DVec3, c: usize, cache: &mut LeafCache) -> f32 {
        match self.stencil(p, c, cache) {
            Stencil::Constant(v) => v,
            Stencil::Corners(v, t) => trilinear(&v, t.as_vec3()),
        }
    }

    /// Channel `c` at local index point `points[c]` for c = 0, 1, 2 (a vector's
    /// components, each where it is stored), each leaf looked up once for all three.
    pub fn sample_components(&self, points: [DVec3; 3]) -> [f32; 3] {
        let mut cache = LeafCache::new();
        let mut out = [0.0; 3];
        for (c, (p, o)) in points.iter().zip(out.iter_mut()).enumerate() {
            *o = if c >= self.channels {
                0.0
            } else if !(p.abs().max_element() < LOOKUP_LIMIT) {
                self.tile_values[c]
            } else {
                let i = IVec3::new(floor_i32(p.x), floor_i32(p.y), floor_i32(p.z));
                match self.stencil_in(i, *p - i.as_dvec3(), c, &mut cache) {
                    Stencil::Constant(v) => v,
                    Stencil::Corners(v, t) => trilinear(&v, t.as_vec3()),
                }
            };
        }
        out
    }

    /// [`VoxelGrid::sample_channel`] with the blend done in f64 (the stored values are
    /// f32): what the reference render's exact integrals use.
    #[inline]
    pub fn sample_channel_f64(&self, p: DVec3, c: usize) -> f64 {
        match self.stencil(p, c, &mut LeafCache::new()) {
            Stencil::Constant(v) => v as f64,
            Stencil::Corners(v, t) => trilinear_f64(&v, t),
        }
    }

    /// The eight voxel values around `p` and its fractional position among them, or the
    /// value where all eight are one tile.
    #[inline(always)]
    fn stencil(&self, p: DVec3, c: usize, cache: &mut LeafCache) -> Stencil {
        if !(p.abs().max_element() < LOOKUP_LIMIT) || c >= self.channels {
            return Stencil::Constant(if c < self.channels {
                self.tile_values[c]
            } else {
                0.0
            });
        }
        let i = IVec3::new(floor_i32(p.x), floor_i32(p.y), floor_i32(p.z));
        self.stencil_in(i, p - i.as_dvec3(), c, cache)
    }

    /// The slot of the 8³ block holding global voxel `g`, from `cache` when the last
    /// lookup was in the same block.
    #[inline(always)]
    fn lookup_cached(&self, g: IVec3, cache: &mut LeafCache) -> Slot {
        let key = g >> 3_i32;
        if key != cache.key {
            cache.slot = self.lookup(g);
            cache.key = key;
        }
        cache.slot
    }

    /// [`VoxelGrid::stencil`] of the cell whose lowest corner is local voxel `i`, at
    /// fraction `t` in it (`c` a valid channel, `i` within the lookup limit).
    #[inline(always)]
    pub(super) fn stencil_in(
        &self,
        i: IVec3,
        t: DVec3,
        c: usize,
        cache: &mut LeafCache,
    ) -> Stencil {
        let g = i + self.transform.origin;
        let ch = self.channels;
        let mut v = [0.0f32; 8];
        let base_slot = self.lookup_cached(g, cache);
        if (g.x & 7) != 7 && (g.y & 7) != 7 && (g.z & 7) != 7 {
            // All eight corners in one leaf or tile.
            match base_slot {
                Slot::Tile(tile) => {
                    return Stencil::Constant(self.tile_values[tile as usize * ch + c]);
                }
                Slot::Leaf(l) => {
                    let base = l as usize * LEAF_VOXELS + leaf_offset(g);
                    let vals = &self.leaf_values;
                    for (k, o) in [0usize, 1, 8, 9, 64, 65, 72, 73].iter().enumerate() {
                        v[k] = vals[(base + o) * ch + c];
                    }
                }
            }
        } else {
            // Corners spread over up to eight leaves: look each leaf up once.
            let mut seen: [(IVec3, Slot); 8] = [(g >> 3_i32, base_slot); 8];
            let mut n_seen = 1;
            for (k, value) in v.iter_mut().enumerate() {
                let corner = g + IVec3::new((k >> 2) as i32 & 1, (k >> 1) as i32 & 1, k as i32 & 1);
                let key = corner >> 3_i32;
                let slot = match seen[..n_seen].iter().find(|(sk, _)| *sk == key) {
                    Some((_, s)) => *s,
                    None => {
                        let s = self.lookup(corner);
                        seen[n_seen] = (key, s);
                        n_seen += 1;
                        s
                    }
                };
                *value = match slot {
                    Slot::Tile(tile) => self.tile_values[tile as usize * ch + c],
                    Slot::Leaf(l) => {
                        self.leaf_values[(l as usize * LEAF_VOXELS + leaf_offset(corner)) * ch + c]
                    }
                };
            }
        }
        Stencil::Corners(v, t)
    }

    /// Trilinear RGB / vector value at a local index point (channels 0..3; a scalar grid
    /// gives its value in all three).
    pub fn sample_vec3(&self, p: DVec3) -> Vec3 {
        if self.channels < 3 {
            return Vec3::splat(self.sample_channel(p, 0));
        }
        Vec3::new(
            self.sample_channel(p, 0),
            self.sample_channel(p, 1),
            self.sample_channel(p, 2),
        )
    }

    fn cell_global(&self, g: IVec3) -> Cell {
        let align = |s: i32| IVec3::new(g.x & !(s - 1), g.y & !(s - 1), g.z & !(s - 1));
        let o = self.transform.origin;
        let tile_cell = |t: u32, size: i32| {
            let origin = align(size);
            Cell {
                origin: origin - o,
                size,
                range: self.stencil_range_pub(self.tile_range(t), origin, size),
            }
        };
        let e = self.root.get(g >> 12);
        if e & CHILD == 0 {
            return tile_cell(e, 4096);
        }
        let u = (e & !CHILD) as usize;
        let e = self.upper_slots[u * UPPER_SLOTS + upper_offset(g)];
        if e & CHILD == 0 {
            return tile_cell(e, 128);
        }
        let l = (e & !CHILD) as usize;
        let e = self.lower_slots[l * LOWER_SLOTS + lower_offset(g)];
        if e & CHILD == 0 {
            let origin = align(8);
            return Cell {
                origin: origin - o,
                size: 8,
                range: self.stencil_range_in_lower(self.tile_range(e), origin, l),
            };
        }
        Cell {
            origin: align(8) - o,
            size: 8,
            range: self.leaf_stencil[(e & !CHILD) as usize],
        }
    }
}

/// The block (`global >> 3`) and slot of the last lookup along a ray.
pub(super) struct LeafCache {
    key: IVec3,
    slot: Slot,
}

impl LeafCache {
    pub(super) fn new() -> Self {
        LeafCache {
            key: IVec3::MIN,
            slot: Slot::Tile(0),
        }
    }
}

/// What a trilinear lookup needs: one value, or eight corners and the fraction.
pub(super) enum Stencil {
    Constant(f32),
    Corners([f32; 8], DVec3),
}

/// [`trilinear`] in f64.
#[inline]
pub(super) fn trilinear_f64(v: &[f32; 8], t: DVec3) -> f64 {
    let lerp = |a: f64, b: f64, s: f64| a + (b - a) * s;
    let v = v.map(|x| x as f64);
    let c00 = lerp(v[0], v[1], t.z);
    let c01 = lerp(v[2], v[3], t.z);
    let c10 = lerp(v[4], v[5], t.z);
    let c11 = lerp(v[6], v[7], t.z);
    lerp(lerp(c00, c01, t.y), lerp(c10, c11, t.y), t.x)
}

#[inline]
pub(crate) fn trilinear(v: &[f32; 8], t: Vec3) -> f32 {
    // v[k]: corner (k>>2 & 1, k>>1 & 1, k & 1) in (x, y, z).
    let lerp = |a: f32, b: f32, s: f32| a + (b - a) * s;
    let c00 = lerp(v[0], v[1], t.z);
    let c01 = lerp(v[2], v[3], t.z);
    let c10 = lerp(v[4], v[5], t.z);
    let c11 = lerp(v[6], v[7], t.z);
    lerp(lerp(c00, c01, t.y), lerp(c10, c11, t.y), t.x)
}

impl Field for VoxelGrid {
    #[inline]
    fn value_at_index(&self, p: DVec3) -> f32 {
        self.sample_channel(p, 0)
    }

    fn transform(&self) -> &IndexToWorld {
        &self.transform
    }

    fn active_bounds(&self) -> IndexBox {
        self.bounds
    }

    fn cell_at(&self, ijk: IVec3) -> Cell {
        let lim = 1 << 30;
        let g = ijk.clamp(IVec3::splat(-lim), IVec3::splat(lim)) + self.transform.origin;
        self.cell_global(g)
    }

    /// Exact: the ray is cut at every voxel face (Amanatides–Woo), and inside a voxel the
    /// trilinear reconstruction along the ray is a cubic, which two-point Gauss–Legendre
    /// integrates exactly.
    fn quadrature(&self) -> super::Quadrature {
        super::Quadrature::ExactPerVoxel
    }

    fn content_hash(&self) -> Option<u64> {
        Some(VoxelGrid::content_hash(self))
    }

    fn as_voxel_grid(&self) -> Option<&VoxelGrid> {
        Some(self)
    }

    fn memory_bytes(&self) -> usize {
        VoxelGrid::memory_bytes(self)
    }

    fn integral(&self, ray: &IndexRay, t0: f64, t1: f64) -> f64 {
        self.exact_integral(ray, t0, t1)
    }

    fn piece_integrals(&self, ray: &IndexRay, t0: f64, ends: &[f64], out: &mut [f64]) {
        self.exact_piece_integrals(ray, t0, ends, out)
    }

    fn values_along(&self, ray: &IndexRay, ts: &[f64], out: &mut [f32]) {
        self.sample_along(ray, ts, out)
    }

    fn slopes_along(
        &self,
        ray: &IndexRay,
        t0: f64,
        targets: &[f64],
        side: &super::Sideways,
        out: &mut Vec<[f64; 4]>,
    ) -> bool {
        VoxelGrid::slopes_along(self, ray, t0, targets, side, out)
    }

    fn tight_range_over(&self, b: &IndexBox) -> ValueRange {
        self.tight_range_of_box(b)
    }

    fn range_over(&self, b: &IndexBox) -> ValueRange {
        self.range_of_box(b)
    }
}
