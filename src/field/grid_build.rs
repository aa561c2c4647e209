//! Builds a [`VoxelGrid`] from the tiles and leaves a VDB decoder streams into it,
//! sanitising NaN, ±Inf and (for scalar grids) negative values to 0 and counting them.

use super::grid::{
    CHILD, GridStats, LEAF_VOXELS, LOWER_SLOTS, RootIndex, UPPER_SLOTS, VoxelGrid, lower_offset,
    upper_offset,
};
use super::{IndexBox, IndexToWorld, ValueRange};
use crate::vdb::{TreeSink, ValueKind, VdbError, VdbFile};
use glam::{DMat4, IVec3, Vec3};
use std::collections::HashMap;

/// A grid that cannot be built from the voxels given, and why.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("grid {name}: {problem}")]
pub struct GridError {
    pub name: String,
    pub problem: String,
}

/// Largest dense root table (entries) before falling back to a sorted list.
const DENSE_ROOT_LIMIT: i64 = 1 << 18;

/// Collects a grid's tree. Implements [`TreeSink`].
#[derive(Default)]
pub struct GridBuilder {
    channels: usize,
    /// Negative values are bad (a scalar grid that is not `signed`).
    scalar: bool,
    /// The grid holds a signed quantity (a slope), so negatives are data.
    signed: bool,
    root: HashMap<[i32; 3], u32>,
    upper_slots: Vec<u32>,
    lower_slots: Vec<u32>,
    leaf_origin: Vec<IVec3>,
    leaf_values: Vec<f32>,
    /// Each leaf's range of (sanitised) values, found as it is added.
    leaf_range: Vec<ValueRange>,
    tile_values: Vec<f32>,
    /// Bounding box (global, inclusive) of everything that is not background.
    content_min: IVec3,
    content_max: IVec3,
    active_min: IVec3,
    active_max: IVec3,
    stats: GridStats,
}

impl GridBuilder {
    pub fn new() -> Self {
        GridBuilder {
            content_min: IVec3::MAX,
            content_max: IVec3::MIN,
            active_min: IVec3::MAX,
            active_max: IVec3::MIN,
            ..Default::default()
        }
    }

    /// Replaces a bad value by 0, counting it `weight` times.
    fn sanitise(&mut self, v: f32, weight: u64) -> f32 {
        if v.is_nan() {
            self.stats.nan += weight;
            0.0
        } else if v.is_infinite() {
            self.stats.inf += weight;
            0.0
        } else if self.scalar && v < 0.0 {
            self.stats.negative += weight;
            0.0
        } else {
            v
        }
    }

    fn count_active(&mut self, raw: &[f32], voxels: u64) {
        for (c, v) in raw.iter().enumerate() {
            if v.is_finite() {
                self.stats.min[c] = self.stats.min[c].min(*v as f64);
                self.stats.max[c] = self.stats.max[c].max(*v as f64);
                self.stats.sum[c] += *v as f64 * voxels as f64;
            }
        }
    }

    fn add_tile_value(&mut self, raw: &[f32], voxels: u64) -> u32 {
        let idx = (self.tile_values.len() / self.channels.max(1)) as u32;
        for v in raw {
            let s = self.sanitise(*v, voxels);
            self.tile_values.push(s);
        }
        idx
    }

    fn upper_for(&mut self, g: IVec3) -> Result<usize, String> {
        let key = (g >> 12_i32).to_array();
        match self.root.get(&key) {
            Some(e) if e & CHILD != 0 => Ok((e & !CHILD) as usize),
            Some(_) => Err("a node overlaps a root tile".to_string()),
            None => {
                let u = self.upper_slots.len() / UPPER_SLOTS;
                if u as u32 >= CHILD {
                    return Err("too many nodes".to_string());
                }
                self.upper_slots
                    .resize(self.upper_slots.len() + UPPER_SLOTS, 0);
                self.root.insert(key, CHILD | u as u32);
                Ok(u)
            }
        }
    }

