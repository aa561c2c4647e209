//! Multiple scattering on a coarse lattice: the light scattered two or more times,
//! solved once per light before the render by discrete ordinates, and read back by the
//! march as an isotropic in-scattered radiance (see [`super::fast`]).
//!
//! The lattice is world-axis-aligned over the density's world bounds (one empty node of
//! padding on every side), with cubic cells of side `h` chosen so the node count stays
//! under a budget. Per node it holds the mean density `ρ̄` over the node's cell and, per
//! light, the mean of `ρ·E·e^{−σt·∫ρ}` over the cell (the first scattering's source,
//! read from the light's shadow map at `SUPERSAMPLE³` points, so a sharp lit edge inside a
//! cell keeps its energy).
//!
//! Order by order (source iteration), for each of `directions` directions `d` (a
//! Fibonacci sphere, turned by the golden angle each order so ray artefacts of one set
//! average out over the orders) the radiance `L_k(x, d)` of light scattered exactly `k`
//! times is swept through the lattice upwind: from each node one short characteristic
//! back to the plane of nodes behind it along `d`'s dominant axis, bilinear there, with
//! density taken as the mean of the two ends and the source linear along the step
//! (exact for a linear source in a constant medium):
//!
//! ```text
//! L(x) = L(u)·e^{−τ} + ω·[J(x)·(1 − e^{−τ} − P) + J(u)·P],   P = (1 − e^{−τ} − τe^{−τ})/τ
//! ```
//!
//! `J` is the phase-weighted in-radiance: for the first scattering `p(d·travel)·E·T`
//! (the true phase), afterwards the mean of `L_k` over the directions (isotropic). An
//! anisotropic phase is handled by similarity: after the first scattering, transport
//! uses `σs* = σs(1−ḡ)`, `σt* = σa + σs*` with `ḡ` the phase function's mean cosine.
//! Orders past the last one solved are added as a geometric tail, `J_N·r/(1−r)`, with
//! `r` half the ratio of the density-weighted sums of the last two orders (the source
//! iteration's convergence rate; clamped below 1) and half the node's own ratio
//! (see [`TAIL_OWN_WEIGHT`]).
//!
//! Cells are sized in mean free paths ([`LatticeSettings::cell_depth`]): where a cell at
//! the medium's dense part is optically thicker than that, the lattice grows (up to
//! [`LatticeSettings::node_cap`] times its budget), sweeps fewer orders over fewer
//! directions with fewer sub-samples a cell (so it costs about what the base lattice
//! does), and the orders after the last swept one are a diffusion solve
//! ([`super::ms_diffusion`]) instead of the geometric tail: in such a medium light
//! needs many orders to leave, where diffusion holds and the geometric extrapolation of
//! one order's shape does not.

use super::march::{Illumination, Volume};
use super::ms_sweep::{Grid, sweep};
use glam::DVec3;
use rayon::prelude::*;

/// How the lattice is built and solved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LatticeSettings {
    /// Scattering orders beyond the first that are swept (the fast mode's `--bounces`
    /// minus one); later ones are the geometric tail.
    pub orders: u32,
    /// Most nodes the lattice may have.
    pub max_nodes: usize,
    /// Directions per order.
    pub directions: usize,
    /// Largest optical depth of a cell at the medium's dense part before the lattice
    /// takes more nodes (None: the node budget alone).
    pub cell_depth: Option<f64>,
    /// Most times `max_nodes` the lattice may grow to for `cell_depth`.
    pub node_cap: f64,
    /// A grown lattice's orders after the last swept one as a diffusion solve
    /// ([`super::ms_diffusion`]) rather than the geometric tail.
    pub diffusion_tail: bool,
}

