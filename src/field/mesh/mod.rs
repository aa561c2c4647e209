//! Unstructured meshes (tetrahedra, hexahedra, wedges, pyramids) as a [`Field`].
//!
//! [`MeshGeometry`] is built once per file: the cells cut into conforming tetrahedra
//! ([`geometry`]), their face adjacency, a BVH over the boundary faces ([`bvh`]) and a
//! virtual lattice of bricks ([`lattice`]). A [`MeshField`] is one data array over it
//! (point data interpolated as VTK does, cell data constant per cell); several share
//! one geometry (density, temperature, …).
//!
//! To the traversal the field is a lattice: [`Field::cell_at`] answers with 8³-voxel
//! bricks whose ranges come from the cells overlapping them (zero included, so a brick
//! is never taken as constant), and empty bricks are skipped. [`Field::integral`] and
//! [`Field::piece_integrals`] walk the ray cell to cell ([`walk`]) and integrate each
//! crossing: exactly for tetrahedra and cell data (the value is linear, resp. constant,
//! along the crossing: one midpoint evaluation is exact), and by three-point
//! Gauss–Legendre per crossing of one of the tetrahedra a hexahedron, wedge or pyramid
//! is cut into for point data there (exact for parallelepipeds and straight prisms,
//! where VTK's interpolation is a polynomial of degree ≤ 3 along the ray; otherwise
//! the parametric map is inverted by Newton's method at each node and the error is of
//! order h⁶ in the crossing length h).

pub mod bvh;
pub mod geometry;
pub mod interp;
pub mod lattice;
pub mod line;
mod source;
pub mod walk;

use super::{Cell, Field, IndexBox, IndexRay, IndexToWorld, Quadrature, ValueRange};
use crate::vtk::{CellType, UnstructuredMesh};
pub use geometry::LoadReport;
use geometry::TetMesh;
use glam::{DVec3, IVec3, Vec3};
use lattice::{BRICK, Lattice, check_extent};
pub use source::MeshSource;
use std::sync::Arc;
use walk::{Line, Resume, WalkStats, Walker};

thread_local! {
    /// The last walk of this thread: its ray (origin, direction), end and where it
    /// stopped. A march asks for consecutive stretches of one ray; the next walk goes
    /// on from there instead of locating its start again (the same tetrahedra, so the
    /// same result).
    static LAST_WALK: std::cell::Cell<Option<(DVec3, DVec3, f64, Resume)>> =
        const { std::cell::Cell::new(None) };
    /// The tetrahedron this thread last located a point in, with its geometry's address.
    static LAST_TET: std::cell::Cell<Option<(usize, u32)>> = const { std::cell::Cell::new(None) };
}

/// The walkable mesh shared by the fields of one file.
///
/// Its points are held relative to `offset`: a mesh far from the origin compared with
/// its size is moved near it (per axis, by the centre of its bounds, a subtraction that
/// is exact there), so the walk's hair (1e-10 of the diagonal) still moves a point and
/// its predicates see the mesh's own differences. World points are taken and given
/// with the offset added back.
pub struct MeshGeometry {
    pub tets: TetMesh,
    /// World position of the origin of the points' coordinates.
    pub offset: DVec3,
    pub bvh: bvh::FaceBvh,
    pub lattice: Lattice,
    /// Mesh diagonal and the walk's hair (1e-10 of it).
    pub diag: f64,
    pub tol: f64,
    hash: u64,
}

fn mix(h: u64, v: u64) -> u64 {
    crate::field::random::mix64(h ^ v).wrapping_add(0x9E37_79B9_7F4A_7C15)
}