    fn lower_for(&mut self, g: IVec3) -> Result<usize, String> {
        let u = self.upper_for(g)?;
        let slot = u * UPPER_SLOTS + upper_offset(g);
        let e = self.upper_slots[slot];
        if e & CHILD != 0 {
            return Ok((e & !CHILD) as usize);
        }
        let l = self.lower_slots.len() / LOWER_SLOTS;
        self.lower_slots
            .resize(self.lower_slots.len() + LOWER_SLOTS, 0);
        self.upper_slots[slot] = CHILD | l as u32;
        Ok(l)
    }

    fn grow_content(&mut self, origin: IVec3, size: i32, active: bool) {
        let hi = origin + IVec3::splat(size - 1);
        self.content_min = self.content_min.min(origin);
        self.content_max = self.content_max.max(hi);
        if active {
            self.active_min = self.active_min.min(origin);
            self.active_max = self.active_max.max(hi);
        }
    }

    /// Finishes the structure: ranges, stencil ranges, local origin, root index.
    pub fn finish(self, name: &str, index_to_world: DMat4) -> Result<VoxelGrid, String> {
        let GridBuilder {
            channels,
            root,
            upper_slots,
            lower_slots,
            leaf_origin,
            leaf_values,
            leaf_range,
            mut tile_values,
            content_min,
            content_max,
            active_min,
            active_max,
            mut stats,
            ..
        } = self;
        let channels = channels.max(1);
        if tile_values.is_empty() {
            tile_values = vec![0.0; channels];
        }
        let has_content = content_min.cmple(content_max).all();
        let origin = if has_content {
            (content_min + content_max) / 2
        } else {
            IVec3::ZERO
        };
        let transform = IndexToWorld::new(index_to_world, origin)
            .ok_or_else(|| "the transform is singular or not finite".to_string())?;
        if active_min.cmple(active_max).all() {
            stats.active_index_bbox = Some((active_min.to_array(), active_max.to_array()));
        }
        if stats.active_voxels == 0 {
            stats.min.clear();
            stats.max.clear();
            stats.sum.clear();
        }
        let range_of = |vals: &[f32]| {
            let mut r = ValueRange::EMPTY;
            for v in vals {
                r.include(*v);
            }
            r
        };
        let tile_range =
            |t: u32| range_of(&tile_values[t as usize * channels..(t as usize + 1) * channels]);
        let slot_range = |e: u32, child: &[ValueRange]| {
            if e & CHILD != 0 {
                child[(e & !CHILD) as usize]
            } else {
                tile_range(e)
            }
        };
        let lower_range: Vec<ValueRange> = lower_slots
            .chunks_exact(LOWER_SLOTS)
            .map(|s| {
                s.iter().fold(ValueRange::EMPTY, |r, e| {
                    r.union(&slot_range(*e, &leaf_range))
                })
            })
            .collect();
        let upper_range: Vec<ValueRange> = upper_slots
            .chunks_exact(UPPER_SLOTS)
            .map(|s| {
                s.iter().fold(ValueRange::EMPTY, |r, e| {
                    r.union(&slot_range(*e, &lower_range))
                })
            })
            .collect();
        let root_index = build_root_index(&root);
        let bounds = if has_content {
            IndexBox::new(
                (content_min - origin).as_vec3() - Vec3::ONE,
                (content_max - origin).as_vec3() + Vec3::ONE,
            )
        } else {
            IndexBox::EMPTY
        };
        let mut grid = VoxelGrid {
            name: name.to_string(),
            channels,
            transform,
            root: root_index,
            upper_slots,
            upper_range,
            lower_slots,
            lower_range,
            leaf_values,
            leaf_stencil: Vec::new(),
            leaf_range,
            tile_values,
            bounds,
            stats,
            dense: None,
        };
        grid.leaf_stencil = leaf_origin
            .iter()
            .enumerate()
            .map(|(i, o)| grid.leaf_stencil_of(grid.leaf_range[i], *o))
            .collect();
        Ok(grid)
    }
}

