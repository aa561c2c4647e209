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
use super::ms_orders::{Coefficients, Iteration, Sources, solve};
use super::ms_sampling::{fibonacci_sphere, hg, mean_cosine, sub_offsets};
use super::ms_sweep::{Grid, Sweeper};
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
/// Largest `max p × 4π / directions` of a phase function whose forward peak the
/// lattice's directions are taken to resolve (see `ms_orders::DiscretePhase`).
const PEAK_RESOLVED: f64 = 4.0;

/// Floats per node and light: see [`MsLattice`]'s `values`.
pub const MOMENTS: usize = 15;

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
    /// Of `seconds`: sizing the lattice and sampling the density in its cells; the
    /// lights' first-scattering sources; the orders' sweeps and tails (all lights).
    pub sampling_seconds: f64,
    pub source_seconds: f64,
    pub solve_seconds: f64,
    /// Where the orders' sweeps ran: "cpu", or the GPU that swept every order of every
    /// light (a [`Sweeper`]'s name).
    pub swept_on: String,
}

/// The multiply scattered in-radiance of every light on the lattice.
pub struct MsLattice {
    origin: DVec3,
    inv_h: f64,
    dims: [usize; 3],
    /// Per light, per node: `Σ_{k≥2} J_k` per channel (the mean in-radiance of light
    /// scattered two or more times), then per channel `Σ_{k≥2} G_k` (its mean times the
    /// direction, x y z), then per channel `J_1` (of light scattered once): see
    /// [`MsLattice::toward`].
    values: Vec<Vec<[f32; MOMENTS]>>,
    /// The phase function's mean cosine.
    g_mean: f64,
    pub report: LatticeReport,
}

impl MsLattice {
    /// Solves the lattice for every light of `lights` in `vol`.
    pub fn build(vol: &Volume, lights: &dyn Illumination, s: &LatticeSettings) -> MsLattice {
        Self::build_with(vol, lights, s, None)
    }

    /// [`MsLattice::build`] with each order's sweeps done by `sweeper` (a GPU) where it
    /// takes them; the orders, sources and tails stay here.
    pub fn build_with(
        vol: &Volume,
        lights: &dyn Illumination,
        s: &LatticeSettings,
        sweeper: Option<&dyn Sweeper>,
    ) -> MsLattice {
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
            g_mean: 0.0,
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
        let sampled = start.elapsed().as_secs_f64();
        let (mut source_seconds, mut solve_seconds) = (0.0, 0.0);
        let mut all_elsewhere = true;
        for l in 0..n_lights {
            let at = std::time::Instant::now();
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
            let travel: Vec<DVec3> = first.par_iter().map(|(_, t)| *t).collect();
            source_seconds += at.elapsed().as_secs_f64();
            let at = std::time::Instant::now();
            let phase = |mu: f64| vol.phase.eval(mu).x;
            // The phase's peak is resolved where it carries no more than a few times what
            // one direction's share of the sphere does: Henyey–Greenstein up to g ≈ 0.85
            // at 20 directions, never a water drop's diffraction peak.
            let peak_resolved = vol.phase.max_value() * 4.0 * std::f64::consts::PI
                / s.directions.max(1) as f64
                <= PEAK_RESOLVED;
            let iteration = Iteration {
                orders: s.orders,
                dirs_for: &dirs_for,
                diffusion: grown && s.diffusion_tail,
                flux: g_mean != 0.0,
                sweeper,
            };
            // A grey medium with no colour grid is one channel, scaled by the light's
            // colour; else the three are swept together.
            let (total, swept, ratio, elsewhere) = if grey {
                let source: Vec<[f32; 1]> = first.par_iter().map(|(a, _)| [a[0]]).collect();
                let sources = Sources {
                    rho: &rho,
                    first: &source,
                    travel: &travel,
                    tint: None,
                    phase: &phase,
                    peak_resolved,
                };
                let coeffs = coefficients::<1>(sigma_t_red, sigma_s, sigma_s_red, h);
                let colour = colour.as_vec3().to_array();
                solve_moments(&grid, &sources, &coeffs, &iteration, colour)
            } else {
                let source: Vec<[f32; 3]> = first.par_iter().map(|(a, _)| *a).collect();
                let sources = Sources {
                    rho: &rho,
                    first: &source,
                    travel: &travel,
                    tint: tint.as_deref(),
                    phase: &phase,
                    peak_resolved,
                };
                let coeffs = coefficients::<3>(sigma_t_red, sigma_s, sigma_s_red, h);
                solve_moments(&grid, &sources, &coeffs, &iteration, [1.0; 3])
            };
            solve_seconds += at.elapsed().as_secs_f64();
            all_elsewhere &= elsewhere;
            report.orders_swept.push(swept);
            report.tail_ratio.push(ratio);
            values.push(total);
        }
        report.seconds = start.elapsed().as_secs_f64();
        report.sampling_seconds = sampled;
        report.source_seconds = source_seconds;
        report.solve_seconds = solve_seconds;
        report.swept_on = match sweeper {
            Some(sw) if all_elsewhere => sw.name(),
            _ => "cpu".into(),
        };
        MsLattice {
            origin,
            inv_h: 1.0 / h,
            dims,
            values,
            g_mean,
            report,
        }
    }

