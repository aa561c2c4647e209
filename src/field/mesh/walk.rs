//! Walking a ray from tetrahedron to tetrahedron through shared faces.
//!
//! The ray is the exact line through two floating-point points `p` (its origin) and `q`
//! (a point further along it). Which face it leaves a tetrahedron through is decided
//! only by the signs of `orient3d(p, q, a, b)` for the tetrahedron's edges `ab` —
//! Plücker side tests, exact (Shewchuk's adaptive predicates in the `robust` crate), so
//! two tetrahedra sharing an edge never disagree about which side of it the ray
//! passes. A face is an exit when the line crosses its closed triangle from inside to
//! outside: no side positive, not all zero (all zero is a line in the face's plane).
//! The parameter at the crossing comes from the same side values (they are the
//! barycentric weights of the crossing point), and t is carried forward from tet to
//! tet (never backward), so the pieces the walk reports tile the ray's stretch inside
//! the mesh: no length is lost or counted twice, whatever the ray passes through.
//!
//! Rays exactly through an edge or a vertex may step into a tetrahedron that touches
//! the line at that one point and has no exit (the line passes it by): the walk then
//! locates the point a hair (`tol`) further along, and carries on from the
//! tetrahedron there. Leaving through a boundary face, it asks the boundary BVH for the
//! next face the line enters through (a non-convex mesh is re-entered).

use super::bvh::FaceBvh;
use super::geometry::{FACES, NONE, TetMesh};
use super::lattice::Lattice;
pub use super::line::Line;
use super::line::exit_point;

/// Counters of one walk (for tests and the benchmark).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WalkStats {
    /// Tetrahedra stepped through.
    pub steps: u64,
    /// Times the walk re-located itself past an edge or vertex.
    pub relocations: u64,
    /// Times it entered through a boundary face.
    pub entries: u64,
}

pub struct Walker<'a> {
    pub mesh: &'a TetMesh,
    pub bvh: &'a FaceBvh,
    pub lattice: &'a Lattice,
    /// A length far below any cell of interest (1e-10 of the mesh's diagonal).
    pub tol: f64,
    pub scale: f64,
}

const RING: usize = 8;

/// Where a walk stopped at its end `t1`, to go on from there without locating the
/// point again: inside a tetrahedron (entered through face `from`, 4 for none), or
/// outside the mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Resume {
    Inside(u32, usize),
    Outside,
}

