//! Fields seen at another time: a velocity field, and [`Advected`], which looks a field up
//! at the point the velocity carried there (Eulerian motion blur, as Cycles, Arnold and
//! RenderMan blur a volume from its velocity grid).
//!
//! A cache stores the fields at the frame's time and a velocity `u` (world units per
//! unit of time). At a time offset `Δt` the field at `x` is the stored one at the point
//! `x′` the flow brings to `x`, found by two steps of backward advection (Kim & Ko 2007;
//! Wrenninge, *Production Volume Rendering*, 2012):
//!
//! ```text
//! v₀ = u(x),   x₁ = x − Δt·v₀,   x′ = x − Δt·u(x₁)
//! ```
//!
//! exact for a uniform velocity, second order where it varies. `x′` lies within
//! `|Δt|·max|u|` of `x`, so the advected field's bounds and the value ranges of its
//! cells are the stored field's over the cell grown by that distance: nothing that
//! moves into empty space is skipped.

use super::padded_cells::PaddedCells;
pub use super::velocity::{ConstantVelocity, GridVelocity, RayFlow, VelocityField};
use super::{Cell, ColorField, Field, IndexBox, IndexRay, IndexToWorld, ValueRange};
use glam::{DVec3, IVec3, Vec3};

/// How far (voxels) the displacement may stray from the line between a batch's ends
/// for [`Advected::piece_integrals`] to interpolate it.
const LINEAR_DISPLACEMENT: f64 = 1e-3;

/// The finest cell an advected field reports where its stored field's coarse cell is
/// empty but something moves into it.
const FINE_CELL: i32 = 8;

/// `inner` at a time offset: looked up at the point advected back by `shift` (the time
/// offset times the velocity's scale, so `shift·u` is a displacement in world units).
pub struct Advected<'a> {
    inner: &'a dyn Field,
    velocity: &'a dyn VelocityField,
    shift: f64,
    /// The displacement along the one ray this field is marched on, shared with the
    /// ray's other fields (`None`: every lookup advects on its own).
    flow: Option<&'a RayFlow<'a>>,
    /// The ranges of the stored field's cells grown by the shutter's farthest
    /// displacement, computed once for every time (`None`: asked for cell by cell).
    cells: Option<&'a PaddedCells>,
    /// How far (local index units, per axis) a lookup can move.
    pad: DVec3,
}

impl<'a> Advected<'a> {
    /// `inner` seen `shift` time units from its own time (negative: earlier).
    pub fn new(inner: &'a dyn Field, velocity: &'a dyn VelocityField, shift: f64) -> Self {
        let pad = index_pad(inner.transform(), shift.abs() * velocity.max_speed());
        Advected {
            inner,
            velocity,
            shift,
            flow: None,
            cells: None,
            pad,
        }
    }

    /// With its cells' ranges read from `table` where it is the stored field's, grown at
    /// least as far as this time's displacement reaches.
    pub fn with_cells(mut self, table: Option<&'a PaddedCells>) -> Self {
        self.cells = table.filter(|t| t.serves(self.inner, self.pad));
        self
    }

    /// With the displacement of points on `flow`'s ray read from it (the flow's
    /// velocity and shift must be this field's).
    pub fn along(mut self, flow: &'a RayFlow<'a>) -> Self {
        self.flow = Some(flow);
        self
    }

    /// How far (local index units) the flow carried what is at local index point `p`:
    /// the stored field is looked up at `p` minus this.
    #[inline]
    pub fn displacement(&self, p: DVec3) -> DVec3 {
        flow_displacement(
            self.flow,
            self.inner.transform(),
            self.velocity,
            self.shift,
            p,
        )
    }