fn build_root_index(root: &HashMap<[i32; 3], u32>) -> RootIndex {
    let mut keys: Vec<[i32; 3]> = root.keys().copied().collect();
    keys.sort_unstable();
    if keys.is_empty() {
        return RootIndex::Sorted {
            keys: Vec::new(),
            entries: Vec::new(),
        };
    }
    let (mut lo, mut hi) = (IVec3::MAX, IVec3::MIN);
    for k in &keys {
        lo = lo.min(IVec3::from_array(*k));
        hi = hi.max(IVec3::from_array(*k));
    }
    let dims = (hi - lo + IVec3::ONE).as_i64vec3();
    if dims.x * dims.y * dims.z <= DENSE_ROOT_LIMIT {
        let dims = dims.as_ivec3();
        let mut entries = vec![0u32; (dims.x * dims.y * dims.z) as usize];
        for k in &keys {
            let r = IVec3::from_array(*k) - lo;
            entries[((r.x * dims.y + r.y) * dims.z + r.z) as usize] = root[k];
        }
        RootIndex::Dense {
            min: lo,
            dims,
            entries,
        }
    } else {
        let entries = keys.iter().map(|k| root[k]).collect();
        RootIndex::Sorted { keys, entries }
    }
}

impl TreeSink for GridBuilder {
    fn begin(&mut self, channels: usize, background: &[f32]) -> Result<(), String> {
        self.channels = channels;
        self.scalar = channels == 1 && !self.signed;
        self.stats.min = vec![f64::INFINITY; channels];
        self.stats.max = vec![f64::NEG_INFINITY; channels];
        self.stats.sum = vec![0.0; channels];
        self.tile_values.clear();
        self.add_tile_value(background, 0);
        Ok(())
    }

    fn tile(
        &mut self,
        origin: IVec3,
        size: i32,
        value: &[f32],
        active: bool,
    ) -> Result<(), String> {
        if !matches!(size, 8 | 128 | 4096) || (origin & IVec3::splat(size - 1)) != IVec3::ZERO {
            return Err(format!(
                "a tile of size {size} at a misaligned origin ({}, {}, {})",
                origin.x, origin.y, origin.z
            ));
        }
        let voxels = (size as u64).pow(3);
        if active {
            self.count_active(value, voxels);
            self.stats.active_voxels += voxels;
            let level = match size {
                8 => 0,
                128 => 1,
                _ => 2,
            };
            self.stats.active_tiles_by_level[level] += 1;
        }
        self.grow_content(origin, size, active);
        let t = self.add_tile_value(value, voxels);
        match size {
            4096 => {
                let key = (origin >> 12_i32).to_array();
                if self.root.insert(key, t).is_some() {
                    return Err("two root entries at the same place".to_string());
                }
            }
            128 => {
                let u = self.upper_for(origin)?;
                self.upper_slots[u * UPPER_SLOTS + upper_offset(origin)] = t;
            }
            8 => {
                let l = self.lower_for(origin)?;
                self.lower_slots[l * LOWER_SLOTS + lower_offset(origin)] = t;
            }
            _ => return Err(format!("a tile of size {size}")),
        }
        Ok(())
    }

