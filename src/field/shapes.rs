//! Analytic fields with closed-form answers: a constant-density box and sphere.
//!
//! Both live on a *virtual* voxel grid — `IndexToWorld::uniform(voxel_size,
//! IVec3::ZERO)`, so local index = world / voxel size — which gives the traversal
//! cells to step through, but their value is the **exact indicator** of the shape
//! (`ρ` inside, `0` outside, a hard edge, no trilinear blur). A ray's optical depth
//! through them is therefore `σt · ρ · chord` with the chord from
//! [`ConstantBox::chord_length`] / [`ConstantSphere::chord_length`], which is what the
//! integrator's closed-form tests need.
//!
//! Boundaries are closed: a point exactly on the surface is inside. Inside/outside tests
//! and the cell classification are both done in index space on the same f64 numbers,
//! so a cell reported as entirely outside (inside) never contains a point whose value
//! is `ρ` (`0`).
//!
//! Precision note: local index space has its origin at world 0, so shapes far from the
//! world origin (index coordinates beyond ~1e6) lose f32 precision in
//! [`Field::value_at_index`].

use super::{Cell, Field, IndexBox, IndexRay, IndexToWorld, ValueRange};
use glam::{DVec3, IVec3, Vec3};

/// Cell sizes (in voxels) of the virtual hierarchy of the analytic fields, coarsest
/// first, like an OpenVDB tree (root tile 4096, internal node 128, leaf 8).
pub const VIRTUAL_CELL_SIZES: [i32; 3] = [4096, 128, 8];

/// The cell of the virtual hierarchy containing `ijk`: the coarsest aligned cell of
/// [`VIRTUAL_CELL_SIZES`] over which `range_of_box` reports a zero range, otherwise the
/// 8³ leaf cell with its range. Cells are aligned with an arithmetic shift
/// (`origin = (ijk >> log2 size) << log2 size`, which rounds towards −∞ for negative
/// indices as well).
///
/// `range_of_box(lo, hi)` must return a conservative range of the field over the closed
/// local-index box `[lo, hi]` (the cell `[origin, origin + size]`, which includes the
/// +1 voxel layer a trilinear stencil would reach).
pub fn virtual_cell(ijk: IVec3, range_of_box: impl Fn(DVec3, DVec3) -> ValueRange) -> Cell {
    let leaf = VIRTUAL_CELL_SIZES[VIRTUAL_CELL_SIZES.len() - 1];
    for &size in &VIRTUAL_CELL_SIZES[..VIRTUAL_CELL_SIZES.len() - 1] {
        let (origin, lo, hi) = aligned_cell(ijk, size);
        if range_of_box(lo, hi).is_zero() {
            return Cell {
                origin,
                size,
                range: ValueRange::ZERO,
            };
        }
    }
    let (origin, lo, hi) = aligned_cell(ijk, leaf);
    Cell {
        origin,
        size: leaf,
        range: range_of_box(lo, hi),
    }
}

/// Origin and closed box `[origin, origin + size]` (f64, no i32 overflow) of the
/// `size`-aligned cell containing `ijk`. `size` must be a power of two.
fn aligned_cell(ijk: IVec3, size: i32) -> (IVec3, DVec3, DVec3) {
    let shift = size.trailing_zeros() as i32;
    let origin = (ijk >> shift) << shift;
    let lo = origin.as_dvec3();
    (origin, lo, lo + DVec3::splat(size as f64))
}

/// Converts an f64 index box to an [`IndexBox`], rounding outward so that the f32 box
/// contains the f64 one.
pub(crate) fn index_box_outward(lo: DVec3, hi: DVec3) -> IndexBox {
    let down = |x: f64| {
        let v = x as f32;
        if (v as f64) > x { v.next_down() } else { v }
    };
    let up = |x: f64| {
        let v = x as f32;
        if (v as f64) < x { v.next_up() } else { v }
    };
    IndexBox::new(
        Vec3::new(down(lo.x), down(lo.y), down(lo.z)),
        Vec3::new(up(hi.x), up(hi.y), up(hi.z)),
    )
}

/// `[min(0, ρ), max(0, ρ)]`: the range over a region that straddles the surface.
fn straddle(density: f32) -> ValueRange {
    ValueRange {
        min: density.min(0.0),
        max: density.max(0.0),
    }
}

