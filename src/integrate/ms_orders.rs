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

use super::ms_sweep::{Grid, sweep};
use glam::DVec3;
use rayon::prelude::*;

/// Directions swept by one task: fixed, so the sum over directions is done in the same
/// order for any thread count (same image whatever `--threads`).
const DIRECTION_GROUP: usize = 4;
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

/// One channel's coefficients for the sweeps.
pub(super) struct Coefficients {
    /// Reduced extinction per unit density.
    pub sigma_t: f64,
    /// σs/σt* for the first scattering (true phase) and σs*/σt* afterwards.
    pub albedo_first: f64,
    pub albedo: f64,
    pub h: f64,
}

/// What one light's channel needs besides the lattice.
pub(super) struct Sources<'a> {
    /// Mean density per node.
    pub rho: &'a [f32],
    /// First scattering's source per node (mean of `ρ·E·T` over the cell).
    pub first: &'a [f32],
    /// The light's travel direction per node.
    pub travel: &'a [DVec3],
    /// Per node, the colour grid's tint of this channel.
    pub tint: Option<&'a [f32]>,
    /// The phase function, `p(cos θ)` between the light's travel and the scattered
    /// direction (grey part).
    pub phase: &'a (dyn Fn(f64) -> f64 + Sync),
}

/// The orders' sum on the lattice.
pub(super) struct Solved {
    /// `J_1` per node: the once-scattered light's mean radiance.
    pub j1: Vec<f32>,
    /// `Σ_{k≥2} J_k` per node (tail included).
    pub j: Vec<f32>,
    /// `Σ_{k≥2} G_k` per node (tail included), `|G| ≤ J`.
    pub g: Vec<[f32; 3]>,
    pub orders: u32,
    pub ratio: f64,
}

/// The orders to sweep, how many directions, and how the tail is found.
pub(super) struct Iteration<'a> {
    pub orders: u32,
    pub dirs_for: &'a (dyn Fn(u32) -> Vec<DVec3> + Sync),
    /// The orders after the last swept one as a diffusion solve, else geometric.
    pub diffusion: bool,
}