impl MeshGeometry {
    pub fn new(mesh: &UnstructuredMesh) -> Result<MeshGeometry, String> {
        if mesh.cells() == 0 {
            return Err("the mesh has no cells".into());
        }
        let (lo, hi) = mesh.bounds();
        let (lo, hi) = (DVec3::from_array(lo), DVec3::from_array(hi));
        let offset = check_extent(lo, hi, mesh.points.len())?;
        let diag = (hi - lo).length();
        let tets = TetMesh::build(mesh, offset)?;
        let lattice = Lattice::build(&tets, lo - offset, hi - offset, offset)?;
        let bvh = bvh::FaceBvh::build(&tets, diag * 1e-9);
        let mut h = 0x6d75_726b_6d65_7368u64;
        for p in &mesh.points {
            for c in p {
                h = mix(h, c.to_bits());
            }
        }
        for t in &mesh.cell_types {
            h = mix(h, t.vtk_id() as u64);
        }
        for c in &mesh.connectivity {
            h = mix(h, *c as u64);
        }
        Ok(MeshGeometry {
            tets,
            offset,
            bvh,
            lattice,
            diag,
            tol: diag * 1e-10,
            hash: h,
        })
    }

    pub fn report(&self) -> &LoadReport {
        &self.tets.report
    }

    fn walker(&self) -> Walker<'_> {
        Walker {
            mesh: &self.tets,
            bvh: &self.bvh,
            lattice: &self.lattice,
            tol: self.tol,
            scale: self.diag,
        }
    }

    /// The pieces of the world ray `o + t·d` over `[t0, t1]` inside the mesh, each in
    /// one tetrahedron: `f(tet, ta, tb)`.
    pub fn walk(
        &self,
        o: DVec3,
        d: DVec3,
        t0: f64,
        t1: f64,
        f: impl FnMut(u32, f64, f64),
    ) -> WalkStats {
        let line = Line::new(o - self.offset, d, self.diag / d.length().max(1e-300));
        self.walker().walk(&line, t0, t1, f)
    }

    /// World length inside the mesh of the segment from `p + t0·(q − p)` to
    /// `p + t1·(q − p)`, walking the exact line through the points `p` and `q` (so a
    /// ray aimed at a vertex passes exactly through it), with the walk's counters; NaN
    /// if the pieces came out of order.
    pub fn chord_through(&self, p: DVec3, q: DVec3, t0: f64, t1: f64) -> (f64, WalkStats) {
        let line = Line::through(p - self.offset, q - self.offset);
        let mut len = 0.0;
        let mut last = f64::NEG_INFINITY;
        let mut ordered = true;
        let st = self.walker().walk(&line, t0, t1, |_, a, b| {
            ordered &= a >= last && b >= a;
            last = b;
            len += b - a;
        });
        // Pieces out of order would be a walk bug: NaN makes any comparison fail.
        let len = if ordered { len } else { f64::NAN };
        (len * (q - p).length(), st)
    }

    /// A tetrahedron containing the world point `x` (closed, exact), or `None`: first
    /// the one this thread found last (for this geometry) and its neighbours — samples
    /// along a ray move little — then the lattice's lists. The shortcut is taken only
    /// for a point strictly inside (on no face), where the answer is the only one: a
    /// point on a face always gets the lattice's answer, whatever the thread did before,
    /// so images do not depend on the thread count or tiling.
    pub fn locate(&self, x: DVec3) -> Option<u32> {
        self.locate_in_mesh(x - self.offset)
    }

    /// [`MeshGeometry::locate`] for a point in the mesh's coordinates (world − offset).
    fn locate_in_mesh(&self, x: DVec3) -> Option<u32> {
        let me = self as *const MeshGeometry as usize;
        if let Some((g, t)) = LAST_TET.get()
            && g == me
            && (t as usize) < self.tets.tets.len()
        {
            if self.tets.strictly_contains(t, x) {
                return Some(t);
            }
            for nb in self.tets.neighbors[t as usize] {
                if nb != geometry::NONE && self.tets.strictly_contains(nb >> 2, x) {
                    LAST_TET.set(Some((me, nb >> 2)));
                    return Some(nb >> 2);
                }
            }
        }
        let t = self.lattice.locate(&self.tets, x)?;
        LAST_TET.set(Some((me, t)));
        Some(t)
    }

    /// [`MeshGeometry::walk`] of a ray whose origin `o` is in the mesh's coordinates
    /// (world − offset), going on from this thread's previous walk when it was of the
    /// same ray and ended at `t0`.
    fn walk_continued(&self, o: DVec3, d: DVec3, t0: f64, t1: f64, f: impl FnMut(u32, f64, f64)) {
        let line = Line::new(o, d, self.diag / d.length().max(1e-300));
        let start = LAST_WALK
            .get()
            .and_then(|(lo, ld, lt, r)| (lo == o && ld == d && lt == t0).then_some(r))
            .or_else(|| {
                Some(match self.locate_in_mesh(line.at(t0)) {
                    Some(t) => Resume::Inside(t, 4),
                    None => Resume::Outside,
                })
            });
        let (_, end) = self.walker().walk_from(&line, t0, t1, start, f);
        LAST_WALK.set(end.map(|r| (o, d, t1, r)));
    }

    /// World length of `o + t·d, t ∈ [t0, t1]` inside the mesh, by the walk.
    pub fn chord_length(&self, o: DVec3, d: DVec3, t0: f64, t1: f64) -> f64 {
        let mut len = 0.0;
        self.walk(o, d, t0, t1, |_, a, b| len += b - a);
        len * d.length()
    }

    pub fn memory_bytes(&self) -> usize {
        self.tets.memory_bytes() + self.bvh.memory_bytes() + self.lattice.memory_bytes()
    }
}