/// The parametric interval `[t0, t1]` (possibly with `t0 < 0`) over which the ray
/// `o + t·d` is inside the closed box `[lo, hi]`, by the slab method; `None` if it
/// misses. Axis-parallel rays on a slab boundary count as inside.
fn ray_box(o: DVec3, d: DVec3, lo: DVec3, hi: DVec3) -> Option<(f64, f64)> {
    let mut t0 = f64::NEG_INFINITY;
    let mut t1 = f64::INFINITY;
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a] < lo[a] || o[a] > hi[a] {
                return None;
            }
        } else {
            let inv = 1.0 / d[a];
            let (mut ta, mut tb) = ((lo[a] - o[a]) * inv, (hi[a] - o[a]) * inv);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            t0 = t0.max(ta);
            t1 = t1.min(tb);
        }
    }
    if t0 <= t1 { Some((t0, t1)) } else { None }
}

/// Length (world units) of `o + t·d, t ∈ [t_min, t_max]` inside a parametric interval.
fn clipped_length(interval: Option<(f64, f64)>, d: DVec3, t_min: f64, t_max: f64) -> f64 {
    match interval {
        Some((a, b)) => {
            let (a, b) = (a.max(t_min), b.min(t_max));
            if b > a { (b - a) * d.length() } else { 0.0 }
        }
        None => 0.0,
    }
}

/// Constant density `ρ` inside a world-space axis-aligned box, 0 outside.
#[derive(Clone, Debug)]
pub struct ConstantBox {
    /// World-space corners.
    min: DVec3,
    max: DVec3,
    density: f32,
    transform: IndexToWorld,
    /// The box in local index space (world / voxel size).
    index_min: DVec3,
    index_max: DVec3,
}

impl ConstantBox {
    /// A box with world corners `a`, `b` (in any order), density `density`, on a virtual
    /// grid of voxel size `voxel_size`. `None` if any input is non-finite or
    /// `voxel_size ≤ 0`.
    pub fn new(a: DVec3, b: DVec3, density: f32, voxel_size: f64) -> Option<Self> {
        if !(a.is_finite()
            && b.is_finite()
            && density.is_finite()
            && voxel_size.is_finite()
            && voxel_size > 0.0)
        {
            return None;
        }
        let transform = IndexToWorld::new(
            glam::DMat4::from_scale(DVec3::splat(voxel_size)),
            IVec3::ZERO,
        )?;
        let (min, max) = (a.min(b), a.max(b));
        let index_min = transform.world_to_index(min);
        let index_max = transform.world_to_index(max);
        if !(index_min.is_finite() && index_max.is_finite()) {
            return None;
        }
        Some(ConstantBox {
            min,
            max,
            density,
            transform,
            index_min,
            index_max,
        })
    }

    /// World-space corners `(min, max)`.
    pub fn world_box(&self) -> (DVec3, DVec3) {
        (self.min, self.max)
    }

    /// The density `ρ` inside.
    pub fn density(&self) -> f32 {
        self.density
    }

    /// The parametric interval `[t0, t1]` over which the world ray `o + t·d` is inside
    /// the box (`t0` may be negative), or `None`.
    pub fn ray_interval(&self, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
        ray_box(o, d, self.min, self.max)
    }

    /// World length of the part of the segment `o + t·d, t ∈ [t_min, t_max]` inside the
    /// box (`d` need not be normalised). The optical depth along it is
    /// `σt · ρ · chord_length`.
    pub fn chord_length(&self, o: DVec3, d: DVec3, t_min: f64, t_max: f64) -> f64 {
        clipped_length(self.ray_interval(o, d), d, t_min, t_max)
    }
}

/// [`Field::range_over`] for a field that knows its range over any closed box.
pub fn range_over_box(
    b: &IndexBox,
    range_of_box: impl Fn(DVec3, DVec3) -> ValueRange,
) -> ValueRange {
    if b.is_empty() {
        return ValueRange::ZERO;
    }
    range_of_box(b.min.as_dvec3(), b.max.as_dvec3())
}

