//! The ray march: emission–absorption plus single scattering, per ray.
//!
//! The ray is cut into segments (at most `step` voxels long, restarted in every cell the
//! traversal reports, the first one shortened by a per-pixel random offset so there is
//! no banding). On a segment of length `ds`, ρ is the density's mean over the segment
//! from its exact integral (voxel by voxel, two-point Gauss–Legendre: exact for
//! trilinear grids, so opacity does not depend on the step), extinction `σt·ρ` is
//! taken as constant and everything is integrated exactly:
//!
//! ```text
//! τ   += σt·ρ·ds                                   (optical depth, summed)
//! L_e += T · ε · ds·φ(σt·ρ·ds)                      (emission ε per world unit)
//! L_s += T · σs·ρ·p·E · ∫₀^ds e^{−σt·ρ·u} e^{−τ_l(u)} du
//! ```
//!
//! where τ_l is the optical depth toward the light, known at both segment ends and taken
//! as linear in between — so the scatter integral is `e^{−τ_l(0)}·ds·φ((σt·ρ+k)·ds)`
//! with `k = (τ_l(ds) − τ_l(0))/ds`, evaluated from whichever end keeps the argument of φ
//! non-negative. In a homogeneous medium lit by a sun τ_l *is* linear along the ray, so
//! the closed forms (slab, sphere, camera inside) come out exact at any step.
//!
//! In cells where the majorant is small (σt·max ρ·step below [`THIN_STEP_DEPTH`] scaled
//! by the step, so that the error still falls as step²), steps grow until they reach
//! that optical depth: the source term there changes little per step, and opacity does
//! not depend on the step anyway. Not with emission active.
//!
//! Opacity is `1 − e^{−τ}` from the summed optical depth τ (as `−expm1(−τ)`), not from
//! a product of per-step transmittances, so a million steps of depth 1e-8 give
//! `1 − e^{−0.01}` to the last digits.
//!
//! The march stops once every channel's transmittance is below `termination` (default
//! 1e-4), setting T to 0: the radiance dropped is at most `termination × (the largest
//! source behind that point)` — below 1e-4 of the light's contribution for scattering
//! with albedo ≤ 1.

use super::deep::DeepTrace;
use super::medium::Emission;
use super::motion::MovedFields;
use super::optics::{one_minus_exp, phi};
use super::sampled_means::sampled_integrals;
use crate::accel::{IndexRay, Spans};
use crate::field::advect::RayFlow;
use glam::DVec3;

pub use super::march_settings::{
    DEFAULT_STEP, DEFAULT_TERMINATION, MarchSettings, REFERENCE_STEP, THIN_STEP_DEPTH,
};
pub use super::volume::{TimedVolume, Volume};

/// How a light reaches a point: unshadowed irradiance and propagation direction, and
/// the density integral `∫ρ ds` (world units) from the point toward the light.
pub trait Illumination: Sync {
    fn light_count(&self) -> usize;
    /// Irradiance (RGB) arriving at `x` unshadowed, and the unit direction the light travels.
    fn incident(&self, light: usize, x: DVec3) -> (DVec3, DVec3);
    /// `∫ρ ds` from `x` (world) toward the light; extinction is this times σt.
    fn density_to_light(&self, light: usize, x: DVec3) -> f64;
    /// Distance from `x` to the light (infinite for a sun): how far a shadow ray goes.
    fn distance_to_light(&self, light: usize, x: DVec3) -> f64 {
        let _ = (light, x);
        f64::INFINITY
    }
    /// Whether [`Illumination::multiple_scattered`] is more than zero anywhere.
    fn scatters_multiply(&self) -> bool {
        false
    }
    /// The radiance that light which has scattered one or more times already scatters
    /// at `x` into direction `omega` (unit), per unit `σs·ρ` (the in-scattered radiance
    /// is `σs·ρ` times this). Zero unless an integrator models multiple scattering
    /// (`integrate::fast`).
    fn multiple_scattered(&self, _light: usize, _x: DVec3, _omega: DVec3) -> DVec3 {
        DVec3::ZERO
    }
}

/// What one ray gathered.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RayResult {
    /// Transmittance through the whole volume (RGB).
    pub transmittance: DVec3,
    /// Optical depth through the whole volume (RGB), summed; +inf once terminated.
    pub optical_depth: DVec3,
    pub emission: DVec3,
    /// Sum over lights of the single-scattered radiance.
    pub scatter: DVec3,
    /// Ray parameter (world distance) where the mean transmittance first falls to 0.5.
    pub half_opacity_t: Option<f64>,
    /// Density samples taken.
    pub samples: u64,
}

