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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::grid_build::GridBuilder;
    use crate::field::{Field, VoxelGrid};
    use crate::vdb::TreeSink;
    use glam::{DMat4, DVec3, IVec3};

    /// A grid with leaves, an 8³ tile, a 128³ tile and empty space between, far from
    /// the index origin.
    fn test_grid() -> VoxelGrid {
        let mut b = GridBuilder::new();
        b.begin(1, &[0.0]).unwrap();
        let base = IVec3::new(100_096, -50_048, 256);
        let mut vals = vec![0f32; 512];
        for (i, v) in vals.iter_mut().enumerate() {
            *v = ((i * 37) % 11) as f32 * 0.1;
        }
        let mask = [u64::MAX; 8];
        for o in [
            IVec3::ZERO,
            IVec3::new(8, 0, 0),
            IVec3::new(40, 16, 8),
            IVec3::new(0, 64, 120),
        ] {
            b.leaf(base + o, &vals, &mask).unwrap();
        }
        b.tile(base + IVec3::new(16, 0, 0), 8, &[0.5], true)
            .unwrap();
        b.tile(base + IVec3::new(128, 0, 0), 128, &[0.25], true)
            .unwrap();
        b.finish("t", DMat4::from_scale(DVec3::new(0.1, 0.2, 0.1)))
            .unwrap()
    }

    fn rng(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Every point where the field is non-zero lies in a span, and the span's range
    /// bounds the value there: for random rays, including axis-parallel ones (±0
    /// direction components) and rays along voxel faces.
    #[test]
    fn spans_cover_the_field_and_bound_it() {
        let g = test_grid();
        let b = g.active_bounds();
        let mut s = 7u64;
        let mut dirs: Vec<DVec3> = vec![
            DVec3::X,
            DVec3::NEG_X,
            DVec3::Y,
            DVec3::NEG_Z,
            DVec3::new(-0.0, 0.0, 1.0),
        ];
        for _ in 0..200 {
            dirs.push(
                DVec3::new(rng(&mut s) - 0.5, rng(&mut s) - 0.5, rng(&mut s) - 0.5).normalize(),
            );
        }
        let mut nonzero_checked = 0;
        for (k, d) in dirs.iter().enumerate() {
            // Origins inside the bounds (on voxel faces for the first rays), and outside.
            let lo = b.min.as_dvec3();
            let ext = b.extent().as_dvec3();
            let mut oi = lo + ext * DVec3::new(rng(&mut s), rng(&mut s), rng(&mut s));
            if k < 5 {
                oi = oi.round();
            }
            let o = g.transform().index_to_world(oi) - *d * 50.0 * (k % 2) as f64;
            let ray = IndexRay::new(&g, o, *d);
            let spans: Vec<Span> = Spans::new(&g, ray, 0.0, 1e3).collect();
            for w in spans.windows(2) {
                assert!(w[0].t1 <= w[1].t0 + 1e-12, "spans out of order");
            }
            for i in 0..4000 {
                let t = i as f64 * 0.25 * 0.05;
                let v = g.value_at_index(ray.at(t));
                let inside = spans
                    .iter()
                    .find(|sp| sp.t0 - 1e-9 <= t && t <= sp.t1 + 1e-9);
                if v > 0.0 {
                    nonzero_checked += 1;
                    let sp = inside.unwrap_or_else(|| {
                        panic!("ray {k}: value {v} at t {t} outside every span")
                    });
                    assert!(
                        v <= sp.range.max + 1e-6 && v >= sp.range.min - 1e-6,
                        "ray {k}: {v} outside {:?}",
                        sp.range
                    );
                }
            }
        }
        assert!(nonzero_checked > 10_000, "{nonzero_checked}");
    }

    /// A ray that misses the bounds yields nothing; one parallel to an axis outside the
    /// slab of the bounds too (a ±0 component must not produce NaN intervals).
    #[test]
    fn misses_and_parallel_rays() {
        let g = test_grid();
        let far = g
            .transform()
            .index_to_world(g.active_bounds().max.as_dvec3() + DVec3::splat(10.0));
        assert_eq!(
            Spans::new(&g, IndexRay::new(&g, far, DVec3::X), 0.0, 1e9).count(),
            0
        );
        assert_eq!(
            Spans::new(
                &g,
                IndexRay::new(&g, far, DVec3::new(0.0, -0.0, 1.0)),
                0.0,
                1e9
            )
            .count(),
            0
        );
        let inside = g.transform().index_to_world(DVec3::ZERO);
        assert!(
            clip_to_box(
                &IndexRay::new(&g, inside, DVec3::new(-0.0, 0.0, 1.0)),
                &g.active_bounds(),
                0.0,
                1e9
            )
            .is_some()
        );
    }
}