    /// [`Field::piece_integrals`] along `flow`'s ray (`false`, untouched, where `ray` is
    /// not it): between two of its knots the displacement is linear in `t`, `D(t) = A +
    /// G·t`, so the stored field is integrated along the straight ray `origin − A` with
    /// direction `dir − G` — exactly the advected field's integral, in one walk of the
    /// stored field for every piece between the two knots (pieces across a knot split
    /// there).
    fn flow_walk(
        &self,
        flow: &RayFlow,
        ray: &IndexRay,
        t0: f64,
        ends: &[f64],
        out: &mut [f64],
    ) -> bool {
        /// Pieces (split at knots) walked at once.
        const SUB: usize = 96;
        let tr = self.inner.transform();
        let t1 = ends.last().copied().unwrap_or(t0);
        let on = |t: f64| {
            flow.param_of(tr.index_to_world(ray.at(t)))
                .is_some_and(|u| (u - t).abs() <= 1e-9 * (1.0 + t.abs()))
        };
        if ends.len() > out.len() || !(t1 >= t0) || !on(t0) || !on(t1) {
            return false;
        }
        let index = |d: DVec3| tr.world_dir_to_index(d);
        let s = flow.spacing();
        if !(s.is_finite() && s > 0.0) {
            // A uniform flow: one displacement for the whole batch.
            let d = index(flow.knot_displacement(0));
            if !d.is_finite() {
                return false;
            }
            let moved = IndexRay {
                origin: ray.origin - d,
                dir: ray.dir,
            };
            self.inner.piece_integrals(&moved, t0, ends, out);
            return true;
        }
        if !((t1 - t0) / s < 256.0) || !((t0 / s).abs() < 1e15) {
            return false;
        }
        let (mut sub_ends, mut sub_out, mut owner) = ([0.0; SUB], [0.0; SUB], [0usize; SUB]);
        out[..ends.len()].fill(0.0);
        let mut k = (t0 / s).floor() as i64;
        let (mut a, mut i) = (t0, 0);
        while i < ends.len() {
            let knot_end = (k + 1) as f64 * s;
            let start = a;
            let mut n = 0;
            let mut crossed = false;
            while i < ends.len() && n < SUB {
                let b = ends[i];
                owner[n] = i;
                if b <= knot_end {
                    sub_ends[n] = b;
                    i += 1;
                    a = b;
                    n += 1;
                } else {
                    sub_ends[n] = knot_end;
                    a = knot_end;
                    n += 1;
                    crossed = true;
                    break;
                }
            }
            let (d0, d1) = (
                index(flow.knot_displacement(k)),
                index(flow.knot_displacement(k + 1)),
            );
            let g = (d1 - d0) / s;
            let base = d0 - g * (k as f64 * s);
            if !(g.is_finite() && base.is_finite()) {
                return false;
            }
            let sheared = IndexRay {
                origin: ray.origin - base,
                dir: ray.dir - g,
            };
            self.inner
                .piece_integrals(&sheared, start, &sub_ends[..n], &mut sub_out[..n]);
            for j in 0..n {
                out[owner[j]] += sub_out[j];
            }
            if crossed {
                k += 1;
            }
        }
        true
    }

    fn grown(&self, b: &IndexBox) -> IndexBox {
        let pad = self.pad.as_vec3();
        IndexBox::new(b.min - pad, b.max + pad)
    }
}

/// Two-step backward advection in the index space of `tr`: the index displacement
/// `x − x′` of the point at local index `p` over `shift` time units.
#[inline]
fn displacement(tr: &IndexToWorld, velocity: &dyn VelocityField, shift: f64, p: DVec3) -> DVec3 {
    if shift == 0.0 {
        return DVec3::ZERO;
    }
    let x = tr.index_to_world(p);
    let v0 = velocity.velocity_at_world(x);
    let v1 = velocity.velocity_at_world(x - v0 * shift);
    let d = tr.world_dir_to_index(v1 * shift);
    if d.is_finite() { d } else { DVec3::ZERO }
}

/// [`displacement`], read from `flow` where `p` lies on its ray.
#[inline]
fn flow_displacement(
    flow: Option<&RayFlow>,
    tr: &IndexToWorld,
    velocity: &dyn VelocityField,
    shift: f64,
    p: DVec3,
) -> DVec3 {
    if let Some(d) = flow.and_then(|f| f.displacement_at(tr.index_to_world(p))) {
        let d = tr.world_dir_to_index(d);
        if d.is_finite() {
            return d;
        }
    }
    displacement(tr, velocity, shift, p)
}

/// A colour field seen at another time, as [`Advected`] sees a scalar one.
pub struct AdvectedColor<'a> {
    pub inner: &'a dyn ColorField,
    pub velocity: &'a dyn VelocityField,
    pub shift: f64,
    /// As [`Advected`]'s.
    pub flow: Option<&'a RayFlow<'a>>,
}

impl ColorField for AdvectedColor<'_> {
    fn transform(&self) -> &IndexToWorld {
        self.inner.transform()
    }
    fn color_at_index(&self, p: DVec3) -> Vec3 {
        let d = flow_displacement(
            self.flow,
            self.inner.transform(),
            self.velocity,
            self.shift,
            p,
        );
        self.inner.color_at_index(p - d)
    }
}

