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

use super::{Cell, ColorField, Field, IndexBox, IndexRay, IndexToWorld, ValueRange, VoxelGrid};
use glam::{DVec3, IVec3, Vec3};

/// A velocity at every world point, world units per unit of time.
pub trait VelocityField: Send + Sync {
    fn velocity_at_world(&self, p: DVec3) -> DVec3;
    /// A bound on the speed anywhere.
    fn max_speed(&self) -> f64;
}

/// The same velocity everywhere.
#[derive(Clone, Copy, Debug)]
pub struct ConstantVelocity(pub DVec3);

impl VelocityField for ConstantVelocity {
    fn velocity_at_world(&self, _: DVec3) -> DVec3 {
        self.0
    }
    fn max_speed(&self) -> f64 {
        self.0.length()
    }
}

/// A velocity grid: a vec3 [`VoxelGrid`] (Houdini's `vel`, Blender's `velocity`), or
/// three float grids one per component (`vel.x`, `vel.y`, `vel.z`); trilinear, zero
/// outside the active voxels. A staggered grid (OpenVDB's `staggered` class, as
/// Mantaflow writes its MAC velocity) holds each component on the voxel face below it
/// along its axis, half a voxel from the centre, and is read there.
pub struct GridVelocity {
    /// One vec3 grid, or three float grids x, y, z.
    grids: Vec<VoxelGrid>,
    staggered: bool,
    max_speed: f64,
    /// Speeds above this are clamped to it.
    limit: f64,
}

impl GridVelocity {
    /// A vec3 grid (`None` where it has fewer than three channels).
    pub fn vector(grid: VoxelGrid, staggered: bool) -> Option<Self> {
        if grid.channels() < 3 {
            return None;
        }
        let s = grid.stats();
        let bound = |c: usize| {
            let lo = s.min.get(c).copied().unwrap_or(0.0).abs();
            let hi = s.max.get(c).copied().unwrap_or(0.0).abs();
            lo.max(hi)
        };
        let max_speed = DVec3::new(bound(0), bound(1), bound(2)).length();
        Some(GridVelocity {
            grids: vec![grid],
            staggered,
            max_speed,
            limit: f64::INFINITY,
        })
    }

    /// Three float grids of signed values, x, y, z.
    pub fn channels(xyz: [VoxelGrid; 3], staggered: bool) -> Self {
        let bound = |g: &VoxelGrid| {
            let s = g.stats();
            let lo = s.min.first().copied().unwrap_or(0.0).abs();
            let hi = s.max.first().copied().unwrap_or(0.0).abs();
            lo.max(hi)
        };
        let max_speed = DVec3::new(bound(&xyz[0]), bound(&xyz[1]), bound(&xyz[2])).length();
        GridVelocity {
            grids: xyz.into(),
            staggered,
            max_speed,
            limit: f64::INFINITY,
        }
    }

    /// Speeds above `limit` clamped to it.
    pub fn limited(mut self, limit: f64) -> Self {
        self.limit = limit.max(0.0);
        self
    }

    /// The speed bound before any limit: the largest the file's values allow.
    pub fn file_max_speed(&self) -> f64 {
        self.max_speed
    }
}

impl VelocityField for GridVelocity {
    fn velocity_at_world(&self, p: DVec3) -> DVec3 {
        // Component c of a staggered grid sits half a voxel below the centre along c.
        let half = if self.staggered { 0.5 } else { 0.0 };
        let at = |c: usize, i: DVec3| {
            let mut q = i;
            q[c] += half;
            q
        };
        let v = match &self.grids[..] {
            [g] => {
                let i = Field::transform(g).world_to_index(p);
                let [x, y, z] = g.sample_components([at(0, i), at(1, i), at(2, i)]);
                DVec3::new(x as f64, y as f64, z as f64)
            }
            [x, y, z] => {
                let one = |c: usize, g: &VoxelGrid| {
                    g.sample_channel(at(c, Field::transform(g).world_to_index(p)), 0) as f64
                };
                DVec3::new(one(0, x), one(1, y), one(2, z))
            }
            _ => DVec3::ZERO,
        };
        if self.limit.is_finite() {
            v.clamp_length_max(self.limit)
        } else {
            v
        }
    }
    fn max_speed(&self) -> f64 {
        self.max_speed.min(self.limit)
    }
}

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
            pad,
        }
    }

    /// How far (local index units) the flow carried what is at local index point `p`:
    /// the stored field is looked up at `p` minus this.
    #[inline]
    pub fn displacement(&self, p: DVec3) -> DVec3 {
        displacement(self.inner.transform(), self.velocity, self.shift, p)
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

/// A colour field seen at another time, as [`Advected`] sees a scalar one.
pub struct AdvectedColor<'a> {
    pub inner: &'a dyn ColorField,
    pub velocity: &'a dyn VelocityField,
    pub shift: f64,
}

