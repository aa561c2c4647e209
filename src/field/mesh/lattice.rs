//! The virtual lattice over a mesh: bricks of 8³ voxels covering its bounds, each
//! listing the tetrahedra whose bounding boxes overlap it. The traversal steps brick to
//! brick (with a majorant per brick from those tetrahedra's cells) and the walk
//! locates points with the lists (exact containment tests).

use super::geometry::TetMesh;
use crate::field::IndexToWorld;
use glam::{DMat4, DVec3, IVec3};

/// Voxels per brick edge.
pub const BRICK: i32 = 8;

pub struct Lattice {
    /// Index → world (the mesh's offset added back).
    pub transform: IndexToWorld,
    /// Corner of brick (0,0,0) in the mesh's coordinates (world minus its offset), and
    /// the edge of a brick.
    pub lo: DVec3,
    pub edge: f64,
    pub dims: IVec3,
    /// Brick `b`'s tetrahedra are `items[starts[b]..starts[b + 1]]`.
    pub starts: Vec<u32>,
    pub items: Vec<u32>,
}

/// List entries at most (beyond it the lattice is coarsened).
fn max_items(tets: usize) -> u64 {
    (64 * tets as u64).max(1 << 20)
}

/// Coordinates murk takes, in magnitude: the walk's exact predicates multiply three
/// differences of them, the lattice three extents, and neither may overflow or fall
/// into subnormals.
const MAX_COORD: f64 = 1e80;
/// The smallest diagonal of a mesh's bounds murk takes (see [`MAX_COORD`]).
const MIN_EXTENT: f64 = 1e-80;

/// Checks that a mesh with bounds `lo..hi` (of `n` points) can be walked, and returns
/// the offset its points are held relative to: per axis, the centre of the bounds where
/// it is over 1024 diagonals from the origin (there every coordinate is within a factor
/// of 2 of it, so subtracting it is exact), else 0.
pub(super) fn check_extent(lo: DVec3, hi: DVec3, n: usize) -> Result<DVec3, String> {
    let far = lo.abs().max(hi.abs()).max_element();
    if !(far <= MAX_COORD) {
        return Err(format!(
            "a point coordinate reaches {far:e}; murk takes coordinates up to {MAX_COORD:e} (scale the mesh down)"
        ));
    }
    let ext = hi - lo;
    let longest = ext.max_element();
    if longest == 0.0 {
        return Err(format!(
            "all {n} points are the same point: the mesh has no extent"
        ));
    }
    // Scaled: the squares of a tiny extent would underflow.
    let diag = longest * (ext / longest).length();
    if !(diag >= MIN_EXTENT) {
        return Err(format!(
            "the mesh is {diag:e} across; murk takes meshes at least {MIN_EXTENT:e} across (scale it up)"
        ));
    }
    let mid = (lo + hi) * 0.5;
    Ok(DVec3::select(
        mid.abs().cmpge(DVec3::splat(1024.0 * diag)),
        mid,
        DVec3::ZERO,
    ))
}

/// Bricks at most: the sizing below gives at most about 8 × 2²¹ for bounds the
/// geometry accepts; a lattice of more is coarsened, never allocated.
const MAX_BRICKS: u64 = 1 << 25;

