//! The mesh as the walk sees it: every cell cut into tetrahedra that meet face to face,
//! each positively oriented, with the neighbour across each face.
//!
//! A tetrahedron is itself. A hexahedron, wedge or pyramid gets a point at its centroid
//! (the mean of its corners) and one tetrahedron per triangle of its faces, a quad face
//! cut along the diagonal through its smallest global point id. Two cells sharing a
//! quad cut it the same way, so the tetrahedra are conforming across cells of any
//! types; a non-planar quad becomes two planar triangles (VTK's bilinear face is
//! approximated by them; the values are still VTK's, by parametric coordinates of the
//! parent cell).
//!
//! Orientation is decided with the exact `orient3d` of the `robust` crate (Shewchuk's
//! adaptive predicates): a tetrahedron whose orientation is exactly zero is flat and
//! left out (its faces become boundary faces, which the walk re-enters through), and
//! one oriented the other way round has two vertices swapped.

use super::interp;
use crate::vtk::{CellType, UnstructuredMesh};
use glam::DVec3;

/// No neighbour: a boundary face.
pub const NONE: u32 = u32::MAX;

/// Exact orientation: positive when `d` is below the plane of `a, b, c` (which appear
/// counter-clockwise seen from above), i.e. when `a, b, c` face away from `d`.
#[inline]
pub fn orient(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    let p = |v: DVec3| robust::Coord3D {
        x: v.x,
        y: v.y,
        z: v.z,
    };
    robust::orient3d(p(a), p(b), p(c), p(d))
}

/// The vertices of face `k` (opposite vertex `k`) of a positive tetrahedron, ordered
/// so that the face looks outward (counter-clockwise seen from outside).
pub const FACES: [[usize; 3]; 4] = [[1, 3, 2], [0, 2, 3], [0, 3, 1], [0, 1, 2]];

/// What loading found, for `murk info` and the render report.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct LoadReport {
    pub cells: usize,
    pub tetrahedra: usize,
    /// Cells of zero volume (every tetrahedron of theirs exactly flat).
    pub degenerate_cells: usize,
    /// Cells oriented against the majority of their type (VTK's Jacobian sign).
    pub inverted_cells: usize,
    /// Flat tetrahedra left out (of otherwise non-degenerate cells too).
    pub flat_tetrahedra: usize,
    pub boundary_faces: usize,
    /// Faces shared by more than two tetrahedra (treated as boundary).
    pub non_manifold_faces: usize,
}

impl LoadReport {
    /// One line for a render report or `murk info`.
    pub fn summary(&self) -> String {
        format!(
            "{} cells as {} tetrahedra, {} boundary faces; {} degenerate, {} inverted cells, \
             {} flat tetrahedra left out, {} non-manifold faces",
            self.cells,
            self.tetrahedra,
            self.boundary_faces,
            self.degenerate_cells,
            self.inverted_cells,
            self.flat_tetrahedra,
            self.non_manifold_faces
        )
    }
}

/// Tetrahedra, neighbours and the parent cells.
pub struct TetMesh {
    /// Mesh points, then one centroid per non-tetrahedral cell.
    pub points: Vec<DVec3>,
    pub tets: Vec<[u32; 4]>,
    /// Parent cell of each tetrahedron.
    pub tet_cell: Vec<u32>,
    /// Across face `k` of tet `i`: `(neighbour << 2) | its face`, or [`NONE`].
    pub neighbors: Vec<[u32; 4]>,
    pub cell_types: Vec<CellType>,
    pub offsets: Vec<usize>,
    pub connectivity: Vec<u32>,
    pub report: LoadReport,
}

/// Faces of a cell (VTK local ids, cyclic order), for the centroid split.
fn cell_faces(ty: CellType) -> &'static [&'static [usize]] {
    match ty {
        CellType::Tetra => &[],
        CellType::Hexahedron => &[
            &[0, 1, 2, 3],
            &[4, 5, 6, 7],
            &[0, 1, 5, 4],
            &[1, 2, 6, 5],
            &[2, 3, 7, 6],
            &[3, 0, 4, 7],
        ],
        CellType::Wedge => &[
            &[0, 1, 2],
            &[3, 4, 5],
            &[0, 1, 4, 3],
            &[1, 2, 5, 4],
            &[2, 0, 3, 5],
        ],
        CellType::Pyramid => &[
            &[0, 1, 2, 3],
            &[0, 1, 4],
            &[1, 2, 4],
            &[2, 3, 4],
            &[3, 0, 4],
        ],
    }
}

