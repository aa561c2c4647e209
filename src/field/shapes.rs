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

    /// True if the local index point is inside the closed box.
    #[inline]
    fn inside_index(&self, p: DVec3) -> bool {
        p.cmpge(self.index_min).all() && p.cmple(self.index_max).all()
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

    /// Range over the closed local-index box `[lo, hi]`.
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

impl Field for ConstantBox {
    /// The exact indicator: `ρ` inside the closed box, 0 outside (no interpolation).
    fn value_at_index(&self, p: DVec3) -> f32 {
        if self.inside_index(p) {
            self.density
        } else {
            0.0
        }
    }

    fn transform(&self) -> &IndexToWorld {
        &self.transform
    }

    fn active_bounds(&self) -> IndexBox {
        index_box_outward(self.index_min, self.index_max)
    }

    fn quadrature(&self) -> super::Quadrature {
        super::Quadrature::ClosedForm
    }

    /// Exact: ρ × the length of the chord inside the box.
    fn integral(&self, ray: &IndexRay, t0: f64, t1: f64) -> f64 {
        chord_integral(&self.transform, self.density, ray, t0, t1, |o, d, a, b| {
            self.chord_length(o, d, a, b)
        })
    }

    fn cell_at(&self, ijk: IVec3) -> Cell {
        virtual_cell(ijk, |lo, hi| self.range_of_box(lo, hi))
    }

    fn range_over(&self, b: &IndexBox) -> ValueRange {
        if b.is_empty() {
            return ValueRange::ZERO;
        }
        self.range_of_box(b.min.as_dvec3(), b.max.as_dvec3())
    }
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

    /// Range over the closed local-index box `[lo, hi]`.
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

impl Field for ConstantSphere {
    /// The exact indicator: `ρ` inside the closed ball, 0 outside (no interpolation).
    fn value_at_index(&self, p: DVec3) -> f32 {
        let d2 = (p - self.index_center).length_squared();
        if d2 <= self.index_radius * self.index_radius {
            self.density
        } else {
            0.0
        }
    }

    fn transform(&self) -> &IndexToWorld {
        &self.transform
    }

    fn active_bounds(&self) -> IndexBox {
        let r = DVec3::splat(self.index_radius);
        index_box_outward(self.index_center - r, self.index_center + r)
    }

    fn quadrature(&self) -> super::Quadrature {
        super::Quadrature::ClosedForm
    }

    /// Exact: ρ × the length of the chord inside the ball.
    fn integral(&self, ray: &IndexRay, t0: f64, t1: f64) -> f64 {
        chord_integral(&self.transform, self.density, ray, t0, t1, |o, d, a, b| {
            self.chord_length(o, d, a, b)
        })
    }

    fn cell_at(&self, ijk: IVec3) -> Cell {
        virtual_cell(ijk, |lo, hi| self.range_of_box(lo, hi))
    }

    fn range_over(&self, b: &IndexBox) -> ValueRange {
        if b.is_empty() {
            return ValueRange::ZERO;
        }
        self.range_of_box(b.min.as_dvec3(), b.max.as_dvec3())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// SplitMix64, for reproducible random tests.
    struct Rng(u64);
    impl Rng {
        fn next_u64(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
            lo + (hi - lo) * ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
        }
        fn vec(&mut self, lo: f64, hi: f64) -> DVec3 {
            DVec3::new(
                self.uniform(lo, hi),
                self.uniform(lo, hi),
                self.uniform(lo, hi),
            )
        }
    }

    fn test_box() -> ConstantBox {
        ConstantBox::new(
            DVec3::new(-0.5, -0.25, 0.1),
            DVec3::new(0.75, 0.5, 0.9),
            2.5,
            1.0 / 32.0,
        )
        .unwrap()
    }

    fn test_sphere() -> ConstantSphere {
        ConstantSphere::new(DVec3::new(0.2, -0.1, 0.3), 0.7, 3.0, 1.0 / 40.0).unwrap()
    }

    #[test]
    fn cells_align_towards_negative_infinity() {
        let s = test_sphere();
        let c = s.cell_at(IVec3::new(-1, -8, -9));
        // Away from the sphere the cell may be coarser, but always aligned and containing.
        assert_eq!(c.origin % c.size, IVec3::ZERO);
        let leaf = aligned_cell(IVec3::new(-1, -8, -9), 8).0;
        assert_eq!(leaf, IVec3::new(-8, -8, -16));
        assert_eq!(aligned_cell(IVec3::new(7, 8, 15), 8).0, IVec3::new(0, 8, 8));
        assert_eq!(
            aligned_cell(IVec3::new(-4097, 4095, 0), 4096).0,
            IVec3::new(-8192, 0, 0)
        );
        // Extreme indices neither overflow nor panic.
        let c = s.cell_at(IVec3::new(i32::MAX, i32::MIN, 0));
        assert!(c.range.is_zero());
    }

    #[test]
    fn box_indicator_is_exact() {
        let b = test_box();
        let w = |x: f64, y: f64, z: f64| b.value_at_world(DVec3::new(x, y, z));
        assert_eq!(w(0.0, 0.0, 0.5), 2.5);
        assert_eq!(w(-0.5, -0.25, 0.1), 2.5); // corner: closed
        assert_eq!(w(0.75, 0.5, 0.9), 2.5);
        assert_eq!(w(-0.51, 0.0, 0.5), 0.0);
        assert_eq!(w(0.0, 0.0, 0.95), 0.0);
        // Hard edge in index space: just inside / just outside a face.
        let face = (0.75f64 * 32.0) as f32; // index x of the +x face = 24
        assert_eq!(b.value_at_index(Vec3::new(face, 0.0, 10.0).as_dvec3()), 2.5);
        assert_eq!(
            b.value_at_index(Vec3::new(face.next_up(), 0.0, 10.0).as_dvec3()),
            0.0
        );
        assert_eq!(
            b.value_at_index(Vec3::new(f32::NAN, 0.0, 10.0).as_dvec3()),
            0.0
        );
    }

    #[test]
    fn sphere_indicator_is_exact() {
        let s = test_sphere();
        assert_eq!(s.value_at_world(s.center()), 3.0);
        assert_eq!(
            s.value_at_world(s.center() + DVec3::new(0.0, 0.69, 0.0)),
            3.0
        );
        assert_eq!(
            s.value_at_world(s.center() + DVec3::new(0.0, 0.71, 0.0)),
            0.0
        );
        assert_eq!(s.value_at_world(s.center() + DVec3::splat(0.5)), 0.0); // |.| = 0.866
    }

    /// Checks cell classification and range_over against point samples.
    fn check_conservative(f: &dyn Field, lo: f64, hi: f64, density: f32, seed: u64) {
        let mut rng = Rng(seed);
        let (mut n_inside, mut n_outside, mut n_edge) = (0, 0, 0);
        for _ in 0..100_000 {
            let p = rng.vec(lo, hi).as_vec3();
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
            match (cell.range.min, cell.range.max) {
                (a, b) if a == density && b == density => n_inside += 1,
                (0.0, 0.0) => n_outside += 1,
                _ => n_edge += 1,
            }
            if v != 0.0 {
                assert!(f.active_bounds().contains(p), "{p} outside active bounds");
            }
            // Random boxes around p.
            let ext = Vec3::new(
                rng.uniform(0.0, 12.0) as f32,
                rng.uniform(0.0, 3.0) as f32,
                5.0,
            );
            let r = f.range_over(&IndexBox::new(p - ext * 0.3, p + ext * 0.7));
            assert!(r.min <= v && v <= r.max, "{p}: {v} outside {r:?}");
        }
        assert!(
            n_inside > 1000 && n_outside > 1000 && n_edge > 1000,
            "{n_inside} {n_outside} {n_edge}"
        );
    }

    #[test]
    fn box_cells_are_conservative() {
        let b = test_box();
        check_conservative(&b, -40.0, 45.0, 2.5, 1);
        // A leaf strictly inside is constant, one far away is a coarse zero cell.
        let c = b.cell_at(IVec3::new(2, 2, 12));
        assert_eq!(
            (c.origin, c.size, c.range),
            (IVec3::new(0, 0, 8), 8, ValueRange::point(2.5))
        );
        let c = b.cell_at(IVec3::new(5000, 0, 0));
        assert_eq!((c.size, c.range), (4096, ValueRange::ZERO));
        let c = b.cell_at(IVec3::new(200, 0, 0));
        assert_eq!((c.size, c.range), (128, ValueRange::ZERO));
        // A leaf touching the face x = 24 exactly: [16, 24] is inside, [24, 32] straddles.
        assert_eq!(
            b.cell_at(IVec3::new(17, 0, 8)).range,
            ValueRange::point(2.5)
        );
        assert_eq!(
            b.cell_at(IVec3::new(25, 0, 8)).range,
            ValueRange { min: 0.0, max: 2.5 }
        );
        assert_eq!(b.range_over(&IndexBox::EMPTY), ValueRange::ZERO);
    }

    #[test]
    fn sphere_cells_are_conservative() {
        let s = test_sphere();
        check_conservative(&s, -40.0, 45.0, 3.0, 2);
        // Negative density: the straddling range is [ρ, 0].
        let neg = ConstantSphere::new(DVec3::ZERO, 1.0, -1.5, 0.05).unwrap();
        check_conservative(&neg, -30.0, 30.0, -1.5, 3);
    }

    #[test]
    fn bounds_match_the_shape() {
        let b = test_box();
        let (lo, hi) = b.world_bounds();
        assert!((lo - DVec3::new(-0.5, -0.25, 0.1)).abs().max_element() < 1e-6);
        assert!((hi - DVec3::new(0.75, 0.5, 0.9)).abs().max_element() < 1e-6);
        let s = test_sphere();
        let (lo, hi) = s.world_bounds();
        assert!((lo - (s.center() - DVec3::splat(0.7))).abs().max_element() < 1e-6);
        assert!((hi - (s.center() + DVec3::splat(0.7))).abs().max_element() < 1e-6);
        assert!(ConstantBox::new(DVec3::ZERO, DVec3::ONE, 1.0, 0.0).is_none());
        assert!(ConstantBox::new(DVec3::ZERO, DVec3::NAN, 1.0, 0.1).is_none());
        assert!(ConstantSphere::new(DVec3::ZERO, -1.0, 1.0, 0.1).is_none());
        assert!(ConstantSphere::new(DVec3::ZERO, 1.0, f32::INFINITY, 0.1).is_none());
    }

    /// Chord by brute force: midpoint rule on the indicator along the segment.
    fn numeric_chord(f: &dyn Field, o: DVec3, d: DVec3, t0: f64, t1: f64, density: f32) -> f64 {
        let n = 200_000;
        let dt = (t1 - t0) / n as f64;
        let hits = (0..n)
            .filter(|i| f.value_at_world(o + d * (t0 + (*i as f64 + 0.5) * dt)) == density)
            .count();
        hits as f64 * dt * d.length()
    }

    #[test]
    fn chords_have_closed_forms() {
        let s = test_sphere();
        let c = s.center();
        // Through the centre: the diameter.
        let l = s.chord_length(c - DVec3::X * 5.0, DVec3::X, 0.0, 100.0);
        assert!((l - 1.4).abs() < 1e-12, "{l}");
        // Offset by h: 2√(r² − h²), with an unnormalised direction.
        let h = 0.3;
        let l = s.chord_length(c + DVec3::new(-5.0, h, 0.0), DVec3::X * 2.0, 0.0, 100.0);
        assert!((l - 2.0 * (0.49f64 - h * h).sqrt()).abs() < 1e-12, "{l}");
        // Starting inside at the centre: r.
        let l = s.chord_length(c, DVec3::new(1.0, 2.0, -1.0), 0.0, f64::INFINITY);
        assert!((l - 0.7).abs() < 1e-12, "{l}");
        // Missing and tangent rays.
        assert_eq!(
            s.chord_length(c + DVec3::new(-5.0, 0.71, 0.0), DVec3::X, 0.0, 100.0),
            0.0
        );
        // Far-away origin: no cancellation.
        let l = s.chord_length(c - DVec3::X * 1e8, DVec3::X, 0.0, 2e8);
        assert!((l - 1.4).abs() < 1e-7, "{l}");

        let b = test_box();
        let l = b.chord_length(DVec3::new(-3.0, 0.0, 0.5), DVec3::X, 0.0, 10.0);
        assert!((l - 1.25).abs() < 1e-12, "{l}");
        let l = b.chord_length(DVec3::new(-3.0, 0.0, 0.5), DVec3::X, 0.0, 3.0);
        assert!((l - 0.5).abs() < 1e-12, "{l}");
        // Diagonal, against the brute-force march.
        let (o, d) = (DVec3::new(-1.0, -1.0, -0.4), DVec3::new(1.0, 0.9, 0.8));
        for (f, dens, l) in [
            (&b as &dyn Field, 2.5, b.chord_length(o, d, 0.0, 3.0)),
            (&s as &dyn Field, 3.0, s.chord_length(o, d, 0.0, 3.0)),
        ] {
            let n = numeric_chord(f, o, d, 0.0, 3.0, dens);
            assert!(l > 0.3 && (l - n).abs() < 1e-4, "{l} vs {n}");
        }
        // Axis-parallel ray along a face (closed boundary) and a zero direction.
        let l = b.chord_length(DVec3::new(-3.0, 0.5, 0.5), DVec3::X, 0.0, 10.0);
        assert!((l - 1.25).abs() < 1e-12);
        assert_eq!(s.chord_length(c, DVec3::ZERO, 0.0, 1.0), 0.0);
    }
}