/// Sub-samples per cell side for the node means.
const SUPERSAMPLE: usize = 3;
/// Sub-samples per cell side of a lattice grown for a thick medium.
const GROWN_SUPERSAMPLE: usize = 2;
/// Fewest orders a grown lattice sweeps before its diffusion tail.
const MIN_GROWN_ORDERS: u32 = 10;
/// A medium this white keeps the base lattice and all its orders: there light survives
/// hundreds of orders and the orders count for more than the cells' size (the white
/// slab of tests/fast_scattering.rs, albedo 1, reflected 30 % too little with a grown
/// lattice's 10 orders and the diffusion tail, 44 % with the geometric one).
const MAX_GROWN_ALBEDO: f64 = 0.998;
/// Directions per order of a grown lattice.
const GROWN_DIRECTIONS: usize = 20;
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

/// What the solve did, for the stats.
#[derive(Clone, Debug, Default, serde::Serialize, PartialEq)]
pub struct LatticeReport {
    pub dims: [usize; 3],
    pub cell_world: f64,
    /// Times the node budget the lattice grew to for cells sized in mean free paths
    /// (1: not grown).
    pub growth: f64,
    /// Directions swept per order.
    pub directions: usize,
    /// The orders after the last swept one: "diffusion", "geometric" or "none".
    pub tail: &'static str,
    /// Orders swept per light (after the first scattering), and the tail's ratio.
    pub orders_swept: Vec<u32>,
    pub tail_ratio: Vec<f64>,
    pub seconds: f64,
}

/// The multiply scattered in-radiance of every light on the lattice.
pub struct MsLattice {
    origin: DVec3,
    inv_h: f64,
    dims: [usize; 3],
    /// Per light, per node: `Σ_{k≥1} J_k` per channel (isotropic in-radiance of light
    /// scattered two or more times; the in-scattered radiance is `σs·ρ` times this).
    values: Vec<Vec<[f32; 3]>>,
    pub report: LatticeReport,
}