    fn leaf(&mut self, origin: IVec3, values: &[f32], active: &[u64; 8]) -> Result<(), String> {
        if (origin & IVec3::splat(7)) != IVec3::ZERO {
            return Err(format!(
                "a leaf at a misaligned origin ({}, {}, {})",
                origin.x, origin.y, origin.z
            ));
        }
        let ch = self.channels.max(1);
        if values.len() != LEAF_VOXELS * ch {
            return Err("a leaf of the wrong size".to_string());
        }
        let l = self.lower_for(origin)?;
        let slot = l * LOWER_SLOTS + lower_offset(origin);
        let leaf_index = self.leaf_origin.len() as u32;
        if leaf_index >= CHILD {
            return Err("too many leaves".to_string());
        }
        self.lower_slots[slot] = CHILD | leaf_index;
        self.leaf_origin.push(origin);
        self.stats.leaves += 1;
        let scalar = self.scalar;
        let start = self.leaf_values.len();
        self.leaf_values.extend_from_slice(values);
        // One vectorised pass first: the values' range, and whether any needs sanitising.
        let (raw_range, clean) = range_and_clean(values, scalar);
        let dense = active.iter().all(|w| *w == u64::MAX);
        // Statistics of the raw active values, summed in voxel order.
        let (mut amin, mut amax) = (IVec3::MAX, IVec3::MIN);
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        let mut sum = [0f64; 3];
        let mut n_active = 0u64;
        if dense && clean && ch == 1 {
            // Most of a fog volume: every voxel active, every value finite.
            lo[0] = raw_range.min;
            hi[0] = raw_range.max;
            sum[0] = values.iter().fold(0.0, |s, v| s + *v as f64);
            n_active = LEAF_VOXELS as u64;
            amin = IVec3::ZERO;
            amax = IVec3::splat(7);
        } else {
            for (w, word) in active.iter().enumerate() {
                let mut bits = *word;
                while bits != 0 {
                    let n = w * 64 + bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    n_active += 1;
                    for (c, v) in values[n * ch..(n + 1) * ch].iter().enumerate() {
                        if v.is_finite() {
                            lo[c] = lo[c].min(*v);
                            hi[c] = hi[c].max(*v);
                            sum[c] += *v as f64;
                        }
                    }
                    let p = IVec3::new((n >> 6) as i32, ((n >> 3) & 7) as i32, (n & 7) as i32);
                    amin = amin.min(p);
                    amax = amax.max(p);
                }
            }
        }
        if n_active > 0 {
            self.stats.active_voxels += n_active;
            for c in 0..ch.min(3) {
                if lo[c] <= hi[c] {
                    self.stats.min[c] = self.stats.min[c].min(lo[c] as f64);
                    self.stats.max[c] = self.stats.max[c].max(hi[c] as f64);
                }
                self.stats.sum[c] += sum[c];
            }
            self.active_min = self.active_min.min(origin + amin);
            self.active_max = self.active_max.max(origin + amax);
        }
        if clean {
            self.leaf_range.push(raw_range);
        } else {
            let (mut nan, mut inf, mut neg) = (0u64, 0u64, 0u64);
            let mut range = ValueRange::EMPTY;
            for v in &mut self.leaf_values[start..] {
                if !v.is_finite() || (scalar && *v < 0.0) {
                    if v.is_nan() {
                        nan += 1;
                    } else if v.is_infinite() {
                        inf += 1;
                    } else {
                        neg += 1;
                    }
                    *v = 0.0;
                }
                range.include(*v);
            }
            self.leaf_range.push(range);
            self.stats.nan += nan;
            self.stats.inf += inf;
            self.stats.negative += neg;
        }
        self.grow_content(origin, 8, false);
        Ok(())
    }
}

/// The range of `values` and whether all are finite (and, if `scalar`, not negative),
/// in lanes the compiler can vectorise (a leaf's values are most of the load's work).
fn range_and_clean(values: &[f32], scalar: bool) -> (ValueRange, bool) {
    const LANES: usize = 8;
    let mut lo = [f32::INFINITY; LANES];
    let mut hi = [f32::NEG_INFINITY; LANES];
    let mut bad = [false; LANES];
    let chunks = values.chunks_exact(LANES);
    let tail = chunks.remainder();
    for chunk in chunks {
        for j in 0..LANES {
            let v = chunk[j];
            lo[j] = if v < lo[j] { v } else { lo[j] };
            hi[j] = if v > hi[j] { v } else { hi[j] };
            // NaN fails `<`, so it counts as bad too.
            bad[j] |= !(v.abs() < f32::INFINITY) | (scalar & (v < 0.0));
        }
    }
    let mut range = ValueRange::EMPTY;
    let mut clean = !bad.iter().any(|b| *b);
    for j in 0..LANES {
        range.include(lo[j]);
        range.include(hi[j]);
    }
    for v in tail {
        range.include(*v);
        clean &= v.is_finite() && !(scalar && *v < 0.0);
    }
    (range, clean)
}

impl VoxelGrid {
    fn leaf_stencil_of(&self, own: ValueRange, origin: IVec3) -> ValueRange {
        self.stencil_range_pub(own, origin, 8)
    }

    /// Decodes grid `name` of an opened file into a render structure.
    pub fn load(file: &VdbFile, name: &str) -> Result<VoxelGrid, VdbError> {
        Self::load_with(file, name, GridBuilder::new())
    }

    /// [`VoxelGrid::load`] for a grid of a signed quantity: NaN and ±Inf still become 0,
    /// negative values are kept.
    pub fn load_signed(file: &VdbFile, name: &str) -> Result<VoxelGrid, VdbError> {
        Self::load_with(
            file,
            name,
            GridBuilder {
                signed: true,
                ..GridBuilder::new()
            },
        )
    }