impl RayResult {
    /// Opacity: the mean over the three channels of `1 − e^{−τ}`, from the summed
    /// optical depth (exact for tiny τ, where `1 − T` would cancel).
    pub fn alpha(&self) -> f64 {
        alpha_of(self.optical_depth)
    }
}

/// Opacity of optical depth `tau`: the mean over the channels of `1 − e^{−τ}`.
fn alpha_of(tau: DVec3) -> f64 {
    // A grey medium's channels are equal: one exponential for the same sum.
    let x = one_minus_exp(tau.x);
    let grey = tau.x == tau.y && tau.y == tau.z;
    let (y, z) = if grey {
        (x, x)
    } else {
        (one_minus_exp(tau.y), one_minus_exp(tau.z))
    };
    ((x + y + z) / 3.0).clamp(0.0, 1.0)
}

/// Per-thread buffers, so the per-ray loop does not allocate.
#[derive(Clone, Debug, Default)]
pub struct Scratch {
    /// Per light: optical depth toward it at the current segment start (RGB), if known.
    light_tau: Vec<Option<DVec3>>,
    /// Per light: scattered radiance gathered (all orders).
    pub per_light: Vec<DVec3>,
    /// Radiance of light scattered two or more times, over all lights (the part of
    /// `RayResult::scatter` from [`Illumination::multiple_scattered`]).
    pub indirect: DVec3,
    /// The ends of the segments of the current batch, and the density integral over each.
    ends: Vec<f64>,
    integrals: Vec<f64>,
    /// The emission grid's integral over each segment of the batch, the segments'
    /// midpoints and the temperature grid's values there.
    emission_integrals: Vec<f64>,
    mids: Vec<f64>,
    temperatures: Vec<f32>,
    /// With sampled segment means: the Gauss–Legendre nodes of the batch and the density there.
    nodes: Vec<f64>,
    node_values: Vec<f32>,
    /// With deep output on: the current ray's record (`integrate::deep`).
    pub deep: Option<DeepTrace>,
    /// The per-volume alphas' buffers ([`super::Mattes`]).
    pub mattes: super::mattes::MatteScratch,
}

impl Scratch {
    pub fn new(lights: usize) -> Self {
        Scratch {
            light_tau: vec![None; lights],
            per_light: vec![DVec3::ZERO; lights],
            indirect: DVec3::ZERO,
            ends: Vec::with_capacity(SEGMENT_BATCH),
            integrals: vec![0.0; SEGMENT_BATCH],
            emission_integrals: vec![0.0; SEGMENT_BATCH],
            mids: Vec::with_capacity(SEGMENT_BATCH),
            temperatures: vec![0.0; SEGMENT_BATCH],
            nodes: Vec::with_capacity(2 * SEGMENT_BATCH),
            node_values: Vec::with_capacity(2 * SEGMENT_BATCH),
            deep: None,
            mattes: Default::default(),
        }
    }
}

impl Scratch {
    /// For the batch of segments from `a` to `self.ends`: the emission grid's integral
    /// over each (into `emission_integrals`) and the temperature at each midpoint (into
    /// `temperatures`), where the grid is on the density's lattice (`true` for each
    /// that was).
    fn emission_batch(&mut self, e: &Emission, ray: &IndexRay, a: f64) -> (bool, bool) {
        let batch = self.ends.len();
        if self.emission_integrals.len() < batch {
            self.emission_integrals.resize(batch, 0.0);
        }
        if self.temperatures.len() < batch {
            self.temperatures.resize(batch, 0.0);
        }
        let grid = e.grid.as_ref().is_some_and(|g| {
            g.piece_integrals(ray, a, &self.ends, &mut self.emission_integrals[..batch])
        });
        let temperature = match &e.temperature {
            Some(c) if c.same_lattice() => {
                self.mids.clear();
                let mut s = a;
                for &b in &self.ends {
                    self.mids.push(0.5 * (s + b));
                    s = b;
                }
                c.values_along(ray, &self.mids, &mut self.temperatures[..batch])
            }
            _ => false,
        };
        (grid, temperature)
    }
}

