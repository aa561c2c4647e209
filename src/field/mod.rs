//! Fields: everything that has a scalar (or colour) value at a point in space.
//!
//! Every density-like source — a VDB grid converted to [`VoxelGrid`], a procedural noise
//! field, a constant box or sphere — implements [`Field`], so the traversal, the shadow
//! baker and the integrator never know which one they are sampling.
//!
//! Coordinates come in two spaces:
//! - **world** space, `DVec3` (f64), where cameras and lights live;
//! - **local index** space, `DVec3` for points (f64): the grid's index space shifted by an integer
//!   [`IndexToWorld::origin`] so that the numbers stay small (a grid stored near index 1e6
//!   samples as precisely as one at 0). Voxel values sit at integer local-index points.

pub mod advect;
pub mod advect_shared;
pub mod albedo_mix;
pub mod color3;
pub mod floor;
pub mod grid;
pub mod grid_build;
mod grid_dense;
mod grid_integrals;
mod grid_levels;
pub mod grid_nodes;
mod grid_ranges;
pub mod grid_reader;
pub mod mesh;
pub mod nonzero;
pub mod padded_cells;
pub mod procedural;
pub mod random;
pub mod shapes;
pub mod sum;
#[cfg(test)]
mod test_support;
pub mod transform;
pub mod union;
pub mod velocity;

pub use grid::VoxelGrid;
pub use transform::IndexToWorld;

use glam::{DVec3, IVec3, Vec3};

/// An axis-aligned box in local index space, `min` inclusive, `max` exclusive for cells
/// and inclusive for points (the box of the points a field can be non-zero at).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IndexBox {
    pub min: Vec3,
    pub max: Vec3,
}

impl IndexBox {
    pub const EMPTY: IndexBox = IndexBox {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn new(min: Vec3, max: Vec3) -> Self {
        IndexBox { min, max }
    }
    pub fn is_empty(&self) -> bool {
        !(self.min.x <= self.max.x && self.min.y <= self.max.y && self.min.z <= self.max.z)
    }
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }
    pub fn union(&self, o: &IndexBox) -> IndexBox {
        IndexBox {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }
    pub fn extent(&self) -> Vec3 {
        if self.is_empty() {
            Vec3::ZERO
        } else {
            self.max - self.min
        }
    }
}

/// The range of values a field takes over some region. `max` is a majorant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ValueRange {
    pub min: f32,
    pub max: f32,
}

impl ValueRange {
    pub const EMPTY: ValueRange = ValueRange {
        min: f32::INFINITY,
        max: f32::NEG_INFINITY,
    };
    pub const ZERO: ValueRange = ValueRange { min: 0.0, max: 0.0 };

    pub fn point(v: f32) -> Self {
        ValueRange { min: v, max: v }
    }
    pub fn include(&mut self, v: f32) {
        self.min = self.min.min(v);
        self.max = self.max.max(v);
    }
    pub fn union(&self, o: &ValueRange) -> ValueRange {
        ValueRange {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }
    /// True when the field is zero everywhere in the region (nothing to integrate).
    pub fn is_zero(&self) -> bool {
        self.max <= 0.0 && self.min >= 0.0
    }
    pub fn is_constant(&self) -> bool {
        self.min == self.max
    }
}

/// A ray in a field's local index space, parameterised by world distance.
#[derive(Clone, Copy, Debug)]
pub struct IndexRay {
    /// Local index point at `t = 0`.
    pub origin: DVec3,
    /// Index units per world unit along the ray.
    pub dir: DVec3,
}

impl IndexRay {
    /// The ray `world_origin + t · world_dir` (world_dir unit length) in `field`'s index space.
    pub fn new(field: &(impl Field + ?Sized), world_origin: DVec3, world_dir: DVec3) -> Self {
        let tr = field.transform();
        IndexRay {
            origin: tr.world_to_index(world_origin),
            dir: tr.world_dir_to_index(world_dir),
        }
    }

    #[inline]
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + self.dir * t
    }

    /// Index units travelled per world unit.
    pub fn index_speed(&self) -> f64 {
        self.dir.length()
    }
}

/// Two-point Gauss–Legendre: `∫ f dt` over `[t0, t1]`, exact for cubics in `t` (the
/// trilinear reconstruction along a ray inside one voxel is one).
#[inline]
pub fn gauss_legendre_2(f: impl Fn(f64) -> f64, t0: f64, t1: f64) -> f64 {
    const G: f64 = 0.5 - GL2_HALF_OFFSET;
    let ds = t1 - t0;
    0.5 * ds * (f(t0 + G * ds) + f(t1 - G * ds))
}