/// `∫ρ dt` along a local-index ray over `[t0, t1]` for a constant-density shape, from
/// the world length of its chord (`chord(o, d, t0, t1)` for the world ray `o + t·d`).
fn chord_integral(
    transform: &IndexToWorld,
    density: f32,
    ray: &IndexRay,
    t0: f64,
    t1: f64,
    chord: impl Fn(DVec3, DVec3, f64, f64) -> f64,
) -> f64 {
    let (o, d) = (
        transform.index_to_world(ray.origin),
        transform.linear() * ray.dir,
    );
    density as f64 * chord(o, d, t0, t1) / d.length().max(f64::MIN_POSITIVE)
}

/// Constant density `ρ` inside a world-space ball, 0 outside.
#[derive(Clone, Debug)]
pub struct ConstantSphere {
    center: DVec3,
    radius: f64,
    density: f32,
    transform: IndexToWorld,
    /// Centre and radius in local index space (world / voxel size).
    index_center: DVec3,
    index_radius: f64,
}

impl ConstantSphere {
    /// A ball of world centre `center` and radius `radius ≥ 0`, density `density`, on a
    /// virtual grid of voxel size `voxel_size`. `None` if any input is non-finite,
    /// `radius < 0` or `voxel_size ≤ 0`.
    pub fn new(center: DVec3, radius: f64, density: f32, voxel_size: f64) -> Option<Self> {
        if !(center.is_finite()
            && radius.is_finite()
            && radius >= 0.0
            && density.is_finite()
            && voxel_size.is_finite()
            && voxel_size > 0.0)
        {
            return None;
        }
        let transform = IndexToWorld::new(
            glam::DMat4::from_scale(DVec3::splat(voxel_size)),
            IVec3::ZERO,
        )?;
        let index_center = transform.world_to_index(center);
        let index_radius = radius / voxel_size;
        if !(index_center.is_finite() && index_radius.is_finite()) {
            return None;
        }
        Some(ConstantSphere {
            center,
            radius,
            density,
            transform,
            index_center,
            index_radius,
        })
    }

    /// World-space centre.
    pub fn center(&self) -> DVec3 {
        self.center
    }

    /// World-space radius.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// The density `ρ` inside.
    pub fn density(&self) -> f32 {
        self.density
    }

    /// The parametric interval `[t0, t1]` over which the world ray `o + t·d` is inside
    /// the ball (`t0` may be negative), or `None`. Solved with the numerically stable
    /// form of the quadratic (no cancellation for distant origins).
    pub fn ray_interval(&self, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
        let a = d.length_squared();
        if a == 0.0 {
            return None;
        }
        let f = o - self.center;
        // t² a + 2 t b' + c = 0 with b' = f·d; discriminant from the projected distance
        // (Hearn–Baker / Ray Tracing Gems ch. 7) to avoid cancellation.
        let b = f.dot(d);
        let perp = f - d * (b / a);
        let disc = a * (self.radius * self.radius - perp.length_squared());
        if disc < 0.0 {
            return None;
        }
        let c = f.length_squared() - self.radius * self.radius;
        let q = -(b + b.signum() * disc.sqrt());
        if q == 0.0 {
            // Origin at the centre with b = 0, or a tangent through the centre (r = 0).
            let h = (disc.sqrt()) / a;
            return Some((-h, h));
        }
        let (t0, t1) = (c / q, q / a);
        Some((t0.min(t1), t0.max(t1)))
    }

    /// World length of the part of the segment `o + t·d, t ∈ [t_min, t_max]` inside the
    /// ball (`d` need not be normalised). A full chord at distance `h` from the centre
    /// is `2√(r² − h²)`.
    pub fn chord_length(&self, o: DVec3, d: DVec3, t_min: f64, t_max: f64) -> f64 {
        clipped_length(self.ray_interval(o, d), d, t_min, t_max)
    }
}