impl TetMesh {
    /// `offset` is subtracted from every point (exactly: see [`MeshGeometry::new`]).
    ///
    /// [`MeshGeometry::new`]: super::MeshGeometry::new
    pub fn build(mesh: &UnstructuredMesh, offset: DVec3) -> Result<TetMesh, String> {
        let mut points: Vec<DVec3> = mesh
            .points
            .iter()
            .map(|p| DVec3::from_array(*p) - offset)
            .collect();
        let mut tets = Vec::with_capacity(mesh.cells());
        let mut tet_cell = Vec::with_capacity(mesh.cells());
        let mut report = LoadReport {
            cells: mesh.cells(),
            ..Default::default()
        };
        // Majority orientation per type, for the inverted count.
        let mut signs: Vec<f64> = Vec::with_capacity(mesh.cells());
        let mut push = |t: [u32; 4], cell: usize, points: &[DVec3], tets: &mut Vec<[u32; 4]>| {
            let p = |i: usize| points[t[i] as usize];
            let o = orient(p(0), p(1), p(2), p(3));
            if o == 0.0 {
                return false;
            }
            tets.push(if o > 0.0 { t } else { [t[0], t[2], t[1], t[3]] });
            tet_cell.push(cell as u32);
            true
        };
        for c in 0..mesh.cells() {
            let ty = mesh.cell_types[c];
            let ids = mesh.cell(c);
            let xs: Vec<DVec3> = ids.iter().map(|&i| points[i as usize]).collect();
            signs.push(interp::orientation(ty, &xs));
            let before = tets.len();
            let mut flat = 0;
            if ty == CellType::Tetra {
                if !push([ids[0], ids[1], ids[2], ids[3]], c, &points, &mut tets) {
                    flat += 1;
                }
            } else {
                if points.len() >= u32::MAX as usize - 1 {
                    return Err("too many points with the cell centroids".into());
                }
                let centre = xs.iter().copied().sum::<DVec3>() / xs.len() as f64;
                let ci = points.len() as u32;
                points.push(centre);
                for f in cell_faces(ty) {
                    let g: Vec<u32> = f.iter().map(|&k| ids[k]).collect();
                    let tris: Vec<[u32; 3]> = if g.len() == 3 {
                        vec![[g[0], g[1], g[2]]]
                    } else {
                        let m = (0..4).min_by_key(|&k| g[k]).unwrap_or(0);
                        if m % 2 == 0 {
                            vec![[g[0], g[1], g[2]], [g[0], g[2], g[3]]]
                        } else {
                            vec![[g[1], g[2], g[3]], [g[1], g[3], g[0]]]
                        }
                    };
                    for t in tris {
                        if !push([t[0], t[1], t[2], ci], c, &points, &mut tets) {
                            flat += 1;
                        }
                    }
                }
            }
            report.flat_tetrahedra += flat;
            if tets.len() == before {
                report.degenerate_cells += 1;
            }
            if tets.len() >= (1 << 30) {
                return Err("more than 2^30 tetrahedra".into());
            }
        }
        for ty in [
            CellType::Tetra,
            CellType::Hexahedron,
            CellType::Wedge,
            CellType::Pyramid,
        ] {
            let of_type = || (0..mesh.cells()).filter(|&c| mesh.cell_types[c] == ty);
            let pos = of_type().filter(|&c| signs[c] > 0.0).count();
            let neg = of_type().filter(|&c| signs[c] < 0.0).count();
            report.inverted_cells += pos.min(neg);
        }
        let (neighbors, boundary, nonmanifold) = adjacency(&tets);
        report.tetrahedra = tets.len();
        report.boundary_faces = boundary;
        report.non_manifold_faces = nonmanifold;
        Ok(TetMesh {
            points,
            tets,
            tet_cell,
            neighbors,
            cell_types: mesh.cell_types.clone(),
            offsets: mesh.offsets.clone(),
            connectivity: mesh.connectivity.clone(),
            report,
        })
    }