impl MsLattice {
    /// Solves the lattice for every light of `lights` in `vol`.
    pub fn build(vol: &Volume, lights: &dyn Illumination, s: &LatticeSettings) -> MsLattice {
        let start = std::time::Instant::now();
        let n_lights = lights.light_count();
        // Over where the density is non-zero, not its active bounds: a dense exported
        // domain holding a small plume would otherwise spend its nodes on empty space and
        // blur the plume's optical depth over cells several mean free paths deep.
        let nonzero = crate::field::nonzero::nonzero_bounds(vol.density);
        let (lo, hi) = if nonzero.is_empty() {
            vol.density.world_bounds()
        } else {
            vol.density.transform().index_box_to_world(&nonzero)
        };
        let ext = hi - lo;
        let empty = MsLattice {
            origin: DVec3::ZERO,
            inv_h: 0.0,
            dims: [0; 3],
            values: vec![Vec::new(); n_lights],
            report: LatticeReport::default(),
        };
        let vol_ext = ext.x.max(0.0) * ext.y.max(0.0) * ext.z.max(0.0);
        if !(ext.min_element() > 0.0) || !vol_ext.is_finite() || n_lights == 0 {
            return empty;
        }
        // Cells: cubes with at most max_nodes nodes (two of padding per axis).
        let mut budget = s.max_nodes.max(64) as f64;
        let dims_for = |h: f64| ext.to_array().map(|e| (e / h).ceil() as usize + 3);
        let cell_for = |budget: f64| {
            let mut h = (vol_ext / budget).cbrt();
            while dims_for(h).iter().product::<usize>() as f64 > budget {
                h *= 1.05;
            }
            h
        };
        let mut h = cell_for(budget);
        let mut grow = 1.0;
        if let Some(target) = s.cell_depth {
            // Cells sized in mean free paths: where the dense part of the medium (its
            // 90th percentile of density, sampled at the nodes) makes a cell thicker
            // than `target`, more nodes, up to `node_cap` times the budget.
            let dims = dims_for(h);
            let g = Grid::new(dims);
            let mut d: Vec<f32> = (0..g.len)
                .into_par_iter()
                .map(|n| {
                    let [i, j, k] = g.coords(n);
                    let x = lo - DVec3::splat(h) + DVec3::new(i as f64, j as f64, k as f64) * h;
                    vol.density.value_at_world(x).max(0.0)
                })
                .filter(|v| *v > 0.0)
                .collect();
            if !d.is_empty() {
                let q = (0.9 * (d.len() - 1) as f64) as usize;
                let (_, v, _) = d.select_nth_unstable_by(q, |a, b| a.total_cmp(b));
                let st = vol.medium.sigma_t();
                let g_mean = mean_cosine(vol);
                let ss = vol.medium.sigma_s_scaled();
                let st_red = st - ss * g_mean;
                let albedo = (ss * (1.0 - g_mean) / st_red).max_element();
                let tau = st_red.max_element() * *v as f64 * h;
                if tau > target && albedo < MAX_GROWN_ALBEDO {
                    grow = (tau / target).powi(3).min(s.node_cap);
                    budget *= grow;
                    h = cell_for(budget);
                }
            }
        }
        let dims = dims_for(h);
        let origin = lo - DVec3::splat(h);
        let grid = Grid::new(dims);
        let medium = &vol.medium;
        let sigma_t = medium.sigma_t();
        let sigma_s = medium.sigma_s_scaled();
        let g_mean = mean_cosine(vol);
        let sigma_s_red = sigma_s * (1.0 - g_mean);
        let sigma_t_red = sigma_t - sigma_s + sigma_s_red;
        // A colour grid tints every scattering event (σs·Cd, as the march and the path
        // tracer apply it), so light scattered k times carries k tints: per channel then.
        let tint_at = |p: DVec3| -> DVec3 {
            match &vol.color {
                Some(c) => c.at(vol.density.transform().world_to_index(p), p),
                None => DVec3::ONE,
            }
        };
        let grey = vol.color.is_none()
            && sigma_t.x == sigma_t.y
            && sigma_t.y == sigma_t.z
            && sigma_s.x == sigma_s.y
            && sigma_s.y == sigma_s.z;
        let node_pos = |n: usize| {
            let [i, j, k] = grid.coords(n);
            origin + DVec3::new(i as f64, j as f64, k as f64) * h
        };
        // A lattice grown for an optically thick medium sweeps fewer orders (the
        // diffusion tail takes the rest, and it is at its best there) and samples each
        // of its smaller cells at fewer points, so it costs about what the base one does.
        let mut s = *s;
        let grown = grow > 1.0;
        let supersample = if grown {
            s.orders = s
                .orders
                .min(((s.orders as f64 / grow).ceil() as u32).max(MIN_GROWN_ORDERS));
            s.directions = s.directions.min(GROWN_DIRECTIONS);
            GROWN_SUPERSAMPLE
        } else {
            SUPERSAMPLE
        };
        let s = &s;
        let offsets: Vec<DVec3> = sub_offsets(h, supersample);
        // The density at every sub-sample of every cell (looked up once: the node means
        // and each light's first-scattering source read it), and the mean per node.
        let subs = offsets.len();
        let sub_rho: Vec<f32> = (0..grid.len)
            .into_par_iter()
            .flat_map_iter(|n| {
                let x = node_pos(n);
                offsets
                    .iter()
                    .map(move |o| vol.density.value_at_world(x + *o).max(0.0))
            })
            .collect();
        let rho: Vec<f32> = sub_rho
            .par_chunks(subs)
            .map(|c| (c.iter().map(|v| *v as f64).sum::<f64>() / subs as f64) as f32)
            .collect();
        // Per node, the density-weighted mean tint of its cell (what scattering there sees).
        let tint: Option<Vec<[f32; 3]>> = vol.color.is_some().then(|| {
            (0..grid.len)
                .into_par_iter()
                .map(|n| {
                    let x = node_pos(n);
                    let (mut acc, mut w) = (DVec3::ZERO, 0.0);
                    for (o, r) in offsets.iter().zip(&sub_rho[n * subs..(n + 1) * subs]) {
                        let p = x + *o;
                        let r = *r as f64;
                        if r > 0.0 {
                            acc += r * tint_at(p);
                            w += r;
                        }
                    }
                    if w > 0.0 { acc / w } else { DVec3::ONE }
                        .as_vec3()
                        .to_array()
                })
                .collect()
        });
        let mut values = Vec::with_capacity(n_lights);
        let mut report = LatticeReport {
            dims,
            cell_world: h,
            growth: grow,
            directions: s.directions.max(1),
            tail: if s.orders == 0 {
                "none"
            } else if grown && s.diffusion_tail {
                "diffusion"
            } else {
                "geometric"
            },
            ..Default::default()
        };
        let n_dirs = s.directions.max(1);
        let dirs_for = move |order: u32| fibonacci_sphere(n_dirs, order);
        for l in 0..n_lights {
            // First scattering's source per node and channel: mean of ρ·E·T over the cell,
            // and the light's travel direction at the node (for the phase).
            let (irr_c, _) = lights.incident(l, 0.5 * (lo + hi));
            let colour = if irr_c.max_element() > 0.0 {
                irr_c / irr_c.max_element()
            } else {
                DVec3::ONE
            };
            let first: Vec<([f32; 3], DVec3)> = (0..grid.len)
                .into_par_iter()
                .map(|n| {
                    let x = node_pos(n);
                    let mut acc = DVec3::ZERO;
                    if rho[n] > 0.0 {
                        for (o, r) in offsets.iter().zip(&sub_rho[n * subs..(n + 1) * subs]) {
                            let p = x + *o;
                            let r = *r as f64;
                            if r > 0.0 {
                                let (irr, _) = lights.incident(l, p);
                                let e = if grey {
                                    DVec3::splat(irr.max_element())
                                } else {
                                    irr
                                };
                                let tau = lights.density_to_light(l, p);
                                acc += r * tint_at(p) * e * (-sigma_t * tau).exp();
                            }
                        }
                        acc /= offsets.len() as f64;
                    }
                    let (_, travel) = lights.incident(l, x);
                    (acc.as_vec3().to_array(), travel)
                })
                .collect();
            let channels = if grey { 1 } else { 3 };
            let mut total = vec![[0f32; 3]; grid.len];
            let mut swept = 0;
            let mut ratio = 0.0;
            for c in 0..channels {
                let coeffs = Coefficients {
                    sigma_t: sigma_t_red[c],
                    albedo_first: sigma_s[c] / sigma_t_red[c],
                    albedo: sigma_s_red[c] / sigma_t_red[c],
                    h,
                };
                let source0: Vec<f32> = first.iter().map(|(a, _)| a[c]).collect();
                let travel: Vec<DVec3> = first.iter().map(|(_, t)| *t).collect();
                let tint_c: Option<Vec<f32>> =
                    tint.as_ref().map(|t| t.iter().map(|v| v[c]).collect());
                let (sum, k, r) = solve(
                    &grid,
                    &rho,
                    &source0,
                    &travel,
                    tint_c.as_deref(),
                    vol,
                    &coeffs,
                    s,
                    dirs_for,
                    grown && s.diffusion_tail,
                );
                swept = k;
                ratio = r;
                for (t, v) in total.iter_mut().zip(&sum) {
                    if grey {
                        *t = (colour * *v as f64).as_vec3().to_array();
                    } else {
                        t[c] = *v;
                    }
                }
            }
            report.orders_swept.push(swept);
            report.tail_ratio.push(ratio);
            values.push(total);
        }
        report.seconds = start.elapsed().as_secs_f64();
        MsLattice {
            origin,
            inv_h: 1.0 / h,
            dims,
            values,
            report,
        }
    }

