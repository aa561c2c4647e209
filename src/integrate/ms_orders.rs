//! Source iteration on the multiple-scattering lattice of [`super::ms_lattice`]: the
//! orders of scattering one by one, each swept in every direction
//! ([`super::ms_sweep`]), then the orders after the last one as a tail.
//!
//! Per node it keeps two angular moments of the radiance of light scattered one or more
//! times: its mean over directions `J` (what an isotropic phase function scatters) and
//! its mean times the direction `G = ⟨L·d⟩` (the net flux over 4π). A phase function
//! of mean cosine `ḡ`, expanded to its first order, scatters `J + 3ḡ·ω·G` into the
//! direction `ω`: a forward-scattering cloud lit from behind sends the light flowing
//! through it on toward a camera on the far side, and little back toward a camera on the
//! sun's side. Orders past the first are transported with the similarity-reduced
//! coefficients, whose flux is the true one in the diffusive regime (Fick's law only
//! sees `σs(1 − ḡ)`), so `G` is taken from them as it is.

use super::ms_sweep::{DIRECTION_GROUP, Grid, OrderJob, Sweeper, SweptLattice, sweep};
use glam::DVec3;
use rayon::prelude::*;

/// An order whose density-weighted sum falls below this fraction of the total so far
/// ends the iteration early (its tail is then negligible too).
const CONVERGED: f64 = 1e-4;
/// Weight of a node's own ratio in its tail (against the global ratio). Near a lit
/// surface of a very thick white medium later orders fade faster there than in total
/// (they diffuse inward) but not geometrically: on the white slab of optical depth 60
/// (tests/fast_scattering.rs, Chandrasekhar's H) the global ratio alone reflects 23 %
/// too much and the node's own ratio alone 15 % too little at 24 orders; half of each
/// is within a few %. On clouds both ratios agree (the orders reach the cloud's
/// fundamental mode) and the weight changes little (scripts/calibrate_fast.py).
const TAIL_OWN_WEIGHT: f64 = 0.5;
/// Largest ratio between orders the tail is extrapolated with (the series' sum is at
/// most 1/(1−r) times its first term).
const MAX_TAIL_RATIO: f64 = 0.995;

/// The channels' coefficients for the sweeps.
pub(super) struct Coefficients<const C: usize> {
    /// Reduced extinction per unit density.
    pub sigma_t: [f64; C],
    /// σs/σt* for the first scattering (true phase) and σs*/σt* afterwards.
    pub albedo_first: [f64; C],
    pub albedo: [f64; C],
    pub h: f64,
}

/// What one light's channels need besides the lattice.
pub(super) struct Sources<'a, const C: usize> {
    /// Mean density per node.
    pub rho: &'a [f32],
    /// First scattering's source per node (mean of `ρ·E·T` over the cell).
    pub first: &'a [[f32; C]],
    /// The light's travel direction per node.
    pub travel: &'a [DVec3],
    /// Per node, the colour grid's tint.
    pub tint: Option<&'a [[f32; C]]>,
    /// The phase function, `p(cos θ)` between the light's travel and the scattered
    /// direction (grey part).
    pub phase: &'a (dyn Fn(f64) -> f64 + Sync),
    /// Whether the directions resolve the phase function's forward peak (see
    /// [`DiscretePhase`]).
    pub peak_resolved: bool,
}

/// The orders' sum on the lattice, per channel.
pub(super) struct Solved<const C: usize> {
    /// `J_1` per node: the once-scattered light's mean radiance.
    pub j1: Vec<[f32; C]>,
    /// `Σ_{k≥2} J_k` per node (tail included).
    pub j: Vec<[f32; C]>,
    /// `Σ_{k≥2} G_k` per node and channel (tail included), `|G| ≤ J`.
    pub g: Vec<[[f32; 3]; C]>,
    pub orders: u32,
    /// The tail's ratio between orders, the largest over the channels.
    pub ratio: f64,
    /// Every order was swept by the [`Iteration::sweeper`].
    pub swept_elsewhere: bool,
}