/// Where the two Gauss–Legendre nodes sit, as a fraction of the interval from its
/// middle: `±1/(2√3)`.
pub const GL2_HALF_OFFSET: f64 = 0.288_675_134_594_812_9;

/// What [`Field::integral`] gives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quadrature {
    /// Gauss–Legendre over the interval: callers keep intervals short.
    Approximate,
    /// Exact over any interval, at a cost proportional to the voxels crossed.
    ExactPerVoxel,
    /// Exact over any interval at constant cost (a closed form).
    ClosedForm,
}

/// One cell of a field's hierarchy, as the traversal sees it: an axis-aligned cube of
/// `size` voxels starting at `origin` (local index space) over which the field's
/// trilinear reconstruction stays within `range`. For a VDB grid this is a leaf (8), an
/// internal node or tile (128, 4096), or a root-level gap; for an analytic field a
/// virtual brick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    pub origin: IVec3,
    pub size: i32,
    /// Range of the trilinear reconstruction over the whole cell (it includes the +1
    /// voxel layer the interpolation stencil reaches into).
    pub range: ValueRange,
}

/// A local-index vector affine in the ray parameter: `at(t) = base + rate·t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Affine {
    pub base: glam::DVec3,
    pub rate: glam::DVec3,
}

impl Affine {
    pub fn new(base: glam::DVec3, rate: glam::DVec3) -> Self {
        Affine { base, rate }
    }

    #[inline]
    pub fn at(&self, t: f64) -> glam::DVec3 {
        self.base + self.rate * t
    }
}

/// How the point at parameter t of a ray moves when the ray moves sideways with two
/// lateral coordinates x and y: by `a(t)` per unit of x, `b(t)` per unit of y, and
/// `c(t)` per unit of x·y (the second derivative), in local index units. A parallel
/// shift has constant `a`, `b` and no `c`; a fan of rays from a point has all three
/// proportional to t.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sideways {
    pub a: Affine,
    pub b: Affine,
    pub c: Affine,
}

impl Sideways {
    /// Rays shifted in parallel by `a` per unit of x and `b` per unit of y.
    pub fn parallel(a: glam::DVec3, b: glam::DVec3) -> Self {
        let constant = |v| Affine::new(v, glam::DVec3::ZERO);
        Sideways {
            a: constant(a),
            b: constant(b),
            c: constant(glam::DVec3::ZERO),
        }
    }
}

/// A scalar field sampled by the renderer. Implemented by [`VoxelGrid`], the procedural
/// fields in [`procedural`] and the analytic shapes in [`shapes`].
pub trait Field: Send + Sync {
    /// Trilinear value at a local index point.
    fn value_at_index(&self, p: DVec3) -> f32;

    /// The map between local index space and world space.
    fn transform(&self) -> &IndexToWorld;

    /// Value at a world point.
    fn value_at_world(&self, p: DVec3) -> f32 {
        self.value_at_index(self.transform().world_to_index(p))
    }

    /// The box (local index space) outside which the field is zero.
    fn active_bounds(&self) -> IndexBox;

    /// World-space axis-aligned bounds of [`Field::active_bounds`].
    fn world_bounds(&self) -> (glam::DVec3, glam::DVec3) {
        self.transform().index_box_to_world(&self.active_bounds())
    }

    /// The coarsest cell of the field's hierarchy that contains the voxel `ijk` (local
    /// index), with the range of the field over it. The traversal steps cell by cell.
    fn cell_at(&self, ijk: IVec3) -> Cell;

    /// A majorant and minorant of the field over a local-index box.
    fn range_over(&self, b: &IndexBox) -> ValueRange;

    /// [`Field::range_over`] as tight as the field can make it, for a small box (a
    /// block of a majorant grid, built once per render). A voxel grid reads the values
    /// at the box's points — the trilinear reconstruction stays between them — where
    /// `range_over` unions whole cells and their neighbours.
    fn tight_range_over(&self, b: &IndexBox) -> ValueRange {
        self.range_over(b)
    }