/// Where a field's values live.
#[derive(Clone, Debug)]
enum Values {
    /// One per mesh point, interpolated as VTK does.
    Point(Vec<f64>),
    /// One per cell, constant in it.
    Cell(Vec<f64>),
}

/// One data array of a mesh as a field.
pub struct MeshField {
    geo: Arc<MeshGeometry>,
    values: Values,
    name: String,
    bricks: Vec<ValueRange>,
    hash: u64,
}

/// Three-point Gauss–Legendre nodes on [0, 1] and weights.
const GL3: [(f64, f64); 3] = [
    (0.112_701_665_379_258_31, 5.0 / 18.0),
    (0.5, 8.0 / 18.0),
    (0.887_298_334_620_741_7, 5.0 / 18.0),
];

impl MeshField {
    /// Point data (one value per mesh point; NaN and infinities read as 0).
    pub fn from_point_values(geo: Arc<MeshGeometry>, name: &str, values: Vec<f64>) -> MeshField {
        let values = values
            .into_iter()
            .map(|v| if v.is_finite() { v } else { 0.0 })
            .collect();
        Self::with(geo, name, Values::Point(values))
    }

    /// Cell data (one value per cell; NaN and infinities read as 0).
    pub fn from_cell_values(geo: Arc<MeshGeometry>, name: &str, values: Vec<f64>) -> MeshField {
        let values = values
            .into_iter()
            .map(|v| if v.is_finite() { v } else { 0.0 })
            .collect();
        Self::with(geo, name, Values::Cell(values))
    }

    fn with(geo: Arc<MeshGeometry>, name: &str, values: Values) -> MeshField {
        let tm = &geo.tets;
        let n_cells = tm.cell_types.len();
        let cell_range: Vec<ValueRange> = (0..n_cells as u32)
            .map(|c| {
                let mut r = ValueRange::ZERO;
                match &values {
                    Values::Cell(v) => r.include(v[c as usize] as f32),
                    // VTK's shape functions are non-negative in the cell: its values
                    // lie between the corners'.
                    Values::Point(v) => tm
                        .cell(c)
                        .iter()
                        .for_each(|&p| r.include(v[p as usize] as f32)),
                }
                // f32 rounding: widen so the range still bounds the f64 values.
                ValueRange {
                    min: if r.min < 0.0 {
                        r.min.next_down()
                    } else {
                        r.min
                    },
                    max: if r.max > 0.0 { r.max.next_up() } else { r.max },
                }
            })
            .collect();
        let lat = &geo.lattice;
        let bricks = (0..lat.brick_count())
            .map(|b| {
                lat.tets_in(b).iter().fold(ValueRange::ZERO, |r, &t| {
                    r.union(&cell_range[tm.tet_cell[t as usize] as usize])
                })
            })
            .collect();
        let mut h = mix(geo.hash, name.len() as u64);
        let (tag, vs) = match &values {
            Values::Point(v) => (1, v),
            Values::Cell(v) => (2, v),
        };
        h = mix(h, tag);
        for v in vs {
            h = mix(h, v.to_bits());
        }
        MeshField {
            geo,
            values,
            name: name.to_string(),
            bricks,
            hash: h,
        }
    }