impl Walker<'_> {
    /// Calls `f(tet, ta, tb)` for consecutive pieces of `[t0, t1]` inside the mesh,
    /// front to back, each in the tetrahedron `tet`.
    pub fn walk(&self, line: &Line, t0: f64, t1: f64, f: impl FnMut(u32, f64, f64)) -> WalkStats {
        self.walk_from(line, t0, t1, None, f).0
    }

    /// [`Walker::walk`] starting from where a previous walk of the same line ended at
    /// `t0` (`None`: locate the point at `t0`), returning where this one ends.
    pub fn walk_from(
        &self,
        line: &Line,
        t0: f64,
        t1: f64,
        start: Option<Resume>,
        mut f: impl FnMut(u32, f64, f64),
    ) -> (WalkStats, Option<Resume>) {
        let mut st = WalkStats::default();
        if !(t1 > t0) {
            return (st, start);
        }
        let mut t = t0;
        let mut cur: Option<(u32, usize)> = match start {
            Some(Resume::Inside(tet, from)) => Some((tet, from)),
            Some(Resume::Outside) => None,
            None => self.lattice.locate(self.mesh, line.at(t0)).map(|c| (c, 4)),
        };
        let mut stop = None;
        // The previous tet's vertex ids and edge sides (NONE ids: none yet).
        let mut prev_ids = [NONE; 4];
        let mut prev_s = [[0.0f64; 4]; 4];
        let mut entered: [u32; RING] = [NONE; RING];
        let mut n_entered = 0usize;
        let mut recent: [u32; RING] = [NONE; RING];
        let mut n_recent = 0usize;
        let mut stalled = 0u32;
        let budget = 4 * self.mesh.tets.len() as u64 + 10_000;
        while st.steps < budget {
            let (tet, from) = match cur {
                Some(c) => c,
                None => {
                    let Some(e) = self
                        .bvh
                        .first_entry(self.mesh, line, t - self.tol, &entered)
                    else {
                        break;
                    };
                    if e.t >= t1 {
                        stop = Some(Resume::Outside);
                        break;
                    }
                    st.entries += 1;
                    entered[n_entered % RING] = e.face;
                    n_entered += 1;
                    t = t.max(e.t);
                    ((e.face >> 2), (e.face & 3) as usize)
                }
            };
            st.steps += 1;
            let c = self.mesh.corners(tet);
            let ids = self.mesh.tets[tet as usize];
            // Sides of the six edges: s[i][j] for i < j. The three edges of the face
            // just crossed were decided in the previous tet: the same exact values.
            let mut s = [[0.0f64; 4]; 4];
            for i in 0..4 {
                for j in i + 1..4 {
                    let pi = prev_ids.iter().position(|&v| v == ids[i]);
                    let pj = prev_ids.iter().position(|&v| v == ids[j]);
                    s[i][j] = match (pi, pj) {
                        (Some(a), Some(b)) if a < b => prev_s[a][b],
                        (Some(a), Some(b)) => -prev_s[b][a],
                        _ => line.side(c[i], c[j]),
                    };
                }
            }
            prev_ids = ids;
            prev_s = s;
            let side = |i: usize, j: usize| if i < j { s[i][j] } else { -s[j][i] };
            let mut best: Option<(usize, f64, u32, bool)> = None;
            for (k, fv) in FACES.iter().enumerate() {
                if k == from {
                    continue;
                }
                let tri = [c[fv[0]], c[fv[1]], c[fv[2]]];
                let sv = [side(fv[0], fv[1]), side(fv[1], fv[2]), side(fv[2], fv[0])];
                if let Some((tx, zeros)) = exit_point(line, &tri, sv) {
                    let nb = self.mesh.neighbors[tet as usize][k];
                    let seen = nb != NONE && recent[..n_recent.min(RING)].contains(&(nb >> 2));
                    let better = match best {
                        None => true,
                        Some((_, _, bz, bseen)) => (seen, zeros) < (bseen, bz),
                    };
                    if better {
                        best = Some((k, tx, zeros, seen));
                    }
                }
            }
            let Some((k, tx, _, _)) = best else {
                // The line only touches this tet: find where it goes a hair further on.
                st.relocations += 1;
                let probe = t + self.tol;
                if probe >= t1 {
                    break;
                }
                cur = self
                    .lattice
                    .locate(self.mesh, line.at(probe))
                    .map(|c| (c, 4));
                if stalled > 2 {
                    t = probe; // give up the hair, never loop
                }
                stalled += 1;
                n_recent = 0;
                continue;
            };
            let t_exit = tx.max(t);
            let end = t_exit.min(t1);
            if end > t {
                f(tet, t, end);
                stalled = 0;
                n_recent = 0;
            } else {
                recent[n_recent % RING] = tet;
                n_recent += 1;
                stalled += 1;
                if stalled as usize > 4 * RING {
                    // Circling an edge or vertex: go on from a hair further.
                    st.relocations += 1;
                    let probe = t + self.tol;
                    cur = self
                        .lattice
                        .locate(self.mesh, line.at(probe))
                        .map(|c| (c, 4));
                    t = probe;
                    stalled = 0;
                    n_recent = 0;
                    continue;
                }
            }
            if t_exit >= t1 {
                stop = Some(Resume::Inside(tet, from));
                break;
            }
            t = t_exit;
            let nb = self.mesh.neighbors[tet as usize][k];
            cur = if nb == NONE {
                None
            } else {
                Some((nb >> 2, (nb & 3) as usize))
            };
        }
        (st, stop)
    }
}
