//! One direction's upwind sweep through the multiple-scattering lattice of
//! [`super::ms_lattice`]: short characteristics from each node back to the plane of nodes
//! behind it, bilinear there, with a source linear along the step.
//!
//! A node reads only the plane behind it, so a plane's rows are independent of each
//! other: each plane is split into `pieces` runs of rows done at once (the lattice has
//! 20–32 directions; on more threads than that, or where directions' sweeps differ in
//! cost, the threads left over take rows of the sweeps still running). Every node is
//! computed the same way whatever the split, so the result is the same to the bit for
//! any number of pieces or threads.

use glam::DVec3;
use rayon::prelude::*;

/// Node indexing: x fastest.
pub(super) struct Grid {
    pub dims: [usize; 3],
    pub stride: [usize; 3],
    pub len: usize,
}

impl Grid {
    pub fn new(dims: [usize; 3]) -> Grid {
        Grid {
            dims,
            stride: [1, dims[0], dims[0] * dims[1]],
            len: dims[0] * dims[1] * dims[2],
        }
    }
    pub fn coords(&self, n: usize) -> [usize; 3] {
        let [nx, ny, _] = self.dims;
        [n % nx, (n / nx) % ny, n / (nx * ny)]
    }
}

/// Directions whose radiances are added together before their sum joins the order's
/// (a fixed grouping: the sum over directions is done in the same order for any thread
/// count, and by a [`Sweeper`] too).
pub const DIRECTION_GROUP: usize = 4;

/// One order's sweeps in every direction, handed to a [`Sweeper`]'s lattice.
pub struct OrderJob<'a> {
    /// `ρ·J` per node, `channels` floats a node (x fastest).
    pub source: &'a [f32],
    /// Direction `k`'s source at node `n` is the source times
    /// `weights[k + n·weight_stride]` (the first order's phase function; stride 0: one
    /// weight per direction).
    pub weights: &'a [f32],
    pub weight_stride: usize,
    /// The order's directions; each swept as [`geometry`] sets it up.
    pub dirs: &'a [DVec3],
    /// Per channel: reduced extinction per unit density and the albedo.
    pub sigma_t: &'a [f64],
    pub albedo: &'a [f64],
    /// Cell side.
    pub h: f64,
    /// Whether the flux `G` is wanted.
    pub flux: bool,
}

/// An order's means over its directions, per node: `J` (`channels` floats a node) and,
/// where asked for, `G = ⟨L·d⟩` (`3·channels`: x y z per channel). Each sum over
/// directions is done as [`sweep`]'s caller does it: groups of [`DIRECTION_GROUP`] in
/// direction order, `L·d` with `d` in f32, then the groups in order, times
/// `1/directions` in f32.
pub struct OrderMoments {
    pub j: Vec<f32>,
    pub g: Vec<f32>,
}

/// The lattice's sweeps done outside this module (on a GPU): each order's directions
/// swept and averaged there, what orders are swept and the tail decided here. The
/// sweeper lives above `integrate` (the render's GPU backend) and is passed down to
/// [`super::ms_lattice::MsLattice::build_with`], so `integrate` imports none of it.
pub trait Sweeper: Send + Sync {
    /// Takes a lattice of `dims` nodes with densities `rho`, swept `channels` at once
    /// over at most `directions` directions an order; an error leaves it to the CPU.
    fn open(
        &self,
        dims: [usize; 3],
        rho: &[f32],
        channels: usize,
        directions: usize,
    ) -> Result<Box<dyn SweptLattice + '_>, String>;

    /// Where it sweeps, for the stats.
    fn name(&self) -> String;
}

/// A lattice a [`Sweeper`] took.
pub trait SweptLattice {
    /// One order; an error leaves it and the orders after it to the CPU.
    fn order(&mut self, job: &OrderJob) -> Result<OrderMoments, String>;
}

/// Fewest nodes of a plane one piece of it is given (below this a task costs more to
/// hand out than to do).
const MIN_PIECE_NODES: usize = 512;

