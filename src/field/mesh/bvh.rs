//! A bounding-volume hierarchy over the mesh's boundary faces: where a ray enters the
//! mesh (first, or again after leaving a non-convex part).
//!
//! Boxes are padded so that the floating-point box test never rejects a face the exact
//! line test would accept; the decision itself is the exact one of [`super::walk`].

use super::geometry::{NONE, TetMesh};
use super::line::{Line, crossing};
use glam::DVec3;

#[derive(Clone, Copy)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    /// Leaf: first face and count; inner: right child (left is the next node), count 0.
    first: u32,
    count: u32,
}

/// Boundary faces as `(tet << 2) | face`, in a BVH.
pub struct FaceBvh {
    faces: Vec<u32>,
    nodes: Vec<Node>,
}

/// A boundary face the ray enters the mesh through.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Entry {
    pub face: u32,
    pub t: f64,
}

impl FaceBvh {
    pub fn build(mesh: &TetMesh, pad: f64) -> FaceBvh {
        let mut faces = Vec::new();
        for (i, n) in mesh.neighbors.iter().enumerate() {
            for (k, &nb) in n.iter().enumerate() {
                if nb == NONE {
                    faces.push(((i as u32) << 2) | k as u32);
                }
            }
        }
        let tri = |f: u32| mesh.face(f >> 2, (f & 3) as usize);
        let centroids: Vec<DVec3> = faces
            .iter()
            .map(|&f| {
                let t = tri(f);
                (t[0] + t[1] + t[2]) / 3.0
            })
            .collect();
        let mut order: Vec<usize> = (0..faces.len()).collect();
        let mut nodes = Vec::with_capacity(2 * faces.len() / 4 + 1);
        build_node(
            &mut nodes,
            &mut order[..],
            0,
            &centroids,
            &|i| tri(faces[i]),
            pad,
        );
        let faces = order.iter().map(|&i| faces[i]).collect();
        FaceBvh { faces, nodes }
    }

    pub fn len(&self) -> usize {
        self.faces.len()
    }

    pub fn is_empty(&self) -> bool {
        self.faces.is_empty()
    }

    pub fn memory_bytes(&self) -> usize {
        self.faces.capacity() * 4 + self.nodes.capacity() * std::mem::size_of::<Node>()
    }

    /// The first boundary face (smallest t ≥ `t_min`) the line enters the mesh through,
    /// skipping `skip`; ties prefer a crossing through the face's interior.
    pub fn first_entry(
        &self,
        mesh: &TetMesh,
        line: &Line,
        t_min: f64,
        skip: &[u32],
    ) -> Option<Entry> {
        if self.nodes.is_empty() {
            return None;
        }
        let inv = DVec3::ONE / line.dir;
        let mut best: Option<(Entry, u32)> = None;
        let mut stack = [0u32; 64];
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let idx = stack[sp];
            let n = self.nodes[idx as usize];
            let t_far = best.map_or(f64::INFINITY, |(b, _)| b.t);
            if !slab(line.origin, inv, n.lo, n.hi, t_min, t_far) {
                continue;
            }
            if n.count > 0 {
                for &f in &self.faces[n.first as usize..(n.first + n.count) as usize] {
                    if skip.contains(&f) {
                        continue;
                    }
                    let tri = mesh.face(f >> 2, (f & 3) as usize);
                    // Entering: the face seen from outside, so its reverse is an exit.
                    if let Some((t, zeros)) = crossing(line, [tri[0], tri[2], tri[1]])
                        && t >= t_min
                    {
                        let better = match best {
                            None => true,
                            Some((b, bz)) => t < b.t || (t == b.t && zeros < bz),
                        };
                        if better {
                            best = Some((Entry { face: f, t }, zeros));
                        }
                    }
                }
            } else if sp + 2 <= stack.len() {
                // Right child stored, left child next.
                stack[sp] = n.first;
                stack[sp + 1] = idx + 1;
                sp += 2;
            }
        }
        best.map(|(e, _)| e)
    }
}

fn build_node(
    nodes: &mut Vec<Node>,
    items: &mut [usize],
    offset: usize,
    centroids: &[DVec3],
    tri: &dyn Fn(usize) -> [DVec3; 3],
    pad: f64,
) -> u32 {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for &i in items.iter() {
        for p in tri(i) {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    let me = nodes.len() as u32;
    nodes.push(Node {
        lo: lo - DVec3::splat(pad),
        hi: hi + DVec3::splat(pad),
        first: offset as u32,
        count: items.len() as u32,
    });
    if items.len() <= 4 {
        return me;
    }
    let ext = hi - lo;
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |&a, &b| {
        centroids[a][axis].total_cmp(&centroids[b][axis])
    });
    let (left, right) = items.split_at_mut(mid);
    build_node(nodes, left, offset, centroids, tri, pad);
    let r = build_node(nodes, right, offset + mid, centroids, tri, pad);
    nodes[me as usize].first = r;
    nodes[me as usize].count = 0;
    me
}

/// Does `o + t·d` (with `inv = 1/d`) meet the box within `[t0, t1]`?
fn slab(o: DVec3, inv: DVec3, lo: DVec3, hi: DVec3, t0: f64, t1: f64) -> bool {
    let (mut a, mut b) = (t0, t1);
    for k in 0..3 {
        if inv[k].is_infinite() {
            if o[k] < lo[k] || o[k] > hi[k] {
                return false;
            }
            continue;
        }
        let (mut u, mut v) = ((lo[k] - o[k]) * inv[k], (hi[k] - o[k]) * inv[k]);
        if u > v {
            std::mem::swap(&mut u, &mut v);
        }
        a = a.max(u);
        b = b.min(v);
        if a > b {
            return false;
        }
    }
    true
}