    /// Light `l`'s mean in-radiance of light scattered once or more at world point `x`
    /// (trilinear; zero outside the lattice): what an isotropic phase function scatters.
    #[inline]
    pub fn at(&self, l: usize, x: DVec3) -> DVec3 {
        match self.moments(l, x) {
            Some(m) => DVec3::new(
                (m[0] + m[12]) as f64,
                (m[1] + m[13]) as f64,
                (m[2] + m[14]) as f64,
            ),
            None => DVec3::ZERO,
        }
    }

    /// The radiance light `l`'s once-or-more scattered light sends into direction
    /// `omega` (unit) at `x`, per unit `σs·ρ`, the light travelling along `travel` there:
    ///
    /// - the once-scattered light left its scattering event with the phase function
    ///   about the light's travel direction, so it is taken as `4π·J_1·p(travel·d)`, and
    ///   scattering it again into ω gives `4π·J_1·(p ⊛ p)(travel·ω)`; for
    ///   Henyey–Greenstein `p ⊛ p` is Henyey–Greenstein again with `ḡ²` (the Legendre
    ///   coefficients of the two, `ḡ^l`, multiply), taken so for any phase function;
    /// - light scattered two or more times is broad: the phase function to its first
    ///   order, `J + 3ḡ·ω·G` (never below zero). (Taking it as a Henyey–Greenstein lobe
    ///   about `G` of mean cosine `|G|/J`, scattered by the same product of Legendre
    ///   coefficients, was measured worse: with ḡ 0.6 lit from behind 0.073 against
    ///   0.062, with ḡ 0.8 lit from the front 0.180 against 0.116.)
    ///
    /// With an isotropic phase it is [`MsLattice::at`].
    #[inline]
    pub fn toward(&self, l: usize, x: DVec3, omega: DVec3, travel: DVec3) -> DVec3 {
        let Some(m) = self.moments(l, x) else {
            return DVec3::ZERO;
        };
        let gm = self.g_mean;
        let twice = hg(gm * gm, travel.dot(omega));
        let mut out = [0.0; 3];
        for (c, o) in out.iter_mut().enumerate() {
            let g = DVec3::new(
                m[3 + 3 * c] as f64,
                m[4 + 3 * c] as f64,
                m[5 + 3 * c] as f64,
            );
            let broad = (m[c] as f64 + 3.0 * gm * omega.dot(g)).max(0.0);
            *o = broad + m[12 + c] as f64 * twice;
        }
        DVec3::from(out)
    }