    pub fn geometry(&self) -> &Arc<MeshGeometry> {
        &self.geo
    }
    pub fn name(&self) -> &str {
        &self.name
    }

    /// VTK's interpolated value at the point `x` (mesh coordinates) in tetrahedron `tet`.
    fn value_in(&self, tet: u32, x: DVec3) -> f64 {
        let tm = &self.geo.tets;
        let cell = tm.tet_cell[tet as usize];
        match &self.values {
            Values::Cell(v) => v[cell as usize],
            Values::Point(v) => {
                let ty = tm.cell_types[cell as usize];
                if ty == CellType::Tetra {
                    let c = tm.corners(tet);
                    let t = tm.tets[tet as usize];
                    match interp::barycentric(&c, x) {
                        Some(l) => {
                            (1.0 - l.x - l.y - l.z) * v[t[0] as usize]
                                + l.x * v[t[1] as usize]
                                + l.y * v[t[2] as usize]
                                + l.z * v[t[3] as usize]
                        }
                        None => v[t[0] as usize],
                    }
                } else {
                    let ids = tm.cell(cell);
                    let mut xs = [DVec3::ZERO; 8];
                    let mut vals = [0.0; 8];
                    for (k, &p) in ids.iter().enumerate() {
                        xs[k] = tm.points[p as usize];
                        vals[k] = v[p as usize];
                    }
                    let n = ids.len();
                    let xi = interp::parametric(ty, &xs[..n], x, interp::centre(ty));
                    interp::interpolate(ty, &vals[..n], xi)
                }
            }
        }
    }

    /// `∫ value dt` over `[a, b]` of the ray (origin in mesh coordinates), all in
    /// tetrahedron `tet`.
    fn piece(&self, tet: u32, line_o: DVec3, d: DVec3, a: f64, b: f64) -> f64 {
        let tm = &self.geo.tets;
        let cell = tm.tet_cell[tet as usize];
        let linear = matches!(self.values, Values::Cell(_))
            || tm.cell_types[cell as usize] == CellType::Tetra;
        let h = b - a;
        if linear {
            h * self.value_in(tet, line_o + d * (0.5 * (a + b)))
        } else {
            GL3.iter()
                .map(|(u, w)| w * self.value_in(tet, line_o + d * (a + u * h)))
                .sum::<f64>()
                * h
        }
    }

    /// `∫ value dt` along the world ray `o + t·d` over `[t0, t1]` (t in units of d).
    pub fn integrate_world(&self, o: DVec3, d: DVec3, t0: f64, t1: f64) -> f64 {
        self.integrate_in_mesh(o - self.geo.offset, d, t0, t1)
    }

    /// [`MeshField::integrate_world`] with `o` in mesh coordinates (world − offset).
    fn integrate_in_mesh(&self, o: DVec3, d: DVec3, t0: f64, t1: f64) -> f64 {
        let mut sum = 0.0;
        self.geo
            .walk_continued(o, d, t0, t1, |tet, a, b| sum += self.piece(tet, o, d, a, b));
        sum
    }