/// One direction's upwind sweep: `radiance[n]` = L(node n, d) given the source `ρ·J`
/// per node (`rho_j`), for `C` channels at once (a chromatic medium's, or a colour
/// grid's: the lattice's geometry and densities are read once for all of them).
///
/// The characteristic from a node goes back one node along `d`'s dominant axis `a`, so
/// its foot lies within one node of the node's own column on the other two axes: the
/// four nodes around it are in range everywhere but on the plane's edge rows, and the
/// loop over a row's interior needs no bounds checks (the lattice's cost is these
/// sweeps: `orders × directions × nodes` of them).
///
/// The radiance is swept plane by plane in `planes` (`grid.len` long; its contents on
/// entry do not matter), each plane contiguous, so a plane's runs of rows can be handed
/// to threads as slices; then put in node order in `radiance`. Along z the two orders
/// are the same and `planes` is not used. Each plane is split into at most `pieces`
/// runs of rows (1: the sweep on the calling thread alone).
#[allow(clippy::too_many_arguments)]
pub(super) fn sweep<const C: usize>(
    grid: &Grid,
    rho: &[f32],
    rho_j: &[[f32; C]],
    d: DVec3,
    sigma_t: [f64; C],
    albedo: [f64; C],
    h: f64,
    radiance: &mut [[f32; C]],
    planes: &mut [[f32; C]],
    pieces: usize,
) {
    let s = Setup::new(grid, d, sigma_t, albedo, h);
    if s.a == 2 {
        s.run(rho, rho_j, radiance, pieces);
        return;
    }
    s.run(rho, rho_j, planes, pieces);
    // Back to node order, a row of x at a time (x's stride in `planes`: 1 along y,
    // a plane along x).
    let [nx, ny, _] = grid.dims;
    let pl = s.plane_len();
    let (sx, sy, sz) = if s.a == 1 { (1, pl, nx) } else { (pl, 1, ny) };
    let planes = &*planes;
    radiance
        .par_chunks_mut(nx)
        .enumerate()
        .with_min_len((MIN_PIECE_NODES / nx.max(1)).max(1))
        .for_each(|(r, row)| {
            let at = (r % ny) * sy + (r / ny) * sz;
            for (x, v) in row.iter_mut().enumerate() {
                *v = planes[at + x * sx];
            }
        });
}

/// A direction's sweep geometry (what [`sweep`] works out once per direction), for a
/// sweep done elsewhere to step exactly as this one does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepGeometry {
    /// The dominant axis `a`, the row axis `b` and the third `c`.
    pub axes: [usize; 3],
    /// Bilinear weights at the characteristic's foot: of the plane behind's nodes
    /// (b + fb, c + fc), (b + fb + 1, c + fc), (b + fb, c + fc + 1) and
    /// (b + fb + 1, c + fc + 1), in that order.
    pub w: [f32; 4],
    pub fb: isize,
    pub fc: isize,
    /// The planes are swept in increasing `a` (else decreasing).
    pub forward: bool,
    /// The characteristic's world length: a node's `σt·step` is `(σt·step) as f32`.
    pub step: f64,
}

/// The sweep geometry of direction `d` on a lattice of cell side `h`.
pub fn geometry(d: DVec3, h: f64) -> SweepGeometry {
    let da = d.abs();
    let a = if da.x >= da.y && da.x >= da.z {
        0
    } else if da.y >= da.z {
        1
    } else {
        2
    };
    // The row axis b is the other axis with the smaller stride, so a row's nodes are
    // near each other in memory.
    let (b, cax) = if a == 0 { (1, 2) } else { (0, 3 - a) };
    let dv = d.to_array();
    let step = h / da[a]; // world length of the characteristic
    // Upstream point, in nodes, relative to the node along b and c (|o| ≤ 1).
    let ob = -step * dv[b] / h;
    let oc = -step * dv[cax] / h;
    let (fb, fc) = (ob.floor(), oc.floor());
    let (wb, wc) = (ob - fb, oc - fc);
    SweepGeometry {
        axes: [a, b, cax],
        w: [
            ((1.0 - wb) * (1.0 - wc)) as f32,
            (wb * (1.0 - wc)) as f32,
            ((1.0 - wb) * wc) as f32,
            (wb * wc) as f32,
        ],
        fb: fb as isize,
        fc: fc as isize,
        forward: dv[a] > 0.0,
        step,
    }
}

/// A sweep's geometry, worked out once.
struct Setup<const C: usize> {
    /// The dominant axis, the row axis and the third.
    a: usize,
    b: usize,
    cax: usize,
    /// Bilinear weights at the foot, and its offset (in nodes) from the node along b, c.
    w: [f32; 4],
    fb: isize,
    fc: isize,
    forward: bool,
    node: Node<C>,
    stride: [usize; 3],
    dims: [usize; 3],
    /// Rows (along b) whose four upstream nodes are all in range.
    ib_lo: usize,
    ib_hi: usize,
}