/// A shape of constant density with a closed-form chord: it is a [`Field`] whose
/// integral along any ray is exact (ρ × the chord inside it), on a virtual grid whose
/// cells carry the shape's exact range.
pub trait ConstantShape: Send + Sync {
    fn shape_transform(&self) -> &IndexToWorld;
    /// The density ρ inside.
    fn shape_density(&self) -> f32;
    /// True if the local index point is inside the closed shape.
    fn contains_index(&self, p: DVec3) -> bool;
    /// Corners of the local-index box that holds the shape.
    fn index_bounds(&self) -> (DVec3, DVec3);
    /// World length of the part of the segment `o + t·d, t ∈ [t_min, t_max]` inside the
    /// shape (`d` need not be normalised).
    fn chord(&self, o: DVec3, d: DVec3, t_min: f64, t_max: f64) -> f64;
    /// Range over the closed local-index box `[lo, hi]`: 0 apart from the shape, ρ inside
    /// it, both where it straddles the surface.
    fn range_of_box(&self, lo: DVec3, hi: DVec3) -> ValueRange;
}

impl<S: ConstantShape> Field for S {
    /// The exact indicator: `ρ` inside the closed shape, 0 outside (no interpolation).
    fn value_at_index(&self, p: DVec3) -> f32 {
        if self.contains_index(p) {
            self.shape_density()
        } else {
            0.0
        }
    }

    fn transform(&self) -> &IndexToWorld {
        self.shape_transform()
    }

    fn active_bounds(&self) -> IndexBox {
        let (lo, hi) = self.index_bounds();
        index_box_outward(lo, hi)
    }

    fn quadrature(&self) -> super::Quadrature {
        super::Quadrature::ClosedForm
    }

    /// Exact: ρ × the length of the chord inside the shape.
    fn integral(&self, ray: &IndexRay, t0: f64, t1: f64) -> f64 {
        chord_integral(
            self.shape_transform(),
            self.shape_density(),
            ray,
            t0,
            t1,
            |o, d, a, b| self.chord(o, d, a, b),
        )
    }

    fn cell_at(&self, ijk: IVec3) -> Cell {
        virtual_cell(ijk, |lo, hi| self.range_of_box(lo, hi))
    }

    fn range_over(&self, b: &IndexBox) -> ValueRange {
        range_over_box(b, |lo, hi| self.range_of_box(lo, hi))
    }
}

impl ConstantShape for ConstantBox {
    fn shape_transform(&self) -> &IndexToWorld {
        &self.transform
    }
    fn shape_density(&self) -> f32 {
        self.density
    }
    fn contains_index(&self, p: DVec3) -> bool {
        p.cmpge(self.index_min).all() && p.cmple(self.index_max).all()
    }
    fn index_bounds(&self) -> (DVec3, DVec3) {
        (self.index_min, self.index_max)
    }
    fn chord(&self, o: DVec3, d: DVec3, t_min: f64, t_max: f64) -> f64 {
        self.chord_length(o, d, t_min, t_max)
    }
    fn range_of_box(&self, lo: DVec3, hi: DVec3) -> ValueRange {
        let separated = hi.cmplt(self.index_min).any() || lo.cmpgt(self.index_max).any();
        if separated {
            ValueRange::ZERO
        } else if lo.cmpge(self.index_min).all() && hi.cmple(self.index_max).all() {
            ValueRange::point(self.density)
        } else {
            straddle(self.density)
        }
    }
}

impl ConstantShape for ConstantSphere {
    fn shape_transform(&self) -> &IndexToWorld {
        &self.transform
    }
    fn shape_density(&self) -> f32 {
        self.density
    }
    fn contains_index(&self, p: DVec3) -> bool {
        (p - self.index_center).length_squared() <= self.index_radius * self.index_radius
    }
    fn index_bounds(&self) -> (DVec3, DVec3) {
        let r = DVec3::splat(self.index_radius);
        (self.index_center - r, self.index_center + r)
    }
    fn chord(&self, o: DVec3, d: DVec3, t_min: f64, t_max: f64) -> f64 {
        self.chord_length(o, d, t_min, t_max)
    }
    fn range_of_box(&self, lo: DVec3, hi: DVec3) -> ValueRange {
        let c = self.index_center;
        let r2 = self.index_radius * self.index_radius;
        // Nearest point of the box to the centre, and the farthest corner.
        let near = c.max(lo).min(hi);
        let d2_min = (near - c).length_squared();
        let far = (c - lo).abs().max((hi - c).abs());
        let d2_max = far.length_squared();
        if d2_min > r2 {
            ValueRange::ZERO
        } else if d2_max <= r2 {
            ValueRange::point(self.density)
        } else {
            straddle(self.density)
        }
    }
}

#[cfg(test)]
mod tests;