/// Segments whose density integrals are taken in one walk over the voxels: enough to
/// cover a leaf at the default step, few enough that a ray terminated early wastes little.
const SEGMENT_BATCH: usize = 32;

/// `∫₀^ds e^{−a·u} du · e^{−τ0}` with `a = σt + k`, stably for either sign of `a`:
/// `τ1 = τ0 + k·ds` is the light's optical depth at the far end.
#[inline]
fn exp_source_weight(sigma_t: f64, tau0: f64, tau1: f64, ds: f64) -> f64 {
    let a_ds = sigma_t * ds + (tau1 - tau0);
    if a_ds >= 0.0 {
        (-tau0).exp() * ds * phi(a_ds)
    } else {
        (-(tau1 + sigma_t * ds)).exp() * ds * phi(-a_ds)
    }
}

/// A world-space ray `origin + t·dir` (dir of unit length) over `[t_min, t_max]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldRay {
    pub origin: DVec3,
    pub dir: DVec3,
    pub t_min: f64,
    pub t_max: f64,
    /// When the ray is taken, in frames from the frame's time (0 without a shutter).
    pub time: f64,
}

impl WorldRay {
    /// The ray from `origin` along `dir` (normalised here), unbounded.
    pub fn new(origin: DVec3, dir: DVec3) -> Self {
        WorldRay {
            origin,
            dir: dir.normalize_or_zero(),
            t_min: 0.0,
            t_max: f64::INFINITY,
            time: 0.0,
        }
    }
}

/// Replaces `ends` with the ends of the next (up to [`SEGMENT_BATCH`]) segments of
/// length `h` from `a` toward `t1`, the first of a span (`first`) shortened to `u·h` by
/// the jitter. A step too small to move t makes the rest of the span one segment.
fn next_segments(a: f64, t1: f64, h: f64, u: f64, first: &mut bool, ends: &mut Vec<f64>) {
    ends.clear();
    let mut e = a;
    while ends.len() < SEGMENT_BATCH && e < t1 {
        let step = if *first { u * h } else { h };
        *first = false;
        if step <= 0.0 {
            continue; // jitter 0: no shortened first segment
        }
        let b = (e + step).min(t1);
        let b = if b > e { b } else { t1 };
        ends.push(b);
        e = b;
    }
}

/// `f` of each channel; with `grey` (all channels equal by construction) once.
#[inline(always)]
fn per_channel(grey: bool, f: impl Fn(usize) -> f64) -> DVec3 {
    if grey {
        DVec3::splat(f(0))
    } else {
        DVec3::new(f(0), f(1), f(2))
    }
}

/// Adds the segment `[a, b]` to the ray's deep record: opacity and colour so far. The
/// opacity is `1 − T` from the transmittance the march keeps (`t_now`), without another
/// exponential: it differs from `1 − e^{−τ}` by a rounding of 1 (1e-16), and the
/// record's last point is given the ray's own opacity when the march ends
/// ([`finish_deep`]).
#[inline(never)]
fn record_deep(
    scratch: &mut Scratch,
    n_lights: usize,
    out: &RayResult,
    t_now: DVec3,
    a: f64,
    b: f64,
) {
    let mut color = out.emission;
    for v in &scratch.per_light[..n_lights] {
        color += *v;
    }
    let alpha = (1.0 - t_now.element_sum() / 3.0).clamp(0.0, 1.0);
    if let Some(tr) = scratch.deep.as_mut() {
        let (a0, c0) = tr.last();
        let added = tr.segment(a, b, a0, c0, alpha, color);
        let now = tr.aovs_now(added);
        super::deep_aovs::put(now, out.emission, scratch.indirect, &scratch.per_light);
    }
}

/// The deep record's last point gets the ray's opacity as the flat pixel has it (from
/// the optical depth `tau`), so the record ends exactly where the ray does.
fn finish_deep(scratch: &mut Scratch, tau: DVec3) {
    if let Some(last) = scratch.deep.as_mut().and_then(|tr| tr.points.last_mut()) {
        last.alpha = alpha_of(tau);
    }
}