impl<const C: usize> Setup<C> {
    fn new(grid: &Grid, d: DVec3, sigma_t: [f64; C], albedo: [f64; C], h: f64) -> Self {
        let SweepGeometry {
            axes: [a, b, cax],
            w,
            fb,
            fc,
            forward,
            step,
        } = geometry(d, h);
        let dims = grid.dims;
        let nb = dims[b] as isize;
        // ib + fb ≥ 0 and ib + fb + 1 < nb.
        let ib_lo = (-fb).clamp(0, nb) as usize;
        let ib_hi = (nb - 1 - fb).clamp(ib_lo as isize, nb) as usize;
        Setup {
            a,
            b,
            cax,
            w,
            fb,
            fc,
            forward,
            node: Node {
                sigma_step: sigma_t.map(|s| (s * step) as f32),
                albedo: albedo.map(|a| a as f32),
            },
            stride: grid.stride,
            dims,
            ib_lo,
            ib_hi,
        }
    }

    /// Nodes of a plane; in `run`'s buffer node (ia, ib, ic) is at
    /// `ia·plane_len + ic·nb + ib`.
    fn plane_len(&self) -> usize {
        self.dims[self.b] * self.dims[self.cax]
    }

    /// The sweep, plane after plane, into `out` in plane order.
    fn run(&self, rho: &[f32], rho_j: &[[f32; C]], out: &mut [[f32; C]], pieces: usize) {
        let (na, nb, nc) = (self.dims[self.a], self.dims[self.b], self.dims[self.cax]);
        let pl = nb * nc;
        if pl == 0 {
            return;
        }
        // Rows per piece: the plane in at most `pieces` runs of at least
        // MIN_PIECE_NODES nodes.
        let rows = nc
            .div_ceil(pieces.max(1))
            .max(MIN_PIECE_NODES.div_ceil(nb))
            .max(1);
        for ia_step in 0..na {
            let ia = if self.forward {
                ia_step
            } else {
                na - 1 - ia_step
            };
            let up = if self.forward {
                ia.checked_sub(1)
            } else {
                Some(ia + 1).filter(|u| *u < na)
            };
            let (cur, prev): (&mut [[f32; C]], &[[f32; C]]) = match up {
                None => (&mut out[ia * pl..(ia + 1) * pl], &[]),
                Some(u) if u < ia => {
                    let (done, rest) = out.split_at_mut(ia * pl);
                    (&mut rest[..pl], &done[u * pl..(u + 1) * pl])
                }
                Some(u) => {
                    let (rest, done) = out.split_at_mut(u * pl);
                    (&mut rest[ia * pl..(ia + 1) * pl], &done[..pl])
                }
            };
            let piece = |(p, chunk): (usize, &mut [[f32; C]])| {
                for (r, row) in chunk.chunks_mut(nb).enumerate() {
                    self.row(rho, rho_j, ia, up, p * rows + r, prev, row);
                }
            };
            if rows >= nc {
                piece((0, cur));
            } else {
                cur.par_chunks_mut(rows * nb).enumerate().for_each(piece);
            }
        }
    }