impl Lattice {
    /// The lattice over the bounds `lo..hi` of `mesh`'s points (its coordinates);
    /// `offset` is where their origin lies in the world.
    pub fn build(mesh: &TetMesh, lo: DVec3, hi: DVec3, offset: DVec3) -> Result<Lattice, String> {
        let n = mesh.tets.len().max(1) as f64;
        let ext = (hi - lo).max(DVec3::splat(1e-300));
        let diag = ext.length();
        // About 8 tetrahedra a brick, at most 2^21 bricks; flat extents get one brick.
        let target = (n / 8.0).clamp(1.0, (1u64 << 21) as f64);
        let vol = ext.x.max(diag * 1e-3) * ext.y.max(diag * 1e-3) * ext.z.max(diag * 1e-3);
        let mut edge = (vol / target).cbrt().max(diag * 1e-6);
        let boxes: Vec<(DVec3, DVec3)> = (0..mesh.tets.len() as u32)
            .map(|t| {
                let c = mesh.corners(t);
                let mut a = c[0];
                let mut b = c[0];
                for p in &c[1..] {
                    a = a.min(*p);
                    b = b.max(*p);
                }
                (a, b)
            })
            .collect();
        loop {
            if !(edge > 0.0 && edge.is_finite()) {
                return Err(format!(
                    "the mesh's bounds ({:e} across) give no usable lattice",
                    ext.length()
                ));
            }
            let per_axis = (ext / edge).ceil().max(DVec3::ONE);
            if !(per_axis.element_product() <= MAX_BRICKS as f64) {
                edge *= 2.0;
                continue;
            }
            let dims = per_axis.as_ivec3();
            let range = |a: DVec3, b: DVec3| {
                let pad = edge * 1e-9;
                let i0 = (((a - lo - pad) / edge).floor().as_ivec3()).clamp(IVec3::ZERO, dims - 1);
                let i1 = (((b - lo + pad) / edge).floor().as_ivec3()).clamp(IVec3::ZERO, dims - 1);
                (i0, i1)
            };
            let mut total: u64 = 0;
            for (a, b) in &boxes {
                let (i0, i1) = range(*a, *b);
                let d = (i1 - i0 + 1).as_i64vec3();
                total += (d.x * d.y * d.z) as u64;
            }
            if total > max_items(mesh.tets.len()) {
                edge *= 2.0;
                continue;
            }
            let nb = (dims.x as usize) * (dims.y as usize) * (dims.z as usize);
            let mut counts = vec![0u32; nb + 1];
            let index = |i: IVec3| {
                (i.x as usize)
                    + (dims.x as usize) * ((i.y as usize) + (dims.y as usize) * (i.z as usize))
            };
            for (a, b) in &boxes {
                let (i0, i1) = range(*a, *b);
                for z in i0.z..=i1.z {
                    for y in i0.y..=i1.y {
                        for x in i0.x..=i1.x {
                            counts[index(IVec3::new(x, y, z)) + 1] += 1;
                        }
                    }
                }
            }
            for i in 0..nb {
                counts[i + 1] += counts[i];
            }
            let mut fill = counts.clone();
            let mut items = vec![0u32; total as usize];
            for (t, (a, b)) in boxes.iter().enumerate() {
                let (i0, i1) = range(*a, *b);
                for z in i0.z..=i1.z {
                    for y in i0.y..=i1.y {
                        for x in i0.x..=i1.x {
                            let k = index(IVec3::new(x, y, z));
                            items[fill[k] as usize] = t as u32;
                            fill[k] += 1;
                        }
                    }
                }
            }
            let voxel = edge / BRICK as f64;
            let m = DMat4::from_scale_rotation_translation(
                DVec3::splat(voxel),
                glam::DQuat::IDENTITY,
                lo + offset,
            );
            let transform = IndexToWorld::new(m, IVec3::ZERO)
                .ok_or("the mesh's bounds give no usable lattice")?;
            return Ok(Lattice {
                transform,
                lo,
                edge,
                dims,
                starts: counts,
                items,
            });
        }
    }

    /// The point in the mesh's coordinates of the index point `p` (as the transform
    /// maps it to the world, without the offset: no precision lost to it).
    #[inline]
    pub fn index_to_mesh(&self, p: DVec3) -> DVec3 {
        self.transform.linear() * p + self.lo
    }

    pub fn brick_count(&self) -> usize {
        self.starts.len() - 1
    }

    /// Index of brick `b` (brick coordinates), or `None` outside.
    #[inline]
    pub fn brick_index(&self, b: IVec3) -> Option<usize> {
        if b.cmplt(IVec3::ZERO).any() || b.cmpge(self.dims).any() {
            return None;
        }
        Some(
            (b.x as usize)
                + (self.dims.x as usize)
                    * ((b.y as usize) + (self.dims.y as usize) * (b.z as usize)),
        )
    }

    #[inline]
    pub fn tets_in(&self, b: usize) -> &[u32] {
        &self.items[self.starts[b] as usize..self.starts[b + 1] as usize]
    }

    /// A tetrahedron containing the world point `x` (closed, exact), or `None`.
    pub fn locate(&self, mesh: &TetMesh, x: DVec3) -> Option<u32> {
        let b = ((x - self.lo) / self.edge).floor();
        if !b.is_finite() {
            return None;
        }
        let bi = b.clamp(DVec3::splat(-1.0), self.dims.as_dvec3()).as_ivec3();
        // A point on a brick face may sit in the neighbouring brick's list only.
        let frac = (x - self.lo) / self.edge - b;
        let mut tries = vec![bi];
        for a in 0..3 {
            if frac[a] < 1e-9 {
                let mut o = bi;
                o[a] -= 1;
                tries.push(o);
            }
        }
        for bb in tries {
            let Some(k) = self.brick_index(bb) else {
                continue;
            };
            for &t in self.tets_in(k) {
                let c = mesh.corners(t);
                let (mut a, mut h) = (c[0], c[0]);
                for p in &c[1..] {
                    a = a.min(*p);
                    h = h.max(*p);
                }
                if x.cmplt(a).any() || x.cmpgt(h).any() {
                    continue;
                }
                if mesh.contains(t, x) {
                    return Some(t);
                }
            }
        }
        None
    }

    pub fn memory_bytes(&self) -> usize {
        self.starts.capacity() * 4 + self.items.capacity() * 4
    }
}