    /// Light `l`'s in-radiance of orders ≥ 2 at world point `x` (trilinear; zero
    /// outside the lattice).
    #[inline]
    pub fn at(&self, l: usize, x: DVec3) -> DVec3 {
        let v = match self.values.get(l) {
            Some(v) if !v.is_empty() => v,
            _ => return DVec3::ZERO,
        };
        let q = (x - self.origin) * self.inv_h;
        let [nx, ny, nz] = self.dims;
        if !(q.x >= 0.0 && q.y >= 0.0 && q.z >= 0.0) {
            return DVec3::ZERO;
        }
        let (i, j, k) = (q.x as usize, q.y as usize, q.z as usize);
        if i + 1 >= nx || j + 1 >= ny || k + 1 >= nz {
            return DVec3::ZERO;
        }
        let (fx, fy, fz) = (q.x - i as f64, q.y - j as f64, q.z - k as f64);
        let mut out = DVec3::ZERO;
        for dz in 0..2 {
            let wz = if dz == 0 { 1.0 - fz } else { fz };
            for dy in 0..2 {
                let wy = if dy == 0 { 1.0 - fy } else { fy };
                for dx in 0..2 {
                    let wx = if dx == 0 { 1.0 - fx } else { fx };
                    let n = (i + dx) + nx * ((j + dy) + ny * (k + dz));
                    out += DVec3::from(v[n].map(|a| a as f64)) * (wx * wy * wz);
                }
            }
        }
        out
    }