/// The local-index extent, per axis, of a world displacement of length up to `distance`
/// (rounded up, plus one voxel for the interpolation's reach).
pub fn index_pad(tr: &IndexToWorld, distance: f64) -> DVec3 {
    if !(distance > 0.0) {
        return DVec3::ZERO;
    }
    let m = tr.inverse_linear();
    // Row i of the world→index map: |Σ_j m_ij d_j| ≤ |row_i|·|d|.
    let t = m.transpose();
    let d = distance.min(1e12);
    DVec3::new(
        (t.x_axis.length() * d).ceil() + 1.0,
        (t.y_axis.length() * d).ceil() + 1.0,
        (t.z_axis.length() * d).ceil() + 1.0,
    )
}

impl Field for Advected<'_> {
    fn value_at_index(&self, p: DVec3) -> f32 {
        self.inner.value_at_index(p - self.displacement(p))
    }

    /// The stored field's integral along the ray moved back by the displacement at the
    /// interval's midpoint: exact (as the stored field's is) where the flow is uniform
    /// over the interval, which the march keeps to half a voxel.
    fn integral(&self, ray: &IndexRay, t0: f64, t1: f64) -> f64 {
        let moved = IndexRay {
            origin: ray.origin - self.displacement(ray.at(0.5 * (t0 + t1))),
            dir: ray.dir,
        };
        self.inner.integral(&moved, t0, t1)
    }

    /// The pieces' integrals with the displacement interpolated linearly along the batch
    /// where the flow allows it: the displacement at the batch's ends and at its
    /// quarters is looked up, and where the middle three are within
    /// [`LINEAR_DISPLACEMENT`] voxel of the line between the ends, each piece's is read
    /// from that line (a uniform flow: one walk of the stored field for all the pieces).
    /// Elsewhere each piece looks its own up, as [`Field::integral`].
    fn piece_integrals(&self, ray: &IndexRay, t0: f64, ends: &[f64], out: &mut [f64]) {
        if let Some(flow) = self.flow
            && self.flow_walk(flow, ray, t0, ends, out)
        {
            return;
        }
        let t1 = ends.last().copied().unwrap_or(t0);
        let at = |u: f64| self.displacement(ray.at(t0 + (t1 - t0) * u));
        let (d0, d1) = (at(0.0), at(1.0));
        let linear = ends.len() >= 4
            && t1 > t0
            && [0.25, 0.5, 0.75]
                .iter()
                .all(|&u| (at(u) - d0.lerp(d1, u)).abs().max_element() <= LINEAR_DISPLACEMENT);
        if !linear {
            let mut a = t0;
            for (&b, o) in ends.iter().zip(out.iter_mut()) {
                *o = self.integral(ray, a, b);
                a = b;
            }
            return;
        }
        if d0 == d1 {
            let moved = IndexRay {
                origin: ray.origin - d0,
                dir: ray.dir,
            };
            self.inner.piece_integrals(&moved, t0, ends, out);
            return;
        }
        let mut a = t0;
        for (&b, o) in ends.iter().zip(out.iter_mut()) {
            let d = d0.lerp(d1, (0.5 * (a + b) - t0) / (t1 - t0));
            let moved = IndexRay {
                origin: ray.origin - d,
                dir: ray.dir,
            };
            *o = self.inner.integral(&moved, a, b);
            a = b;
        }
    }

    fn transform(&self) -> &IndexToWorld {
        self.inner.transform()
    }

    fn active_bounds(&self) -> IndexBox {
        let b = self.inner.active_bounds();
        if b.is_empty() { b } else { self.grown(&b) }
    }

    fn cell_at(&self, ijk: IVec3) -> Cell {
        if self.pad == DVec3::ZERO {
            return self.inner.cell_at(ijk);
        }
        if let Some(t) = self.cells {
            return t.cell_at(ijk);
        }
        let cell_box = |origin: IVec3, size: i32| {
            let min = origin.as_vec3();
            IndexBox::new(min, min + Vec3::splat(size as f32))
        };
        let c = self.inner.cell_at(ijk);
        let range = self
            .inner
            .range_over(&self.grown(&cell_box(c.origin, c.size)));
        if c.size <= FINE_CELL || range.is_zero() {
            return Cell { range, ..c };
        }
        // A coarse cell something moves into: report its fine cell at `ijk` alone.
        let origin = IVec3::new(
            ijk.x.div_euclid(FINE_CELL),
            ijk.y.div_euclid(FINE_CELL),
            ijk.z.div_euclid(FINE_CELL),
        ) * FINE_CELL;
        Cell {
            origin,
            size: FINE_CELL,
            range: self
                .inner
                .range_over(&self.grown(&cell_box(origin, FINE_CELL))),
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

#[cfg(test)]
#[path = "advect_tests.rs"]
mod tests;