/// The orders to sweep, how many directions, and how the tail is found.
pub(super) struct Iteration<'a> {
    pub orders: u32,
    pub dirs_for: &'a (dyn Fn(u32) -> Vec<DVec3> + Sync),
    /// The orders after the last swept one as a diffusion solve, else geometric.
    pub diffusion: bool,
    /// Whether the flux `G` is wanted (a phase function that is not isotropic; with an
    /// isotropic one it scatters nothing and stays zero).
    pub flux: bool,
    /// Where the orders' sweeps are done besides here (a GPU), if anywhere.
    pub sweeper: Option<&'a dyn Sweeper>,
}

/// A group of directions' sums over the lattice, kept from order to order.
struct GroupBuffers<const C: usize> {
    acc: Vec<[f32; C]>,
    acc_g: Vec<[[f32; 3]; C]>,
}

/// One direction's source and radiance over the lattice, and the sweep's plane-ordered
/// radiance (see [`sweep`]).
type SweptBuffers<const C: usize> = (Vec<[f32; C]>, Vec<[f32; C]>, Vec<[f32; C]>);

/// Nodes per task when a wave's radiances are added to their groups' sums.
const ADD_CHUNK: usize = 4096;

/// Source iteration for one light, all `C` channels in each sweep.
pub(super) fn solve<const C: usize>(
    grid: &Grid,
    src: &Sources<C>,
    c: &Coefficients<C>,
    it: &Iteration,
) -> Solved<C> {
    let rho = src.rho;
    let mut out = Solved {
        j1: vec![[0f32; C]; grid.len],
        j: vec![[0f32; C]; grid.len],
        g: vec![[[0f32; 3]; C]; grid.len],
        orders: 0,
        ratio: 0.0,
        swept_elsewhere: false,
    };
    if it.orders == 0 || src.first.iter().flatten().all(|v| *v <= 0.0) {
        return out;
    }
    // J per node of the order being scattered (ρ·J for the first, from the map).
    let mut rho_j: Vec<[f32; C]> = src.first.to_vec();
    let uniform_travel = src.travel.windows(2).all(|w| w[0] == w[1]);
    let weight = |v: &[[f32; C]]| -> [f64; C] {
        let mut w = [0f64; C];
        for (a, r) in v.iter().zip(rho) {
            for ch in 0..C {
                w[ch] += a[ch] as f64 * *r as f64;
            }
        }
        w
    };
    let (mut prev, mut total, mut ratio) = ([0f64; C], [0f64; C], [0f64; C]);
    let mut last = vec![[0f32; C]; grid.len];
    let mut last_g = vec![[[0f32; 3]; C]; grid.len];
    let mut before = vec![[0f32; C]; grid.len];
    let mut buffers: Vec<GroupBuffers<C>> = Vec::new();
    // A source and a radiance buffer per direction swept at once: one per thread.
    let wave = rayon::current_num_threads().max(1);
    let mut swept: Vec<SweptBuffers<C>> = Vec::new();
    let mut lattice: Option<Box<dyn SweptLattice + '_>> = it.sweeper.and_then(|s| {
        let dirs = (0..it.orders)
            .map(|o| (it.dirs_for)(o).len())
            .max()
            .unwrap_or(0);
        s.open(grid.dims, rho, C, dirs).ok()
    });
    for order in 0..it.orders {
        let dirs = (it.dirs_for)(order);
        let first = order == 0;
        // The first order scatters with the true phase function over the order's few
        // directions, whose mean of 4π·p is 1 only as their number grows: see
        // [`DiscretePhase`]. Per node where the light's travel differs (a point light).
        let phases: Vec<DiscretePhase> = if !first {
            Vec::new()
        } else if uniform_travel {
            vec![DiscretePhase::new(
                src.phase,
                src.travel[0],
                &dirs,
                src.peak_resolved,
            )]
        } else {
            src.travel
                .par_iter()
                .zip(&rho_j)
                .map(|(t, r)| {
                    if r.iter().any(|v| *v > 0.0) {
                        DiscretePhase::new(src.phase, *t, &dirs, src.peak_resolved)
                    } else {
                        DiscretePhase::default()
                    }
                })
                .collect()
        };
        let albedo = if first { c.albedo_first } else { c.albedo };
        std::mem::swap(&mut before, &mut last);
        // The order elsewhere (a GPU) where a sweeper took the lattice; else, or where it
        // failed, here.
        let elsewhere = lattice.as_mut().map(|l| {
            let weights: Vec<f32> = if !first {
                vec![1.0; dirs.len()]
            } else if uniform_travel {
                (0..dirs.len()).map(|k| phases[0].weight(k)).collect()
            } else {
                (0..grid.len)
                    .into_par_iter()
                    .flat_map_iter(|n| {
                        let lit = rho_j[n].iter().any(|x| *x > 0.0);
                        let p = &phases[n];
                        (0..dirs.len()).map(move |k| if lit { p.weight(k) } else { 0.0 })
                    })
                    .collect()
            };
            l.order(&OrderJob {
                source: rho_j.as_flattened(),
                weights: &weights,
                weight_stride: if first && !uniform_travel {
                    dirs.len()
                } else {
                    0
                },
                dirs: &dirs,
                sigma_t: &c.sigma_t,
                albedo: &albedo,
                h: c.h,
                flux: it.flux,
            })
        });
        let swept_there = match elsewhere {
            Some(Ok(m))
                if m.j.len() == grid.len * C && (!it.flux || m.g.len() == 3 * m.j.len()) =>
            {
                last.par_iter_mut()
                    .zip(m.j.par_chunks(C))
                    .for_each(|(l, j)| l.copy_from_slice(j));
                if it.flux {
                    last_g
                        .par_iter_mut()
                        .zip(m.g.par_chunks(3 * C))
                        .for_each(|(l, g)| {
                            for (ch, v) in l.iter_mut().enumerate() {
                                v.copy_from_slice(&g[3 * ch..3 * ch + 3]);
                            }
                        });
                } else {
                    last_g.par_iter_mut().for_each(|v| *v = [[0.0; 3]; C]);
                }
                true
            }
            _ => false,
        };
        if !swept_there {
            lattice = None;

            let n_groups = dirs.len().div_ceil(DIRECTION_GROUP);
            while buffers.len() < n_groups {
                buffers.push(GroupBuffers {
                    acc: vec![[0f32; C]; grid.len],
                    acc_g: if it.flux {
                        vec![[[0f32; 3]; C]; grid.len]
                    } else {
                        Vec::new()
                    },
                });
            }
            // The source toward direction `k`: the true phase for the first order,
            // isotropic after it.
            let fill_source = |k: usize, s: &mut [[f32; C]]| {
                if first {
                    let p_at = |n: usize| phases[n].weight(k);
                    let p0 = if uniform_travel { p_at(0) } else { 0.0 };
                    for (n, (s, v)) in s.iter_mut().zip(&rho_j).enumerate() {
                        let p = if uniform_travel {
                            p0
                        } else if v.iter().any(|x| *x > 0.0) {
                            p_at(n)
                        } else {
                            0.0
                        };
                        *s = v.map(|x| x * p);
                    }
                } else {
                    s.copy_from_slice(&rho_j);
                }
            };
            // Directions are swept in waves of one per thread, each into its own buffer,
            // then added to their groups' sums node by node in direction order: each sum is
            // the same for any number of threads. Each sweep's planes are split over the
            // threads too, so a thread whose direction is done takes rows of the others'
            // (directions differ in cost, and a wave can be shorter than the threads).
            let n = wave.min(dirs.len());
            while swept.len() < n {
                swept.push((
                    vec![[0f32; C]; grid.len],
                    vec![[0f32; C]; grid.len],
                    vec![[0f32; C]; grid.len],
                ));
            }
            for buf in &mut buffers[..n_groups] {
                buf.acc.par_iter_mut().for_each(|v| *v = [0.0; C]);
                buf.acc_g.par_iter_mut().for_each(|v| *v = [[0.0; 3]; C]);
            }
            for k0 in (0..dirs.len()).step_by(n) {
                let k1 = (k0 + n).min(dirs.len());
                swept[..k1 - k0]
                    .par_iter_mut()
                    .zip(&dirs[k0..k1])
                    .enumerate()
                    .for_each(|(i, ((s, radiance, planes), d))| {
                        fill_source(k0 + i, s);
                        let (sigma, h) = (c.sigma_t, c.h);
                        sweep(grid, rho, s, *d, sigma, albedo, h, radiance, planes, wave);
                    });
                let swept = &swept[..k1 - k0];
                for (g, buf) in buffers[..n_groups].iter_mut().enumerate() {
                    let ks = (g * DIRECTION_GROUP).max(k0)..((g + 1) * DIRECTION_GROUP).min(k1);
                    if ks.is_empty() {
                        continue;
                    }
                    let GroupBuffers { acc, acc_g } = buf;
                    // Node `at`'s chunk of the group's sums, the wave's directions `ks` added.
                    let add = |at: usize, acc: &mut [[f32; C]], acc_g: &mut [[[f32; 3]; C]]| {
                        for k in ks.clone() {
                            let radiance = &swept[k - k0].1[at..at + acc.len()];
                            for (a, r) in acc.iter_mut().zip(radiance) {
                                for ch in 0..C {
                                    a[ch] += r[ch];
                                }
                            }
                            let df = dirs[k].as_vec3().to_array();
                            for (ag, r) in acc_g.iter_mut().zip(radiance) {
                                for ch in 0..C {
                                    for (g, dk) in ag[ch].iter_mut().zip(df) {
                                        *g += r[ch] * dk;
                                    }
                                }
                            }
                        }
                    };
                    if acc_g.is_empty() {
                        acc.par_chunks_mut(ADD_CHUNK)
                            .enumerate()
                            .for_each(|(ci, acc)| add(ci * ADD_CHUNK, acc, &mut []));
                    } else {
                        acc.par_chunks_mut(ADD_CHUNK)
                            .zip(acc_g.par_chunks_mut(ADD_CHUNK))
                            .enumerate()
                            .for_each(|(ci, (acc, acc_g))| add(ci * ADD_CHUNK, acc, acc_g));
                    }
                }
            }
            // Means over directions (in a fixed order of groups).
            let inv = 1.0 / dirs.len() as f32;
            let groups = &buffers[..n_groups];
            last.par_chunks_mut(ADD_CHUNK)
                .enumerate()
                .for_each(|(ci, last)| {
                    let at = ci * ADD_CHUNK;
                    last.iter_mut().for_each(|v| *v = [0.0; C]);
                    for buf in groups {
                        for (l, v) in last.iter_mut().zip(&buf.acc[at..]) {
                            for ch in 0..C {
                                l[ch] += v[ch];
                            }
                        }
                    }
                    last.iter_mut().flatten().for_each(|v| *v *= inv);
                });
            last_g
                .par_chunks_mut(ADD_CHUNK)
                .enumerate()
                .for_each(|(ci, last_g)| {
                    let at = ci * ADD_CHUNK;
                    last_g.iter_mut().for_each(|v| *v = [[0.0; 3]; C]);
                    for buf in groups {
                        for (l, v) in last_g.iter_mut().zip(buf.acc_g.get(at..).unwrap_or(&[])) {
                            for ch in 0..C {
                                for k in 0..3 {
                                    l[ch][k] += v[ch][k];
                                }
                            }
                        }
                    }
                    last_g
                        .iter_mut()
                        .flatten()
                        .flatten()
                        .for_each(|v| *v *= inv);
                });
        }
        out.orders += 1;
        if first {
            out.j1.par_iter_mut().zip(&last).for_each(|(o, l)| *o = *l);
        } else {
            out.j.par_iter_mut().zip(&last).for_each(|(s, v)| {
                add(std::slice::from_mut(s), std::slice::from_ref(v));
            });
            let g = out.g.par_iter_mut().zip(&last_g);
            g.for_each(|(s, v)| {
                add_flux(std::slice::from_mut(s), std::slice::from_ref(v), [1.0; C]);
            });
        }
        let w = weight(&last);
        let mut converged = true;
        for ch in 0..C {
            total[ch] += w[ch];
            if !first && prev[ch] > 0.0 {
                ratio[ch] = (w[ch] / prev[ch]).clamp(0.0, MAX_TAIL_RATIO);
            }
            prev[ch] = w[ch];
            converged &= w[ch] <= CONVERGED * total[ch];
        }
        if converged {
            ratio = [0.0; C];
            break;
        }
        // The next order scatters this one (ρ·J at each node, tinted by the colour grid
        // there: each scattering event carries its tint).
        rho_j
            .par_iter_mut()
            .zip(&last)
            .enumerate()
            .for_each(|(n, (o, j))| {
                let t = src.tint.map_or([1.0; C], |t| t[n]);
                for ch in 0..C {
                    o[ch] = j[ch] * rho[n] * t[ch];
                }
            });
    }
    out.swept_elsewhere = lattice.is_some();
    out.ratio = ratio.iter().fold(0.0, |m, r| r.max(m));
    if it.diffusion {
        for ch in (0..C).filter(|ch| ratio[*ch] > 0.0) {
            let last_c: Vec<f32> = last.iter().map(|v| v[ch]).collect();
            let tint_c: Option<Vec<f32>> = src.tint.map(|t| t.iter().map(|v| v[ch]).collect());
            let (tail, _) = super::ms_diffusion::diffusion_tail(
                grid.dims,
                rho,
                &last_c,
                tint_c.as_deref(),
                &super::ms_diffusion::DiffusionCoefficients {
                    sigma_t: c.sigma_t[ch],
                    albedo: c.albedo[ch],
                    h: c.h,
                },
            );
            // Its flux by Fick's law: G = −∇T/(3σt*·ρ).
            let g = if it.flux {
                fick_flux(grid, rho, &tail, c.sigma_t[ch], c.h)
            } else {
                vec![[0.0; 3]; grid.len]
            };
            for ((j, gs), (t, gt)) in out
                .j
                .iter_mut()
                .zip(out.g.iter_mut())
                .zip(tail.iter().zip(&g))
            {
                j[ch] += t;
                for (a, b) in gs[ch].iter_mut().zip(gt) {
                    *a += b;
                }
            }
        }
    } else if ratio.iter().any(|r| *r > 0.0) {
        // Each node's tail blends two geometric extrapolations of its last order: with
        // the global ratio, and with the node's own ratio (never above the global one).
        // Its flux is the last order's, scaled alike.
        let (j, g) = (&mut out.j, &mut out.g);
        let nodes = j.par_iter_mut().zip(g.par_iter_mut());
        let orders = last.par_iter().zip(&before).zip(&last_g);
        nodes.zip(orders).for_each(|((j, g), ((v, b), last_g))| {
            let mut factor = [0f32; C];
            for ch in 0..C {
                let r = ratio[ch];
                if r <= 0.0 {
                    continue;
                }
                let own = if b[ch] > 0.0 {
                    (v[ch] as f64 / b[ch] as f64).clamp(0.0, r)
                } else {
                    r
                };
                factor[ch] = ((1.0 - TAIL_OWN_WEIGHT) * r / (1.0 - r)
                    + TAIL_OWN_WEIGHT * own / (1.0 - own)) as f32;
                j[ch] += v[ch] * factor[ch];
            }
            add_flux(
                std::slice::from_mut(g),
                std::slice::from_ref(last_g),
                factor,
            );
        });
    }
    // |⟨L·d⟩| ≤ ⟨L⟩ for any radiance: the lattice's and Fick's estimates are held to it.
    out.g.par_iter_mut().zip(&out.j).for_each(|(gs, j)| {
        for (g, j) in gs.iter_mut().zip(j) {
            let len = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
            if len > *j && len > 0.0 {
                let s = j.max(0.0) / len;
                g.iter_mut().for_each(|v| *v *= s);
            }
        }
    });
    out
}