    pub fn memory_bytes(&self) -> usize {
        self.values.iter().map(|v| v.len() * 12).sum()
    }
}

/// One channel's coefficients for the sweeps.
struct Coefficients {
    /// Reduced extinction per unit density.
    sigma_t: f64,
    /// σs/σt* for the first scattering (true phase) and σs*/σt* afterwards.
    albedo_first: f64,
    albedo: f64,
    h: f64,
}

/// Offsets of the sub-samples of a cell around its node.
fn sub_offsets(h: f64, n: usize) -> Vec<DVec3> {
    let at = |i: usize| ((i as f64 + 0.5) / n as f64 - 0.5) * h;
    let mut v = Vec::with_capacity(n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                v.push(DVec3::new(at(i), at(j), at(k)));
            }
        }
    }
    v
}

/// The phase function's mean cosine `∫p(μ)·μ dω` (grey part: channel 0), by the
/// midpoint rule over μ.
fn mean_cosine(vol: &Volume) -> f64 {
    let n = 2048;
    let mut s = 0.0;
    for i in 0..n {
        let mu = -1.0 + (i as f64 + 0.5) * 2.0 / n as f64;
        s += vol.phase.eval(mu).x * mu;
    }
    (s * 2.0 / n as f64 * 2.0 * std::f64::consts::PI).clamp(-0.99, 0.99)
}

/// `n` directions spread evenly over the sphere (a Fibonacci spiral), turned for order
/// `turn` by `turn` golden angles about an axis that itself walks over the sphere, so
/// successive orders use different sets.
fn fibonacci_sphere(n: usize, turn: u32) -> Vec<DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let spiral = |i: f64, n: f64| {
        let z = 1.0 - (2.0 * i + 1.0) / n;
        let r = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(r * (golden * i).cos(), r * (golden * i).sin(), z)
    };
    let axis = spiral((turn % 61) as f64, 61.0);
    let rot = glam::DQuat::from_axis_angle(axis.normalize(), golden * turn as f64);
    (0..n).map(|i| rot * spiral(i as f64, n as f64)).collect()
}