    /// `∫ value dt` along `ray` over `[t0, t1]` (t in world units). Fields that can do it
    /// exactly do (a voxel grid voxel by voxel, the analytic shapes by chord length);
    /// the default is two-point Gauss–Legendre over the interval, and the caller keeps
    /// intervals short.
    fn integral(&self, ray: &IndexRay, t0: f64, t1: f64) -> f64 {
        gauss_legendre_2(|t| self.value_at_index(ray.at(t)) as f64, t0, t1)
    }

    /// [`Field::value_at_index`] at `ray.at(t)` for each `t` of `ts` into `out` (as
    /// long as `ts`). A voxel grid remembers the last leaf it looked up, so points
    /// close together along a ray do not each descend the tree.
    fn values_along(&self, ray: &IndexRay, ts: &[f64], out: &mut [f32]) {
        for (&t, o) in ts.iter().zip(out.iter_mut()) {
            *o = self.value_at_index(ray.at(t));
        }
    }

    /// [`Field::integral`] over consecutive pieces of one ray: `out[i] = ∫ρ dt` over
    /// `[ends[i−1], ends[i]]`, with `ends[−1] = t0` (`ends` ascending, as long as `out`).
    /// A voxel grid walks the voxels once for all the pieces, so a march of many short
    /// segments does not start a walk per segment.
    fn piece_integrals(&self, ray: &IndexRay, t0: f64, ends: &[f64], out: &mut [f64]) {
        let mut a = t0;
        for (&b, o) in ends.iter().zip(out.iter_mut()) {
            *o = self.integral(ray, a, b);
            a = b;
        }
    }

    /// Along `ray` from `t0` to each of `targets` (ascending, world units): `∫ρ dt` and
    /// how it changes as the ray moves sideways as `side` says: `[∫ρ, ∫∇ρ·a, ∫∇ρ·b,
    /// ∫(aᵀ(∇∇ρ)b + ∇ρ·c)]` dt, pushed to `out`, the last with the kinks of the field's
    /// interpolation. `false` (nothing pushed) where the field has no closed form for
    /// them; the caller then differences neighbouring rays.
    fn slopes_along(
        &self,
        _ray: &IndexRay,
        _t0: f64,
        _targets: &[f64],
        _side: &Sideways,
        _out: &mut Vec<[f64; 4]>,
    ) -> bool {
        false
    }

    /// How exact and how costly [`Field::integral`] is.
    fn quadrature(&self) -> Quadrature {
        Quadrature::Approximate
    }

    /// A 64-bit fingerprint of what the field renders as (equal fields give equal
    /// hashes on every machine), or `None` where the field cannot give one: a shadow map
    /// cached for it is then never reused.
    fn content_hash(&self) -> Option<u64> {
        None
    }

    /// Bytes the field's render structure holds (reported in the stats and compared with
    /// the shadow map's).
    /// The field as a [`VoxelGrid`], if it is one (the GPU backend walks its nodes).
    fn as_voxel_grid(&self) -> Option<&VoxelGrid> {
        None
    }

    fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(self)
    }
}

/// A colour (or any 3-vector) field, sampled where the density is: Houdini's `Cd`,
/// Blender's `color`.
pub trait ColorField: Send + Sync {
    fn transform(&self) -> &IndexToWorld;
    /// Trilinear value at a local index point.
    fn color_at_index(&self, p: DVec3) -> Vec3;
    /// The grids the colour is read from, where they are voxel grids (the GPU backend
    /// walks their nodes).
    fn parts(&self) -> Option<ColorParts<'_>> {
        None
    }
}

/// The grids of a colour field ([`ColorField::parts`]).
pub enum ColorParts<'a> {
    /// One grid of three (or more) channels: the colour is channels 0, 1, 2.
    Vector(&'a VoxelGrid),
    /// One scalar field a channel, each on its own transform.
    Channels([&'a dyn Field; 3]),
}

impl ColorField for VoxelGrid {
    fn transform(&self) -> &IndexToWorld {
        Field::transform(self)
    }
    fn color_at_index(&self, p: DVec3) -> Vec3 {
        self.sample_vec3(p)
    }
    fn parts(&self) -> Option<ColorParts<'_>> {
        Some(ColorParts::Vector(self))
    }
}

/// The shift from `b`'s local index space to `a`'s when both are on one lattice (the
/// same index→world map up to an integer offset), else `None`.
pub fn lattice_offset(a: &IndexToWorld, b: &IndexToWorld) -> Option<DVec3> {
    (a.linear() == b.linear() && a.matrix().w_axis == b.matrix().w_axis)
        .then(|| (b.origin - a.origin).as_dvec3())
}
