//! The line a ray follows through a mesh, and where it leaves a triangle.
//!
//! The ray is the exact line through two floating-point points `p` and `q`; which side
//! of an edge it passes is `orient3d(p, q, a, b)`, exact (Shewchuk's adaptive
//! predicates), so the walk ([`walk`](super::walk)) and the boundary BVH
//! ([`bvh`](super::bvh)) agree on every crossing.

use super::geometry::orient;
use glam::DVec3;

/// The ray `origin + t·dir` and the two points defining its line for the predicates.
#[derive(Clone, Copy, Debug)]
pub struct Line {
    pub origin: DVec3,
    pub dir: DVec3,
    p: DVec3,
    q: DVec3,
    inv_dd: f64,
}

impl Line {
    /// `scale`: a length comparable to the mesh (q = origin + dir·scale).
    pub fn new(origin: DVec3, dir: DVec3, scale: f64) -> Line {
        let q = origin + dir * scale;
        Line {
            origin,
            dir,
            p: origin,
            q,
            inv_dd: 1.0 / dir.length_squared(),
        }
    }
    /// The line through `p` and `q` exactly (`t` in units of `q − p`, 0 at `p`).
    pub fn through(p: DVec3, q: DVec3) -> Line {
        let dir = q - p;
        Line {
            origin: p,
            dir,
            p,
            q,
            inv_dd: 1.0 / dir.length_squared(),
        }
    }
    #[inline]
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + self.dir * t
    }
    #[inline]
    fn t_of(&self, x: DVec3) -> f64 {
        (x - self.origin).dot(self.dir) * self.inv_dd
    }
    /// Exact side of the line relative to the directed edge `a → b`.
    #[inline]
    pub fn side(&self, a: DVec3, b: DVec3) -> f64 {
        orient(self.p, self.q, a, b)
    }
}

/// If the line leaves through the outward triangle `tri` (crossing it from behind):
/// the parameter of the crossing and how many of its three sides are exactly zero.
pub fn crossing(line: &Line, tri: [DVec3; 3]) -> Option<(f64, u32)> {
    let s = [
        line.side(tri[0], tri[1]),
        line.side(tri[1], tri[2]),
        line.side(tri[2], tri[0]),
    ];
    exit_point(line, &tri, s)
}

#[inline]
pub(super) fn exit_point(line: &Line, tri: &[DVec3; 3], s: [f64; 3]) -> Option<(f64, u32)> {
    if s.iter().any(|&v| v > 0.0) {
        return None;
    }
    let zeros = s.iter().filter(|&&v| v == 0.0).count() as u32;
    if zeros == 3 {
        return None;
    }
    let sum = s[0] + s[1] + s[2];
    // Weight of a vertex: the side of the edge opposite it.
    let x = (tri[0] * s[1] + tri[1] * s[2] + tri[2] * s[0]) / sum;
    Some((line.t_of(x), zeros))
}
