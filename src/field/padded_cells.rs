//! The value ranges of a moving field's cells, grown by the farthest the flow carries
//! anything within the shutter, computed once for every time: without them every cell a
//! ray of a moving volume crosses asked its field for the range over the grown cell (a
//! walk over the tree's nodes), which cost a blurred render more than its samples.

use super::{Cell, Field, IndexBox, ValueRange};
use glam::{DVec3, IVec3, Vec3};
use rayon::prelude::*;
use std::sync::OnceLock;

/// Edge of the cells, voxels (a leaf's).
pub const CELL: i32 = 8;

/// Cells a table may hold (32 MiB of ranges); a larger field's cells are asked for their
/// ranges one by one, as without a table.
const MAX_CELLS: usize = 1 << 22;

/// The ranges of `field` over every [`CELL`]-voxel cell of its active bounds grown by
/// `pad` (local index units per axis), each over the cell grown by `pad`.
pub struct PaddedCells {
    /// Which field (its address) and pad the table is for.
    key: usize,
    bounds: IndexBox,
    pad: DVec3,
    /// The first cell (in cells) and how many along each axis.
    first: IVec3,
    dims: IVec3,
    ranges: Vec<ValueRange>,
}

/// `f`'s address, to tell the fields a cache holds apart.
fn key_of(f: &dyn Field) -> usize {
    f as *const dyn Field as *const u8 as usize
}

impl PaddedCells {
    /// The table of `field` grown by `pad` (`None` where it would be too large or the
    /// field is empty).
    pub fn build(field: &dyn Field, pad: DVec3) -> Option<Self> {
        let b = field.active_bounds();
        if b.is_empty() || !pad.is_finite() {
            return None;
        }
        let p = pad.as_vec3();
        let (lo, hi) = (b.min - p, b.max + p);
        if !(lo.is_finite() && hi.is_finite()) || (hi - lo).max_element() > 1e7 {
            return None;
        }
        let first = (lo / CELL as f32).floor().as_ivec3();
        let last = (hi / CELL as f32).floor().as_ivec3();
        let dims = last - first + IVec3::ONE;
        let count = dims.x as usize * dims.y as usize * dims.z as usize;
        if count > MAX_CELLS {
            return None;
        }
        let ranges = (0..count)
            .into_par_iter()
            .map(|i| {
                let (x, y, z) = (
                    i as i32 % dims.x,
                    (i as i32 / dims.x) % dims.y,
                    i as i32 / (dims.x * dims.y),
                );
                let min = ((first + IVec3::new(x, y, z)) * CELL).as_vec3();
                let cell = IndexBox::new(min - p, min + Vec3::splat(CELL as f32) + p);
                field.range_over(&cell)
            })
            .collect();
        Some(PaddedCells {
            key: key_of(field),
            bounds: b,
            pad,
            first,
            dims,
            ranges,
        })
    }

    /// Whether the table is `field`'s (its address and bounds), grown by at least `pad`.
    pub fn serves(&self, field: &dyn Field, pad: DVec3) -> bool {
        self.key == key_of(field)
            && self.bounds == field.active_bounds()
            && pad.cmple(self.pad).all()
    }

    /// The cell holding voxel `ijk`, with its grown range (zero outside the grown
    /// bounds: nothing moves there).
    pub fn cell_at(&self, ijk: IVec3) -> Cell {
        let c = IVec3::new(
            ijk.x.div_euclid(CELL),
            ijk.y.div_euclid(CELL),
            ijk.z.div_euclid(CELL),
        );
        let r = c - self.first;
        let range = if r.cmpge(IVec3::ZERO).all() && r.cmplt(self.dims).all() {
            let i = r.x as usize
                + self.dims.x as usize * (r.y as usize + self.dims.y as usize * r.z as usize);
            self.ranges[i]
        } else {
            ValueRange::ZERO
        };
        Cell {
            origin: c * CELL,
            size: CELL,
            range,
        }
    }
}

/// Tables of the fields a moving volume is marched through (its density, its
/// traversal), each built the first time a ray asks for it.
#[derive(Default)]
pub struct CellCache {
    /// The field's address, and its table (`None`: too large to hold).
    slots: [OnceLock<(usize, Option<PaddedCells>)>; 4],
}

impl CellCache {
    /// The table of `field` grown by the shutter's pad `pad`, built on first use (`None`:
    /// too large, or the cache is full of other fields').
    pub fn table(&self, field: &dyn Field, pad: DVec3) -> Option<&PaddedCells> {
        let key = key_of(field);
        for slot in &self.slots {
            let (k, t) = slot.get_or_init(|| (key, PaddedCells::build(field, pad)));
            if *k == key {
                return t.as_ref().filter(|t| t.serves(field, pad));
            }
        }
        None
    }
}

/// A field bounded as it could be anywhere within `pad` (local index units, per axis) of
/// where it is: its value ranges, cells' ranges and bounds are the field's over the box
/// grown by `pad`, its values its own. What bounds a volume that moves up to that far
/// within the shutter, at every time at once (the path tracer's majorants).
pub struct Grown {
    inner: std::sync::Arc<dyn Field>,
    pad: DVec3,
}

impl Grown {
    pub fn new(inner: std::sync::Arc<dyn Field>, pad: DVec3) -> Self {
        Grown { inner, pad }
    }

    fn grown(&self, b: &IndexBox) -> IndexBox {
        if b.is_empty() {
            return *b;
        }
        let p = self.pad.as_vec3();
        IndexBox::new(b.min - p, b.max + p)
    }
}

impl Field for Grown {
    fn value_at_index(&self, p: DVec3) -> f32 {
        self.inner.value_at_index(p)
    }

    fn transform(&self) -> &super::IndexToWorld {
        self.inner.transform()
    }

    fn active_bounds(&self) -> IndexBox {
        self.grown(&self.inner.active_bounds())
    }

    fn cell_at(&self, ijk: IVec3) -> Cell {
        let c = self.inner.cell_at(ijk);
        let min = c.origin.as_vec3();
        let cell = IndexBox::new(min, min + Vec3::splat(c.size as f32));
        Cell {
            range: self.inner.range_over(&self.grown(&cell)),
            ..c
        }
    }

    fn range_over(&self, b: &IndexBox) -> ValueRange {
        self.inner.range_over(&self.grown(b))
    }

    fn tight_range_over(&self, b: &IndexBox) -> ValueRange {
        self.inner.tight_range_over(&self.grown(b))
    }

    fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(self)
    }
}