/// The first order's phase function over an order's directions `d_k`, for light
/// travelling along `t`: the weights `4π·p(t·d_k)` average to 1 only as the directions
/// grow many. A forward-peaked phase (Henyey–Greenstein g 0.8; a water drop's
/// diffraction peak, a fraction of a degree wide) is mostly missed by 20–32 directions,
/// and what is missed is the forward peak: the deficit goes to the direction nearest
/// `t`, so the first order carries all the energy it scatters and in the direction it
/// goes (scaling every weight up instead spread a water drop's diffraction over the
/// rainbow's angles and lit Alexander's dark band). Where the directions oversample the
/// phase (one lands in the peak), every weight is scaled down. Only for a phase whose
/// peak the directions resolve (`fill`; [`Sources::peak_resolved`]): a water drop's
/// diffraction peak is light the similarity-reduced transport already leaves in the
/// beam, and filling it in made the rainbow slab's multiple scattering 8× the path
/// tracer's in Alexander's band (left out: 4×, the isotropic gather before: 5.5×).
#[derive(Clone, Debug, Default)]
struct DiscretePhase {
    weights: Vec<f32>,
}

impl DiscretePhase {
    fn new(phase: &(dyn Fn(f64) -> f64 + Sync), t: DVec3, dirs: &[DVec3], fill: bool) -> Self {
        let four_pi = 4.0 * std::f64::consts::PI;
        let mut weights: Vec<f64> = dirs.iter().map(|d| four_pi * phase(t.dot(*d))).collect();
        let n = weights.len().max(1) as f64;
        let mean = weights.iter().sum::<f64>() / n;
        if fill && mean < 1.0 {
            let nearest = dirs
                .iter()
                .enumerate()
                .max_by(|a, b| t.dot(*a.1).total_cmp(&t.dot(*b.1)))
                .map_or(0, |(k, _)| k);
            if let Some(w) = weights.get_mut(nearest) {
                *w += (1.0 - mean) * n;
            }
        } else if fill && mean > 0.0 {
            weights.iter_mut().for_each(|w| *w /= mean);
        }
        // The sweep's source is ρ·J·p with J's 1/4π folded into the phase.
        DiscretePhase {
            weights: weights.iter().map(|w| (*w / four_pi) as f32).collect(),
        }
    }