impl ColorField for AdvectedColor<'_> {
    fn transform(&self) -> &IndexToWorld {
        self.inner.transform()
    }
    fn color_at_index(&self, p: DVec3) -> Vec3 {
        let d = displacement(self.inner.transform(), self.velocity, self.shift, p);
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
mod tests {
    use super::*;
    use crate::field::shapes::ConstantBox;

    fn unit_box() -> ConstantBox {
        ConstantBox::new(DVec3::ZERO, DVec3::ONE, 1.0, 0.05).unwrap()
    }

    #[test]
    fn a_uniform_flow_moves_the_field_by_its_displacement() {
        let b = unit_box();
        let v = ConstantVelocity(DVec3::new(2.0, 0.0, 0.0));
        let moved = Advected::new(&b, &v, 0.25); // 0.5 world units along +x
        for x in [0.45, 0.55, 1.2, 1.45, 1.55] {
            let p = DVec3::new(x, 0.5, 0.5);
            let want = b.value_at_world(p - DVec3::new(0.5, 0.0, 0.0));
            assert_eq!(moved.value_at_world(p), want, "x {x}");
        }
    }

    #[test]
    fn bounds_and_cells_cover_where_the_field_moves() {
        let b = unit_box();
        let v = ConstantVelocity(DVec3::new(0.0, -4.0, 0.0));
        let moved = Advected::new(&b, &v, 0.5); // 2 world units along −y
        let p = DVec3::new(0.5, -1.5, 0.5);
        assert_eq!(moved.value_at_world(p), 1.0);
        let i = moved.transform().world_to_index(p);
        assert!(moved.active_bounds().contains(i.as_vec3()));
        let cell = moved.cell_at(i.floor().as_ivec3());
        assert!(cell.range.max >= 1.0, "{cell:?}");
    }

    /// A shear: v = (0, x, 0), so the displacement along a ray across x is linear.
    struct Shear;
    impl VelocityField for Shear {
        fn velocity_at_world(&self, p: DVec3) -> DVec3 {
            DVec3::new(0.0, p.x, 0.0)
        }
        fn max_speed(&self) -> f64 {
            10.0
        }
    }

    #[test]
    fn a_batch_of_pieces_follows_a_linearly_varying_displacement() {
        let b = unit_box();
        let moved = Advected::new(&b, &Shear, 0.3);
        let ray = IndexRay::new(&moved, DVec3::new(-0.5, 0.3, 0.5), DVec3::X);
        let ends: Vec<f64> = (1..=12).map(|k| 0.2 * k as f64).collect();
        let mut batch = vec![0.0; ends.len()];
        moved.piece_integrals(&ray, 0.0, &ends, &mut batch);
        let mut a = 0.0;
        for (&e, got) in ends.iter().zip(&batch) {
            let want = moved.integral(&ray, a, e);
            assert!((got - want).abs() < 1e-12, "[{a}, {e}]: {got} vs {want}");
            a = e;
        }
        // The ray meets the sheared box (y − 0.3·x in [0, 1] for x up to 1).
        assert!(batch.iter().sum::<f64>() > 0.5);
    }

    #[test]
    fn no_shift_is_the_field_itself() {
        let b = unit_box();
        let v = ConstantVelocity(DVec3::new(3.0, 1.0, 0.0));
        let still = Advected::new(&b, &v, 0.0);
        assert_eq!(still.active_bounds(), b.active_bounds());
        let p = DVec3::new(0.99, 0.2, 0.7);
        assert_eq!(still.value_at_world(p), b.value_at_world(p));
    }
}