    /// Row `ic` of plane `ia` into `out` (`nb` nodes), from the plane `up` behind it,
    /// whose radiance is `prev` (none for the first plane: nothing comes in from
    /// outside the lattice).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn row(
        &self,
        rho: &[f32],
        rho_j: &[[f32; C]],
        ia: usize,
        up: Option<usize>,
        ic: usize,
        prev: &[[f32; C]],
        out: &mut [[f32; C]],
    ) {
        let (st, node, w) = (&self.stride, &self.node, &self.w);
        let (sb, sc) = (st[self.b], st[self.cax]);
        let (nb, nc) = (self.dims[self.b], self.dims[self.cax]);
        let row = ia * st[self.a] + ic * sc;
        let Some(up_a) = up else {
            let zero = [0f32; C];
            for (ib, o) in out.iter_mut().enumerate() {
                let n = row + ib * sb;
                *o = node.radiance(&zero, 0.0, &zero, rho[n], &rho_j[n]);
            }
            return;
        };
        let up_plane = up_a * st[self.a];
        let jc = ic as isize + self.fc;
        let (nbi, nci) = (nb as isize, nc as isize);
        // The upstream values at the foot, with bounds checks.
        let checked = |ib: usize| -> ([f32; C], f32, [f32; C]) {
            let (mut l, mut r, mut rj) = ([0f32; C], 0.0f32, [0f32; C]);
            for (k, wk) in w.iter().enumerate() {
                let (jb, jc) = (
                    ib as isize + self.fb + (k & 1) as isize,
                    jc + (k >> 1) as isize,
                );
                if *wk == 0.0 || jb < 0 || jc < 0 || jb >= nbi || jc >= nci {
                    continue;
                }
                let (jb, jc) = (jb as usize, jc as usize);
                let m = up_plane + jb * sb + jc * sc;
                let p = jc * nb + jb;
                r += wk * rho[m];
                for ch in 0..C {
                    l[ch] += wk * prev[p][ch];
                    rj[ch] += wk * rho_j[m][ch];
                }
            }
            (l, r, rj)
        };
        if jc < 0 || jc + 1 >= nci {
            for (ib, o) in out.iter_mut().enumerate() {
                let n = row + ib * sb;
                let (l, r, rj) = checked(ib);
                *o = node.radiance(&l, r, &rj, rho[n], &rho_j[n]);
            }
            return;
        }
        for ib in (0..self.ib_lo).chain(self.ib_hi..nb) {
            let n = row + ib * sb;
            let (l, r, rj) = checked(ib);
            out[ib] = node.radiance(&l, r, &rj, rho[n], &rho_j[n]);
        }
        // The row's interior: the four upstream nodes m, m + sb, m + sc, m + sb + sc
        // (in `prev`, p, p + 1, p + nb, p + nb + 1).
        let jc = jc as usize;
        let up_row = up_plane + jc * sc;
        let prev_row = jc * nb;
        for (ib, o) in out.iter_mut().enumerate().take(self.ib_hi).skip(self.ib_lo) {
            let n = row + ib * sb;
            let jb = (ib as isize + self.fb) as usize;
            let m = up_row + jb * sb;
            let p = prev_row + jb;
            let taps = [
                (m, p),
                (m + sb, p + 1),
                (m + sc, p + nb),
                (m + sb + sc, p + nb + 1),
            ];
            let (mut l, mut r, mut rj) = ([0f32; C], 0.0f32, [0f32; C]);
            for ((t, q), wk) in taps.iter().zip(w) {
                r += wk * rho[*t];
                for ch in 0..C {
                    l[ch] += wk * prev[*q][ch];
                    rj[ch] += wk * rho_j[*t][ch];
                }
            }
            *o = node.radiance(&l, r, &rj, rho[n], &rho_j[n]);
        }
    }
}

/// One node's update along its characteristic, per channel.
struct Node<const C: usize> {
    sigma_step: [f32; C],
    albedo: [f32; C],
}

impl<const C: usize> Node<C> {
    /// L at a node from the upstream radiance `l_up`, density `r_up` and source `rj_up`
    /// (bilinear at the characteristic's foot) and the node's own density and source:
    /// density the mean of the two ends, the source linear along the step.
    #[inline(always)]
    fn radiance(
        &self,
        l_up: &[f32; C],
        r_up: f32,
        rj_up: &[f32; C],
        r_here: f32,
        rj_here: &[f32; C],
    ) -> [f32; C] {
        let rho_mean = 0.5 * (r_here + r_up);
        if rho_mean <= 0.0 {
            return *l_up;
        }
        let mut out = [0f32; C];
        for ch in 0..C {
            let tau = self.sigma_step[ch] * rho_mean;
            let j_up = if r_up > 0.0 { rj_up[ch] / r_up } else { 0.0 };
            let (j_here, j_up) = match (r_here > 0.0, r_up > 0.0) {
                (true, true) => (rj_here[ch] / r_here, j_up),
                (true, false) => (rj_here[ch] / r_here, rj_here[ch] / r_here),
                (false, _) => (j_up, j_up),
            };
            let e = (-tau).exp();
            // 1 − e^{−τ} and P = (1 − e^{−τ} − τ·e^{−τ})/τ, by their series where τ is small.
            let (one_minus, p) = if tau < 1e-2 {
                (
                    tau * (1.0 - 0.5 * tau * (1.0 - tau / 3.0)),
                    tau * (0.5 - tau * (1.0 / 3.0 - tau / 8.0)),
                )
            } else {
                let om = 1.0 - e;
                (om, (om - tau * e) / tau)
            };
            let l = l_up[ch] * e + self.albedo[ch] * (j_here * (one_minus - p) + j_up * p);
            out[ch] = l.max(0.0);
        }
        out
    }
}

#[cfg(test)]
#[path = "ms_sweep_tests.rs"]
mod tests;
