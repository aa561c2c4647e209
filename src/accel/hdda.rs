//! Hierarchical DDA over [`Field::cell_at`].
//!
//! A ray is carried into the field's local index space but keeps its world-distance
//! parameter `t`, so optical depth is `σ·ρ·dt` whatever the transform. A ray that misses
//! the field's active bounds costs one box test. Inside, each step asks the field for
//! the coarsest cell containing the current point (a 4096³ root gap, a 128³ or 8³ tile,
//! or an 8³ leaf) and jumps to that cell's exit: empty cells are skipped at every level.

use crate::field::{Field, IndexBox, IndexRay, ValueRange};
use glam::IVec3;

/// The parameter interval `[t0, t1]` (within `[t_min, t_max]`) where the ray is inside
/// `b`, or `None`. Direction components of +0 and −0 are handled: the ray is then inside
/// that slab everywhere or nowhere.
pub fn clip_to_box(ray: &IndexRay, b: &IndexBox, t_min: f64, t_max: f64) -> Option<(f64, f64)> {
    if b.is_empty() {
        return None;
    }
    let (mut t0, mut t1) = (t_min, t_max);
    let lo = b.min.as_dvec3();
    let hi = b.max.as_dvec3();
    for a in 0..3 {
        let (o, d) = (ray.origin[a], ray.dir[a]);
        if d == 0.0 {
            if o < lo[a] || o > hi[a] {
                return None;
            }
            continue;
        }
        let inv = 1.0 / d;
        let (mut ta, mut tb) = ((lo[a] - o) * inv, (hi[a] - o) * inv);
        if ta > tb {
            std::mem::swap(&mut ta, &mut tb);
        }
        t0 = t0.max(ta);
        t1 = t1.min(tb);
        if t0 > t1 {
            return None;
        }
    }
    (t0 < t1 && t0.is_finite() && t1.is_finite()).then_some((t0, t1))
}

/// A stretch `[t0, t1]` of the ray inside one cell, with the field's range there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Span {
    pub t0: f64,
    pub t1: f64,
    pub range: ValueRange,
    /// Edge of the cell in voxels (1, 8, 128, 4096).
    pub cell_size: i32,
}

/// Iterator over the non-empty spans of a ray through a field, front to back.
pub struct Spans<'a> {
    field: &'a dyn Field,
    ray: IndexRay,
    t: f64,
    t_end: f64,
    /// Smallest progress per cell (guards against a stuck traversal on rounding).
    min_step: f64,
    budget: u32,
}

/// Cells visited per ray at most (a ray crossing 2^20 cells is far beyond any real grid).
const MAX_CELLS: u32 = 1 << 20;

impl<'a> Spans<'a> {
    /// Spans of `ray` within `[t_min, t_max]` and the field's active bounds.
    pub fn new(field: &'a dyn Field, ray: IndexRay, t_min: f64, t_max: f64) -> Self {
        let (t, t_end) =
            clip_to_box(&ray, &field.active_bounds(), t_min, t_max).unwrap_or((0.0, 0.0));
        let speed = ray.index_speed().max(1e-300);
        let scale = ray.origin.abs().max_element().max(1.0);
        Spans {
            field,
            ray,
            t,
            t_end,
            min_step: 1e-9 * scale / speed,
            budget: MAX_CELLS,
        }
    }

    /// The voxel containing the ray just after `t`: on a face, the cell the ray is
    /// entering (floor for increasing components, ceil−1 for decreasing ones).
    fn voxel_ahead(&self, t: f64) -> IVec3 {
        let p = self.ray.at(t);
        let pick = |p: f64, d: f64| if d < 0.0 { p.ceil() - 1.0 } else { p.floor() };
        let lim = (1i64 << 30) as f64;
        let c = |p: f64, d: f64| pick(p, d).clamp(-lim, lim) as i32;
        IVec3::new(
            c(p.x, self.ray.dir.x),
            c(p.y, self.ray.dir.y),
            c(p.z, self.ray.dir.z),
        )
    }

    fn cell_exit(&self, origin: IVec3, size: i32) -> f64 {
        let mut t_exit = f64::INFINITY;
        for a in 0..3 {
            let d = self.ray.dir[a];
            if d == 0.0 {
                continue;
            }
            let face = if d > 0.0 {
                (origin[a] as f64) + size as f64
            } else {
                origin[a] as f64
            };
            t_exit = t_exit.min((face - self.ray.origin[a]) / d);
        }
        t_exit
    }
}

impl Iterator for Spans<'_> {
    type Item = Span;

    fn next(&mut self) -> Option<Span> {
        while self.t < self.t_end && self.budget > 0 {
            self.budget -= 1;
            let cell = self.field.cell_at(self.voxel_ahead(self.t));
            let exit = self.cell_exit(cell.origin, cell.size);
            let t1 = if exit.is_nan() {
                self.t_end
            } else {
                exit.max(self.t + self.min_step).min(self.t_end)
            };
            let t0 = self.t;
            self.t = t1;
            if !cell.range.is_zero() {
                return Some(Span {
                    t0,
                    t1,
                    range: cell.range,
                    cell_size: cell.size,
                });
            }
        }
        None
    }
}