    fn load_with(file: &VdbFile, name: &str, builder: GridBuilder) -> Result<VoxelGrid, VdbError> {
        let info = file.grid(name)?;
        if info.kind == ValueKind::Unsupported {
            return Err(VdbError::grid(
                file.path(),
                &info.unique_name,
                format!(
                    "value type \"{}\" cannot be rendered (murk reads float, double and vec3 grids)",
                    info.value_type
                ),
            ));
        }
        let mut b = builder;
        let decoded = file.decode(name, &mut b)?;
        let unique = info.unique_name.clone();
        b.finish(&unique, decoded.index_to_world)
            .map_err(|p| VdbError::grid(file.path(), &unique, p))
    }

    /// A scalar grid from active voxels `(ijk, value)` (file index space), through the
    /// same builder a decoded file goes through (NaN, ±Inf and negatives become 0). For
    /// tests and the stability battery, which need grids no fixture holds.
    pub fn from_voxels(
        name: &str,
        voxels: impl IntoIterator<Item = (IVec3, f32)>,
        index_to_world: DMat4,
    ) -> Result<VoxelGrid, GridError> {
        let bad = |problem: String| GridError {
            name: name.to_string(),
            problem,
        };
        /// A leaf's values and its active mask.
        type Leaf = (Box<[f32; 512]>, [u64; 8]);
        let mut leaves: HashMap<[i32; 3], Leaf> = HashMap::new();
        for (ijk, v) in voxels {
            let origin = (ijk >> 3_i32) << 3_i32;
            let (values, mask) = leaves
                .entry(origin.to_array())
                .or_insert_with(|| (Box::new([0.0; 512]), [0; 8]));
            let l = ijk - origin;
            let offset = (l.x << 6 | l.y << 3 | l.z) as usize;
            values[offset] = v;
            mask[offset >> 6] |= 1 << (offset & 63);
        }
        let mut keys: Vec<_> = leaves.keys().copied().collect();
        keys.sort();
        let mut b = GridBuilder::new();
        b.begin(1, &[0.0]).map_err(bad)?;
        for k in keys {
            let (values, mask) = &leaves[&k];
            b.leaf(IVec3::from_array(k), &values[..], mask)
                .map_err(bad)?;
        }
        b.finish(name, index_to_world).map_err(bad)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn misaligned_nodes_are_rejected() {
        let mut b = GridBuilder::new();
        b.begin(1, &[0.0]).unwrap();
        assert!(
            b.leaf(IVec3::new(8, 3, 0), &[0.0; 512], &[0; 8])
                .unwrap_err()
                .contains("misaligned")
        );
        assert!(
            b.tile(IVec3::new(8, 0, 0), 128, &[1.0], true)
                .unwrap_err()
                .contains("misaligned")
        );
        assert!(b.tile(IVec3::ZERO, 16, &[1.0], true).is_err());
        assert!(
            b.tile(IVec3::new(4096, 0, -4096), 4096, &[1.0], true)
                .is_ok()
        );
    }

    /// NaN, ±Inf and negative values become 0 and are counted; stats keep the finite raw values.
    #[test]
    fn bad_values_are_sanitised_and_counted() {
        let mut b = GridBuilder::new();
        b.begin(1, &[0.0]).unwrap();
        let mut vals = [1.0f32; 512];
        vals[0] = f32::NAN;
        vals[1] = f32::INFINITY;
        vals[2] = f32::NEG_INFINITY;
        vals[3] = -2.0;
        b.leaf(IVec3::ZERO, &vals, &[u64::MAX; 8]).unwrap();
        b.tile(IVec3::new(8, 0, 0), 8, &[f32::NAN], false).unwrap();
        let g = b.finish("d", glam::DMat4::IDENTITY).unwrap();
        let s = g.stats();
        assert_eq!((s.nan, s.inf, s.negative), (1 + 512, 2, 1));
        assert_eq!(s.min, vec![-2.0]);
        assert_eq!(s.max, vec![1.0]);
        for k in 0..4 {
            assert_eq!(g.voxel_value(IVec3::new(0, 0, k), 0), 0.0);
        }
        assert_eq!(g.voxel_value(IVec3::new(9, 1, 1), 0), 0.0);
    }
}