    /// The value at a world point (0 outside the mesh).
    pub fn value_at_world_point(&self, x: DVec3) -> f64 {
        self.value_at_mesh_point(x - self.geo.offset)
    }

    /// The value at a point in mesh coordinates (world − offset).
    fn value_at_mesh_point(&self, x: DVec3) -> f64 {
        match self.geo.locate_in_mesh(x) {
            Some(t) => self.value_in(t, x),
            None => 0.0,
        }
    }

    /// The cell containing a world point (by the tetrahedra it is cut into), or `None`.
    pub fn cell_at_world_point(&self, x: DVec3) -> Option<u32> {
        let t = self.geo.locate(x)?;
        Some(self.geo.tets.tet_cell[t as usize])
    }

    /// The index ray as a ray in mesh coordinates (world − offset).
    fn mesh_ray(&self, ray: &IndexRay) -> (DVec3, DVec3) {
        let lat = &self.geo.lattice;
        (
            lat.index_to_mesh(ray.origin),
            lat.transform.linear() * ray.dir,
        )
    }
}

impl Field for MeshField {
    fn value_at_index(&self, p: DVec3) -> f32 {
        let x = self.geo.lattice.index_to_mesh(p);
        self.value_at_mesh_point(x) as f32
    }

    fn transform(&self) -> &IndexToWorld {
        &self.geo.lattice.transform
    }

    fn active_bounds(&self) -> IndexBox {
        IndexBox::new(Vec3::ZERO, (self.geo.lattice.dims * BRICK).as_vec3())
    }

    fn cell_at(&self, ijk: IVec3) -> Cell {
        let b = ijk >> 3;
        let range = match self.geo.lattice.brick_index(b) {
            Some(k) => self.bricks[k],
            None => ValueRange::ZERO,
        };
        Cell {
            origin: b << 3,
            size: BRICK,
            range,
        }
    }

    fn range_over(&self, b: &IndexBox) -> ValueRange {
        if b.is_empty() {
            return ValueRange::ZERO;
        }
        let lat = &self.geo.lattice;
        let lo = (b.min.as_dvec3() / BRICK as f64)
            .floor()
            .as_ivec3()
            .max(IVec3::ZERO);
        let hi = (b.max.as_dvec3() / BRICK as f64)
            .floor()
            .as_ivec3()
            .min(lat.dims - 1);
        let mut r = ValueRange::ZERO;
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    if let Some(k) = lat.brick_index(IVec3::new(x, y, z)) {
                        r = r.union(&self.bricks[k]);
                    }
                }
            }
        }
        r
    }

    fn integral(&self, ray: &IndexRay, t0: f64, t1: f64) -> f64 {
        let (o, d) = self.mesh_ray(ray);
        self.integrate_in_mesh(o, d, t0, t1)
    }

    fn piece_integrals(&self, ray: &IndexRay, t0: f64, ends: &[f64], out: &mut [f64]) {
        out.iter_mut().for_each(|v| *v = 0.0);
        let Some(&t_end) = ends.last() else { return };
        let (o, d) = self.mesh_ray(ray);
        let mut i = 0usize;
        self.geo.walk_continued(o, d, t0, t_end, |tet, a, b| {
            let mut a = a;
            while i < ends.len() && ends[i] <= a {
                i += 1;
            }
            while a < b && i < ends.len() {
                let e = ends[i].min(b);
                if e > a {
                    out[i] += self.piece(tet, o, d, a, e);
                }
                a = e;
                if ends[i] <= b {
                    i += 1;
                }
            }
        });
    }

    fn quadrature(&self) -> Quadrature {
        Quadrature::ExactPerVoxel
    }

    fn content_hash(&self) -> Option<u64> {
        Some(self.hash)
    }

    fn memory_bytes(&self) -> usize {
        let values = match &self.values {
            Values::Point(v) | Values::Cell(v) => v.capacity() * 8,
        };
        self.geo.memory_bytes() + values + self.bricks.capacity() * 8
    }
}
