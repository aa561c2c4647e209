//! One direction's upwind sweep through the multiple-scattering lattice of
//! [`super::ms_lattice`]: short characteristics from each node back to the plane of nodes
//! behind it, bilinear there, with a source linear along the step.

use glam::DVec3;

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

/// One direction's upwind sweep: `radiance[n]` = L(node n, d) given the source `ρ·J`
/// per node (`rho_j`).
#[allow(clippy::too_many_arguments)]
pub(super) fn sweep(
    grid: &Grid,
    rho: &[f32],
    rho_j: &[f32],
    d: DVec3,
    sigma_t: f64,
    albedo: f64,
    h: f64,
    radiance: &mut [f32],
) {
    let da = d.abs();
    let a = if da.x >= da.y && da.x >= da.z {
        0
    } else if da.y >= da.z {
        1
    } else {
        2
    };
    let (b, cax) = ((a + 1) % 3, (a + 2) % 3);
    let dv = d.to_array();
    let step = h / da[a]; // world length of the characteristic
    // Upstream point, in nodes, relative to the node along b and c.
    let ob = -step * dv[b] / h;
    let oc = -step * dv[cax] / h;
    let (fb, fc) = (ob.floor(), oc.floor());
    let (wb, wc) = (ob - fb, oc - fc);
    let (fb, fc) = (fb as isize, fc as isize);
    let weights = [
        (0isize, 0isize, (1.0 - wb) * (1.0 - wc)),
        (1, 0, wb * (1.0 - wc)),
        (0, 1, (1.0 - wb) * wc),
        (1, 1, wb * wc),
    ];
    let st = grid.stride;
    let dims = grid.dims;
    let forward = dv[a] > 0.0;
    let sigma_step = sigma_t * step;
    for ia_step in 0..dims[a] {
        let ia = if forward {
            ia_step
        } else {
            dims[a] - 1 - ia_step
        };
        let up_a = if forward {
            ia as isize - 1
        } else {
            ia as isize + 1
        };
        let has_up = up_a >= 0 && (up_a as usize) < dims[a];
        for ic in 0..dims[cax] {
            for ib in 0..dims[b] {
                let n = ia * st[a] + ib * st[b] + ic * st[cax];
                let (mut l_up, mut r_up, mut rj_up) = (0.0f64, 0.0f64, 0.0f64);
                if has_up {
                    for &(db, dc, w) in &weights {
                        if w == 0.0 {
                            continue;
                        }
                        let jb = ib as isize + fb + db;
                        let jc = ic as isize + fc + dc;
                        if jb < 0 || jc < 0 || jb as usize >= dims[b] || jc as usize >= dims[cax] {
                            continue;
                        }
                        let m = up_a as usize * st[a] + jb as usize * st[b] + jc as usize * st[cax];
                        l_up += w * radiance[m] as f64;
                        r_up += w * rho[m] as f64;
                        rj_up += w * rho_j[m] as f64;
                    }
                }
                let r_here = rho[n] as f64;
                let rho_mean = 0.5 * (r_here + r_up);
                if rho_mean <= 0.0 {
                    radiance[n] = l_up as f32;
                    continue;
                }
                let tau = sigma_step * rho_mean;
                let j_here = if r_here > 0.0 {
                    rho_j[n] as f64 / r_here
                } else {
                    0.0
                };
                let j_up = if r_up > 0.0 { rj_up / r_up } else { j_here };
                let j_here = if r_here > 0.0 { j_here } else { j_up };
                let e = (-tau).exp();
                // P = (1 − e^{−τ} − τ·e^{−τ})/τ, by its series where τ is small.
                let p = if tau < 1e-3 {
                    tau * (0.5 - tau / 3.0)
                } else {
                    (1.0 - e - tau * e) / tau
                };
                let one_minus = if tau < 1e-3 {
                    tau * (1.0 - 0.5 * tau)
                } else {
                    1.0 - e
                };
                let l = l_up * e + albedo * (j_here * (one_minus - p) + j_up * p);
                radiance[n] = l.max(0.0) as f32;
            }
        }
    }
}