    /// The trilinear blend of the moments at `x`; None outside the lattice.
    #[inline]
    fn moments(&self, l: usize, x: DVec3) -> Option<[f32; MOMENTS]> {
        let v = match self.values.get(l) {
            Some(v) if !v.is_empty() => v,
            _ => return None,
        };
        let q = (x - self.origin) * self.inv_h;
        let [nx, ny, nz] = self.dims;
        if !(q.x >= 0.0 && q.y >= 0.0 && q.z >= 0.0) {
            return None;
        }
        let (i, j, k) = (q.x as usize, q.y as usize, q.z as usize);
        if i + 1 >= nx || j + 1 >= ny || k + 1 >= nz {
            return None;
        }
        let (fx, fy, fz) = (
            (q.x - i as f64) as f32,
            (q.y - j as f64) as f32,
            (q.z - k as f64) as f32,
        );
        let mut out = [0f32; MOMENTS];
        for dz in 0..2 {
            let wz = if dz == 0 { 1.0 - fz } else { fz };
            for dy in 0..2 {
                let wy = if dy == 0 { 1.0 - fy } else { fy };
                for dx in 0..2 {
                    let wx = if dx == 0 { 1.0 - fx } else { fx };
                    let n = (i + dx) + nx * ((j + dy) + ny * (k + dz));
                    let w = wx * wy * wz;
                    for (o, a) in out.iter_mut().zip(&v[n]) {
                        *o += a * w;
                    }
                }
            }
        }
        Some(out)
    }

    /// What [`MsLattice::toward`] reads, for the GPU: the first node's world position,
    /// 1/cell side, node counts and the phase's mean cosine; [`MsLattice::moments_of`].
    pub fn geometry(&self) -> (DVec3, f64, [usize; 3], f64) {
        (self.origin, self.inv_h, self.dims, self.g_mean)
    }

    /// Per light, the nodes' moments (x fastest; see `values`).
    pub fn moments_of(&self) -> &[Vec<[f32; MOMENTS]>] {
        &self.values
    }

    pub fn memory_bytes(&self) -> usize {
        self.values.iter().map(|v| v.len() * 4 * MOMENTS).sum()
    }
}

/// The sweeps' coefficients of channels 0..C.
fn coefficients<const C: usize>(
    sigma_t_red: DVec3,
    sigma_s: DVec3,
    sigma_s_red: DVec3,
    h: f64,
) -> Coefficients<C> {
    Coefficients {
        sigma_t: std::array::from_fn(|c| sigma_t_red[c]),
        albedo_first: std::array::from_fn(|c| sigma_s[c] / sigma_t_red[c]),
        albedo: std::array::from_fn(|c| sigma_s_red[c] / sigma_t_red[c]),
        h,
    }
}

/// Solves `C` channels and stores each node's moments for red, green and blue: channel
/// `ch` of `C` = 3, or the one channel of `C` = 1 for all three; each scaled by
/// `scale[rgb]`. Returns them, the orders swept, the tail's ratio and whether the
/// iteration's sweeper swept every order.
fn solve_moments<const C: usize>(
    grid: &Grid,
    sources: &Sources<C>,
    coeffs: &Coefficients<C>,
    iteration: &Iteration,
    scale: [f32; 3],
) -> (Vec<[f32; MOMENTS]>, u32, f64, bool) {
    let solved = solve(grid, sources, coeffs, iteration);
    let total = (0..grid.len)
        .into_par_iter()
        .map(|n| {
            let mut t = [0f32; MOMENTS];
            for (rgb, sc) in scale.iter().enumerate() {
                let ch = rgb.min(C - 1);
                t[rgb] = solved.j[n][ch] * sc;
                for k in 0..3 {
                    t[3 + 3 * rgb + k] = solved.g[n][ch][k] * sc;
                }
                t[12 + rgb] = solved.j1[n][ch] * sc;
            }
            t
        })
        .collect();
    (total, solved.orders, solved.ratio, solved.swept_elsewhere)
}

#[cfg(test)]
#[path = "ms_lattice_tests.rs"]
mod tests;