/// Source iteration for one light and channel: returns `Σ_{k≥1} J_k` per node (tail
/// included), the orders swept and the tail's ratio.
#[allow(clippy::too_many_arguments)]
fn solve(
    grid: &Grid,
    rho: &[f32],
    source0: &[f32],
    travel: &[DVec3],
    tint: Option<&[f32]>,
    vol: &Volume,
    c: &Coefficients,
    s: &LatticeSettings,
    dirs_for: impl Fn(u32) -> Vec<DVec3>,
    diffusion: bool,
) -> (Vec<f32>, u32, f64) {
    let mut sum = vec![0f32; grid.len];
    if s.orders == 0 || source0.iter().all(|v| *v <= 0.0) {
        return (sum, 0, 0.0);
    }
    // J per node of the order being scattered (ρ·J for the first, from the map).
    let mut rho_j: Vec<f32> = source0.to_vec();
    let uniform_travel = travel.windows(2).all(|w| w[0] == w[1]);
    let weight = |v: &[f32]| -> f64 { v.iter().zip(rho).map(|(a, r)| *a as f64 * *r as f64).sum() };
    let (mut prev, mut total, mut ratio) = (0.0, 0.0, 0.0);
    let mut last = vec![0f32; grid.len];
    let mut before = vec![0f32; grid.len];
    let mut swept = 0;
    for order in 0..s.orders {
        let dirs = dirs_for(order);
        let first = order == 0;
        let albedo = if first { c.albedo_first } else { c.albedo };
        let groups: Vec<Vec<f32>> = dirs
            .par_chunks(DIRECTION_GROUP)
            .map(|group| {
                let mut acc = vec![0f32; grid.len];
                let mut radiance = vec![0f32; grid.len];
                let mut src = vec![0f32; grid.len];
                for d in group {
                    // The source for this direction: isotropic after the first order,
                    // the true phase toward d for the first.
                    if first {
                        if uniform_travel {
                            let p = vol.phase.eval(travel[0].dot(*d)).x as f32;
                            src.iter_mut().zip(&rho_j).for_each(|(s, v)| *s = v * p);
                        } else {
                            for n in 0..grid.len {
                                src[n] = if rho_j[n] > 0.0 {
                                    rho_j[n] * vol.phase.eval(travel[n].dot(*d)).x as f32
                                } else {
                                    0.0
                                };
                            }
                        }
                    } else {
                        src.copy_from_slice(&rho_j);
                    }
                    sweep(grid, rho, &src, *d, c.sigma_t, albedo, c.h, &mut radiance);
                    acc.iter_mut().zip(&radiance).for_each(|(a, r)| *a += *r);
                }
                acc
            })
            .collect();
        // Mean over directions (in a fixed order of groups).
        let inv = 1.0 / dirs.len() as f32;
        std::mem::swap(&mut before, &mut last);
        last.iter_mut().for_each(|v| *v = 0.0);
        for g in &groups {
            last.iter_mut().zip(g).for_each(|(l, v)| *l += *v);
        }
        last.iter_mut().for_each(|v| *v *= inv);
        swept += 1;
        sum.iter_mut().zip(&last).for_each(|(s, v)| *s += *v);
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
        if let Some(t) = tint {
            rho_j.iter_mut().zip(t).for_each(|(o, t)| *o *= t);
        }
    }
    if ratio > 0.0 && diffusion {
        let (tail, _) = super::ms_diffusion::diffusion_tail(
            grid.dims,
            rho,
            &last,
            tint,
            &super::ms_diffusion::DiffusionCoefficients {
                sigma_t: c.sigma_t,
                albedo: c.albedo,
                h: c.h,
            },
        );
        sum.iter_mut().zip(&tail).for_each(|(s, t)| *s += *t);
    } else if ratio > 0.0 {
        // Each node's tail blends two geometric extrapolations of its last order: with
        // the global ratio, and with the node's own ratio (never above the global one).
        for ((s, v), b) in sum.iter_mut().zip(&last).zip(&before) {
            let own = if *b > 0.0 {
                (*v as f64 / *b as f64).clamp(0.0, ratio)
            } else {
                ratio
            };
            let tail = (1.0 - TAIL_OWN_WEIGHT) * ratio / (1.0 - ratio)
                + TAIL_OWN_WEIGHT * own / (1.0 - own);
            *s += *v * tail as f32;
        }
    }
    (sum, swept, ratio)
}