    /// `p` toward direction `k`, as the sweep's source takes it.
    fn weight(&self, k: usize) -> f32 {
        self.weights.get(k).copied().unwrap_or(0.0)
    }
}

fn add<const C: usize>(sum: &mut [[f32; C]], v: &[[f32; C]]) {
    for (s, v) in sum.iter_mut().zip(v) {
        for ch in 0..C {
            s[ch] += v[ch];
        }
    }
}

fn add_flux<const C: usize>(sum: &mut [[[f32; 3]; C]], v: &[[[f32; 3]; C]], scale: [f32; C]) {
    for (s, v) in sum.iter_mut().zip(v) {
        for ch in 0..C {
            for k in 0..3 {
                s[ch][k] += v[ch][k] * scale[ch];
            }
        }
    }
}

/// `G = −∇T/(3σt·ρ)` at every node with density, by central differences between
/// neighbours that have density too (one-sided where only one has, none where neither).
fn fick_flux(grid: &Grid, rho: &[f32], t: &[f32], sigma_t: f64, h: f64) -> Vec<[f32; 3]> {
    (0..grid.len)
        .into_par_iter()
        .map(|n| {
            let r = rho[n] as f64;
            if r <= 0.0 {
                return [0.0; 3];
            }
            let c = grid.coords(n);
            let mut g = [0f32; 3];
            for (k, gk) in g.iter_mut().enumerate() {
                let lo = (c[k] > 0 && rho[n - grid.stride[k]] > 0.0).then(|| n - grid.stride[k]);
                let hi = (c[k] + 1 < grid.dims[k] && rho[n + grid.stride[k]] > 0.0)
                    .then(|| n + grid.stride[k]);
                let grad = match (lo, hi) {
                    (Some(a), Some(b)) => (t[b] as f64 - t[a] as f64) / (2.0 * h),
                    (Some(a), None) => (t[n] as f64 - t[a] as f64) / h,
                    (None, Some(b)) => (t[b] as f64 - t[n] as f64) / h,
                    (None, None) => 0.0,
                };
                *gk = (-grad / (3.0 * sigma_t * r)) as f32;
            }
            g
        })
        .collect()
}