/// Source iteration for one light and channel.
pub(super) fn solve(grid: &Grid, src: &Sources, c: &Coefficients, it: &Iteration) -> Solved {
    let rho = src.rho;
    let mut out = Solved {
        j1: vec![0f32; grid.len],
        j: vec![0f32; grid.len],
        g: vec![[0f32; 3]; grid.len],
        orders: 0,
        ratio: 0.0,
    };
    if it.orders == 0 || src.first.iter().all(|v| *v <= 0.0) {
        return out;
    }
    // J per node of the order being scattered (ρ·J for the first, from the map).
    let mut rho_j: Vec<f32> = src.first.to_vec();
    let uniform_travel = src.travel.windows(2).all(|w| w[0] == w[1]);
    let weight = |v: &[f32]| -> f64 { v.iter().zip(rho).map(|(a, r)| *a as f64 * *r as f64).sum() };
    let (mut prev, mut total, mut ratio) = (0.0, 0.0, 0.0);
    let mut last = vec![0f32; grid.len];
    let mut last_g = vec![[0f32; 3]; grid.len];
    let mut before = vec![0f32; grid.len];
    for order in 0..it.orders {
        let dirs = (it.dirs_for)(order);
        let first = order == 0;
        // The first order scatters with the true phase function over the order's few
        // directions: their mean of 4π·p is 1 only as their number grows (a peaked phase,
        // g 0.8, is far from it at 20–32), so the source is scaled to carry the energy it
        // has (its mean over directions is then exactly what scatters).
        let norm: Vec<f32> = if !first {
            Vec::new()
        } else if uniform_travel {
            vec![phase_norm(src.phase, src.travel[0], &dirs)]
        } else {
            src.travel
                .par_iter()
                .zip(&rho_j)
                .map(|(t, r)| {
                    if *r > 0.0 {
                        phase_norm(src.phase, *t, &dirs)
                    } else {
                        1.0
                    }
                })
                .collect()
        };
        let albedo = if first { c.albedo_first } else { c.albedo };
        let groups: Vec<(Vec<f32>, Vec<[f32; 3]>)> = dirs
            .par_chunks(DIRECTION_GROUP)
            .map(|group| {
                let mut acc = vec![0f32; grid.len];
                let mut acc_g = vec![[0f32; 3]; grid.len];
                let mut radiance = vec![0f32; grid.len];
                let mut s = vec![0f32; grid.len];
                for d in group {
                    // The source for this direction: isotropic after the first order,
                    // the true phase toward d for the first.
                    if first {
                        if uniform_travel {
                            let p = (src.phase)(src.travel[0].dot(*d)) as f32 * norm[0];
                            s.iter_mut().zip(&rho_j).for_each(|(s, v)| *s = v * p);
                        } else {
                            for n in 0..grid.len {
                                s[n] = if rho_j[n] > 0.0 {
                                    rho_j[n] * (src.phase)(src.travel[n].dot(*d)) as f32 * norm[n]
                                } else {
                                    0.0
                                };
                            }
                        }
                    } else {
                        s.copy_from_slice(&rho_j);
                    }
                    sweep(grid, rho, &s, *d, c.sigma_t, albedo, c.h, &mut radiance);
                    let df = d.as_vec3().to_array();
                    for ((a, ag), r) in acc.iter_mut().zip(acc_g.iter_mut()).zip(&radiance) {
                        *a += *r;
                        for (g, dk) in ag.iter_mut().zip(df) {
                            *g += *r * dk;
                        }
                    }
                }
                (acc, acc_g)
            })
            .collect();
        // Means over directions (in a fixed order of groups).
        let inv = 1.0 / dirs.len() as f32;
        std::mem::swap(&mut before, &mut last);
        last.iter_mut().for_each(|v| *v = 0.0);
        last_g.iter_mut().for_each(|v| *v = [0.0; 3]);
        for (a, ag) in &groups {
            last.iter_mut().zip(a).for_each(|(l, v)| *l += *v);
            for (l, v) in last_g.iter_mut().zip(ag) {
                for k in 0..3 {
                    l[k] += v[k];
                }
            }
        }
        last.iter_mut().for_each(|v| *v *= inv);
        last_g.iter_mut().flatten().for_each(|v| *v *= inv);
        out.orders += 1;
        if first {
            out.j1.copy_from_slice(&last);
        } else {
            out.j.iter_mut().zip(&last).for_each(|(s, v)| *s += *v);
            add(&mut out.g, &last_g, 1.0);
        }
        let w = weight(&last);
        total += w;
        if !first && prev > 0.0 {
            ratio = (w / prev).clamp(0.0, MAX_TAIL_RATIO);
        }
        prev = w;
        if w <= CONVERGED * total {
            ratio = 0.0;
            break;
        }
        // The next order scatters this one (ρ·J at each node, tinted by the colour grid
        // there: each scattering event carries its tint).
        rho_j
            .iter_mut()
            .zip(last.iter().zip(rho))
            .for_each(|(o, (j, r))| *o = j * r);
        if let Some(t) = src.tint {
            rho_j.iter_mut().zip(t).for_each(|(o, t)| *o *= t);
        }
    }
    out.ratio = ratio;
    if ratio > 0.0 && it.diffusion {
        let (tail, _) = super::ms_diffusion::diffusion_tail(
            grid.dims,
            rho,
            &last,
            src.tint,
            &super::ms_diffusion::DiffusionCoefficients {
                sigma_t: c.sigma_t,
                albedo: c.albedo,
                h: c.h,
            },
        );
        // Its flux by Fick's law: G = −∇T/(3σt*·ρ).
        let g = fick_flux(grid, rho, &tail, c.sigma_t, c.h);
        out.j.iter_mut().zip(&tail).for_each(|(s, t)| *s += *t);
        add(&mut out.g, &g, 1.0);
    } else if ratio > 0.0 {
        // Each node's tail blends two geometric extrapolations of its last order: with
        // the global ratio, and with the node's own ratio (never above the global one).
        // Its flux is the last order's, scaled alike.
        for (n, (v, b)) in last.iter().zip(&before).enumerate() {
            let own = if *b > 0.0 {
                (*v as f64 / *b as f64).clamp(0.0, ratio)
            } else {
                ratio
            };
            let tail = ((1.0 - TAIL_OWN_WEIGHT) * ratio / (1.0 - ratio)
                + TAIL_OWN_WEIGHT * own / (1.0 - own)) as f32;
            out.j[n] += *v * tail;
            for (o, l) in out.g[n].iter_mut().zip(&last_g[n]) {
                *o += l * tail;
            }
        }
    }
    // |⟨L·d⟩| ≤ ⟨L⟩ for any radiance: the lattice's and Fick's estimates are held to it.
    for (g, j) in out.g.iter_mut().zip(&out.j) {
        let len = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        if len > *j && len > 0.0 {
            let s = j.max(0.0) / len;
            g.iter_mut().for_each(|v| *v *= s);
        }
    }
    out
}

/// `1/(4π·mean_d p(t·d))` over the directions `dirs`: the factor that makes the discrete
/// phase function scatter exactly what arrives.
fn phase_norm(phase: &(dyn Fn(f64) -> f64 + Sync), t: DVec3, dirs: &[DVec3]) -> f32 {
    let mean = dirs.iter().map(|d| phase(t.dot(*d))).sum::<f64>() / dirs.len().max(1) as f64;
    let m = 4.0 * std::f64::consts::PI * mean;
    if m > 0.0 { (1.0 / m) as f32 } else { 1.0 }
}

fn add(sum: &mut [[f32; 3]], v: &[[f32; 3]], scale: f32) {
    for (s, v) in sum.iter_mut().zip(v) {
        for k in 0..3 {
            s[k] += v[k] * scale;
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
