//! Checks the field tests share.

use super::{Cell, Field, ValueRange};
use glam::Vec3;

/// The cell the traversal gets at `p` holds `p`, the field's value there lies in the
/// cell's range, and cells coarser than a leaf are empty. Returns the cell and the value.
pub fn assert_cell_holds(f: &dyn Field, p: Vec3) -> (Cell, f32) {
    let v = f.value_at_index(p.as_dvec3());
    let cell = f.cell_at(p.floor().as_ivec3());
    let (o, s) = (cell.origin.as_vec3(), cell.size as f32);
    assert!(
        p.cmpge(o).all() && p.cmple(o + s).all(),
        "{p} not in {cell:?}"
    );
    assert!(
        cell.range.min <= v && v <= cell.range.max,
        "{p}: {v} outside {cell:?}"
    );
    if cell.size > 8 {
        assert_eq!(cell.range, ValueRange::ZERO);
    }
    (cell, v)
}