/// Integrates one ray.
/// `jitter` in [0, 1) shortens the first segment of every cell; 0.5 gives midpoints of a
/// regular grid of segments. A moving volume is marched as it is at the ray's time.
pub fn march(
    vol: &Volume,
    lights: Option<&dyn Illumination>,
    ray_w: &WorldRay,
    settings: &MarchSettings,
    jitter: f64,
    scratch: &mut Scratch,
) -> RayResult {
    match &vol.motion {
        Some(m) if m.max_displacement(ray_w.time) > 0.0 => {
            // Every field of the ray is looked up on the ray: one displacement for all.
            let shift = m.shift(ray_w.time);
            let flow = RayFlow::new(m.velocity, shift, ray_w.origin, ray_w.dir);
            let fields = MovedFields::new(
                vol.density,
                vol.traversal,
                vol.emission.as_ref(),
                vol.color.as_ref(),
                m,
                shift,
                Some(&flow),
            );
            let mut moved = vol.moved(&fields);
            // The volumes' alpha layers are taken outside the march.
            moved.mattes = None;
            march_still(&moved, lights, ray_w, settings, jitter, scratch)
        }
        _ => march_still(vol, lights, ray_w, settings, jitter, scratch),
    }
}

/// [`march`] through the volume as it is at the frame's time.
fn march_still(
    vol: &Volume,
    lights: Option<&dyn Illumination>,
    ray_w: &WorldRay,
    settings: &MarchSettings,
    jitter: f64,
    scratch: &mut Scratch,
) -> RayResult {
    let (origin, dir) = (ray_w.origin, ray_w.dir);
    let ray = IndexRay::new(vol.density, origin, dir);
    let speed = ray.index_speed();
    let mut out = RayResult {
        transmittance: DVec3::ONE,
        ..Default::default()
    };
    if !(speed > 0.0) || !speed.is_finite() {
        return out;
    }
    let h = settings.step_voxels.max(1e-6) / speed;
    let thin_depth = settings.thin_step_depth();
    let sigma_t = vol.medium.sigma_t();
    let sigma_t_max = sigma_t.max_element();
    // A grey medium: every channel's arithmetic is the same, so do it once.
    let grey = sigma_t.x == sigma_t.y && sigma_t.y == sigma_t.z;
    let grey_phase = vol.phase.is_grey();
    let sigma_s = vol.medium.sigma_s_scaled();
    let scatter_lights = lights.filter(|l| l.light_count() > 0 && vol.medium.scatters());
    let n_lights = scatter_lights.map_or(0, |l| l.light_count());
    scratch.per_light.iter_mut().for_each(|v| *v = DVec3::ZERO);
    scratch.indirect = DVec3::ZERO;
    let multiple = scatter_lights.is_some_and(|l| l.scatters_multiply());
    scratch.light_tau.iter_mut().for_each(|v| *v = None);
    let emission = vol.emission.as_ref().filter(|e| e.is_active());
    let mut tau = DVec3::ZERO;
    let mut t_now = DVec3::ONE;
    let mut last_end = f64::NAN;
    let u = jitter.clamp(0.0, 1.0);
    if let Some(tr) = scratch.deep.as_mut() {
        tr.clear();
    }

    'spans: for span in Spans::new(vol.traversal, ray, ray_w.t_min, ray_w.t_max) {
        let constant = span.range.is_constant()
            && std::ptr::eq(
                vol.traversal as *const _ as *const u8,
                vol.density as *const _ as *const u8,
            );
        // Where the cell is optically thin (majorant × step tiny), longer steps: the
        // source term then changes little over a step. Not where emission is active:
        // flame does not follow density.
        let h_span = if emission.is_none() {
            let per_step = sigma_t_max * span.range.max as f64 * h;
            if per_step > 0.0 && per_step < thin_depth {
                h * (thin_depth / per_step)
            } else {
                h
            }
        } else {
            h
        };
        let mut a = span.t0;
        let mut first = true;
        while a < span.t1 {
            next_segments(a, span.t1, h_span, u, &mut first, &mut scratch.ends);
            // Mean density over each segment, from its exact integral where the field
            // has one.
            let batch = scratch.ends.len();
            if scratch.integrals.len() < batch {
                scratch.integrals.resize(batch, 0.0);
            }
            if !constant && vol.sampled_means {
                sampled_integrals(
                    vol.density,
                    &ray,
                    a,
                    &scratch.ends,
                    (&mut scratch.nodes, &mut scratch.node_values),
                    &mut scratch.integrals[..batch],
                );
            } else if !constant {
                vol.density.piece_integrals(
                    &ray,
                    a,
                    &scratch.ends,
                    &mut scratch.integrals[..batch],
                );
            }
            // The emission grid's exact segment means and the temperature at the
            // segments' midpoints, each in one walk for the batch (a tree descent per
            // segment cost more than the density's batched walk).
            let (emission_batched, temperature_batched) = match emission {
                Some(e) => scratch.emission_batch(e, &ray, a),
                None => (false, false),
            };
            for i in 0..batch {
                let b = scratch.ends[i];
                let ds = b - a;
                let mid = 0.5 * (a + b);
                let p = ray.at(mid);
                let rho = if constant {
                    span.range.max as f64
                } else {
                    scratch.integrals[i] / ds
                };
                out.samples += 1;
                let st = sigma_t * rho;
                let w = per_channel(grey, |c| ds * phi(st[c] * ds));
                let xw = origin + dir * mid;
                if let Some(e) = emission {
                    let eps = if emission_batched || temperature_batched {
                        let grid_mean = match &e.grid {
                            Some(_) if emission_batched => Some(scratch.emission_integrals[i] / ds),
                            Some(c) => Some(c.mean(&ray, a, b, xw)),
                            None => None,
                        };
                        let temperature = match &e.temperature {
                            Some(_) if temperature_batched => Some(scratch.temperatures[i]),
                            Some(c) => Some(c.value(p, xw)),
                            None => None,
                        };
                        e.from_samples(grid_mean, temperature) + e.others(&ray, a, b, p, xw)
                    } else {
                        e.mean(&ray, a, b, p, xw)
                    };
                    if eps.max_element() > 0.0 {
                        out.emission += t_now * eps * w;
                    }
                }
                if let (Some(ls), true) = (scatter_lights, rho > 0.0) {
                    let sigma_s_here = match &vol.color {
                        Some(c) => sigma_s * c.at(p, xw),
                        None => sigma_s,
                    };
                    for l in 0..n_lights {
                        let tau0 = match scratch.light_tau[l] {
                            Some(t) if last_end == a => t,
                            _ => sigma_t * ls.density_to_light(l, origin + dir * a),
                        };
                        let tau1 = sigma_t * ls.density_to_light(l, origin + dir * b);
                        scratch.light_tau[l] = Some(tau1);
                        let (irradiance, travel) = ls.incident(l, xw);
                        let cos = travel.dot(-dir);
                        let phase = if grey_phase {
                            DVec3::splat(vol.phase.eval(cos).x)
                        } else {
                            vol.phase.eval(cos)
                        };
                        let weight =
                            per_channel(grey, |c| exp_source_weight(st[c], tau0[c], tau1[c], ds));
                        scratch.per_light[l] +=
                            t_now * sigma_s_here * rho * phase * irradiance * weight;
                        if multiple {
                            // Multiply scattered light, toward the camera: taken as
                            // constant over the segment, so its weight is the segment's own.
                            let ms =
                                t_now * sigma_s_here * rho * ls.multiple_scattered(l, xw, -dir) * w;
                            scratch.per_light[l] += ms;
                            scratch.indirect += ms;
                        }
                    }
                    last_end = b;
                }
                let t_before = t_now;
                tau += st * ds;
                t_now = per_channel(grey, |c| (-tau[c]).exp());
                let (m0, m1) = (t_before.element_sum() / 3.0, t_now.element_sum() / 3.0);
                if out.half_opacity_t.is_none() && m0 > 0.5 && m1 <= 0.5 {
                    let rate = (m0 / m1).ln() / ds;
                    let s = if rate.is_finite() && rate > 0.0 {
                        (m0 / 0.5).ln() / rate
                    } else {
                        ds
                    };
                    out.half_opacity_t = Some(a + s.clamp(0.0, ds));
                }
                let stop = t_now.max_element() < settings.termination;
                if stop {
                    t_now = DVec3::ZERO;
                    tau = DVec3::INFINITY;
                }
                if scratch.deep.is_some() {
                    record_deep(scratch, n_lights, &out, t_now, a, b);
                }
                if stop {
                    break 'spans;
                }
                a = b;
            }
        }
    }
    out.transmittance = t_now;
    out.optical_depth = tau;
    if scratch.deep.is_some() {
        finish_deep(scratch, tau);
    }
    for v in &scratch.per_light[..n_lights] {
        out.scatter += *v;
    }
    out
}