    #[inline]
    pub fn corners(&self, tet: u32) -> [DVec3; 4] {
        let t = self.tets[tet as usize];
        [
            self.points[t[0] as usize],
            self.points[t[1] as usize],
            self.points[t[2] as usize],
            self.points[t[3] as usize],
        ]
    }

    /// The outward triangle of face `k` of `tet`.
    #[inline]
    pub fn face(&self, tet: u32, k: usize) -> [DVec3; 3] {
        let c = self.corners(tet);
        let f = FACES[k];
        [c[f[0]], c[f[1]], c[f[2]]]
    }

    /// True if `x` is in the closed tetrahedron (exactly).
    pub fn contains(&self, tet: u32, x: DVec3) -> bool {
        (0..4).all(|k| {
            let f = self.face(tet, k);
            orient(f[0], f[1], f[2], x) >= 0.0
        })
    }

    /// True if `x` is strictly inside the tetrahedron (on no face; exactly).
    pub fn strictly_contains(&self, tet: u32, x: DVec3) -> bool {
        (0..4).all(|k| {
            let f = self.face(tet, k);
            orient(f[0], f[1], f[2], x) > 0.0
        })
    }

    /// The cell's point ids.
    pub fn cell(&self, c: u32) -> &[u32] {
        &self.connectivity[self.offsets[c as usize]..self.offsets[c as usize + 1]]
    }

    pub fn memory_bytes(&self) -> usize {
        self.points.capacity() * 24
            + self.tets.capacity() * 16
            + self.tet_cell.capacity() * 4
            + self.neighbors.capacity() * 16
            + self.offsets.capacity() * 8
            + self.connectivity.capacity() * 4
            + self.cell_types.capacity()
    }
}

/// Neighbours across faces, by sorting the faces' sorted vertex triples; the number of
/// boundary faces and of faces shared by more than two tetrahedra.
fn adjacency(tets: &[[u32; 4]]) -> (Vec<[u32; 4]>, usize, usize) {
    let mut faces: Vec<([u32; 3], u32)> = Vec::with_capacity(tets.len() * 4);
    for (i, t) in tets.iter().enumerate() {
        for (k, f) in FACES.iter().enumerate() {
            let mut key = [t[f[0]], t[f[1]], t[f[2]]];
            key.sort_unstable();
            faces.push((key, ((i as u32) << 2) | k as u32));
        }
    }
    faces.sort_unstable();
    let mut neighbors = vec![[NONE; 4]; tets.len()];
    let (mut boundary, mut nonmanifold) = (0, 0);
    let mut i = 0;
    while i < faces.len() {
        let mut j = i + 1;
        while j < faces.len() && faces[j].0 == faces[i].0 {
            j += 1;
        }
        match j - i {
            1 => boundary += 1,
            2 => {
                let (a, b) = (faces[i].1, faces[i + 1].1);
                neighbors[(a >> 2) as usize][(a & 3) as usize] = b;
                neighbors[(b >> 2) as usize][(b & 3) as usize] = a;
            }
            n => {
                nonmanifold += 1;
                boundary += n;
            }
        }
        i = j;
    }
    (neighbors, boundary, nonmanifold)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The predicate's sign convention and the outward faces of a positive tet.
    #[test]
    fn faces_look_outward() {
        let v = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
        // Positive as the walk needs it.
        let (v1, v2) = if orient(v[0], v[1], v[2], v[3]) > 0.0 {
            (v[1], v[2])
        } else {
            (v[2], v[1])
        };
        let v = [v[0], v1, v2, v[3]];
        assert!(orient(v[0], v[1], v[2], v[3]) > 0.0);
        let centroid = (v[0] + v[1] + v[2] + v[3]) / 4.0;
        for f in FACES {
            // The centroid is on the inner side: orient(face, centroid) > 0.
            assert!(orient(v[f[0]], v[f[1]], v[f[2]], centroid) > 0.0, "{f:?}");
        }
    }
}
