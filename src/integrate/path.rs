//! Multiple scattering by unbiased volumetric path tracing (`--scattering path`).
//!
//! A path leaves the camera and flies through the blocks of a majorant grid
//! ([`MajorantGrid`]: the density's range over 4-voxel blocks, crossed by a 3-D DDA): in
//! each block the majorant `σ̄ = max_c σt_c · max ρ` is the block's own (empty blocks are
//! skipped, thin ones take long steps), and tentative collisions are drawn at rate σ̄
//! (delta tracking, Woodcock; the cell-wise majorants of pbrt-v4's `VolPathIntegrator`).
//! (A grid too large for 4-voxel blocks in [`MajorantGrid`]'s budget is crossed by the
//! tree's own cells instead, [`Spans`].) At a tentative collision the path scatters
//! with probability `P = ⟨β·σt⟩ / (σ̄·⟨β⟩)` (⟨·⟩ the mean over R, G, B, β the path's
//! throughput) and otherwise passes on; the throughput is multiplied by `σs/(σ̄·P)` or
//! `(σ̄ − σt)/(σ̄·(1 − P))` per channel. That is spectral tracking (Kutz et al. 2017,
//! Novák et al. 2018): unbiased in every channel when σ differs between channels, and
//! exactly delta tracking with albedo weighting (`β·σs/σt`) in a grey medium. Absorption
//! is in the weight, so paths end only by escaping, by `--bounces` or by Russian
//! roulette (on the throughput's largest channel, from the third event on). A span
//! so dense that tracking it would take hundreds of tentative collisions is crossed by
//! the density's integral instead ([`dense`]), so no extinction makes a path endless.
//!
//! At every scattering event each light is sampled (next-event estimation): sun and
//! point lights by their direction, with the transmittance toward them from
//! [`Illumination::density_to_light`] (the deep shadow map: one lookup, within its
//! tolerance) or, unbiased, by ratio tracking over the same majorant cells
//! ([`LightTransmittance`]). The environment (a uniform dome) is found by the path
//! itself: the phase function is sampled exactly (its weight is 1 for grey phase
//! functions), so a path escaping after `n` events carries `β·L_env` — for a uniform
//! dome that is phase importance sampling of the whole integrand but the transmittance.
//! Emission is gathered along every flight (track length: `∫ε` between tentative
//! collisions, times the throughput there), so it is scattered too.
//!
//! The camera ray's opacity and depth are computed exactly (the density's integral per
//! cell), not sampled: `A` and `Z` are noise-free and equal single scattering's. The
//! render computes them on a pixel's first 16 samples only
//! ([`PathTracer::with_opacity_samples`]): the exact walk over every voxel of the camera
//! ray cost more than the rest of a sample (on the demo cloud, 160×90 at 64 spp, one
//! thread: 7.2 CPU s for the pixels with it on every sample, 3.7 s on 16).
//!
//! Random numbers: each flight, its event choices, its phase sample and its roulette
//! draw from a stream of its own derived from the pixel sample and the event count, and
//! each light's shadow ray from another ([`SampleRng::stream`]): the image is the same
//! for any thread count or tile order, and the path's choices do not depend on how
//! transmittance toward the lights is found.

use super::integrator::{CameraSample, Integrator, SampleRng};
use super::march::{Illumination, Volume};
use super::pass::PassLayout;
use super::scatter_passes::{ScatterPassSpec, ScatterPasses};
use crate::accel::{IndexRay, MajorantGrid, MajorantSpan, MajorantSpans, Spans, clip_to_box};
use crate::field::random::SplitMix64;
pub use camera::PathScratch;
use glam::DVec3;

mod camera;
mod dense;
mod moving;
mod parts;
pub use parts::PathParts;

/// How a scattering event finds the transmittance toward a sun or point light.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightTransmittance {
    /// `e^{−σt·∫ρ}` from [`Illumination::density_to_light`]: the deep shadow map (one
    /// lookup, within its tolerance), a marched shadow ray, or 1 with no shadows.
    Lookup,
    /// Ratio tracking over the density's majorant cells: unbiased.
    RatioTracking,
}

/// The path tracer's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathSettings {
    /// The most scattering events a path may have (1: single scattering).
    pub bounces: u32,
    pub transmittance: LightTransmittance,
}

/// Edge in voxels of the majorant grid's blocks. On the demo cloud (160×90, 64 spp,
/// one thread, two seeds) the render's CPU seconds × noise² was 0.110 at 2 voxels,
/// 0.102 at 4 and 0.106 at 8 (the noise is the same: the majorant changes only how
/// many null collisions a flight takes).
const MAJORANT_BLOCK: i32 = 4;

/// Russian roulette starts after this many events.
const ROULETTE_AFTER: u32 = 3;

/// Ratio tracking plays roulette once the transmittance's largest channel falls below this.
const RATIO_ROULETTE: f64 = 0.1;

/// Stream ids: a flight (with its events, phase sample and roulette) and a light's
/// shadow ray, per event.
fn flight_stream(events: u32) -> u64 {
    (events as u64) << 16
}
fn shadow_stream(events: u32, light: usize) -> u64 {
    ((events as u64) << 16) | (1 + light as u64)
}

/// What the path tracer integrates.
pub struct PathTracer<'a> {
    volume: &'a Volume<'a>,
    /// Sun and point lights (next-event estimation).
    lights: Option<&'a dyn Illumination>,
    n_lights: usize,
    /// The environment's radiance (its layer follows the lights').
    environment: Option<DVec3>,
    settings: PathSettings,
    /// Shared with the views a moving volume's samples take ([`PathTracer::sample`]).
    passes: std::sync::Arc<ScatterPasses>,
    sigma_t: DVec3,
    sigma_s: DVec3,
    sigma_t_max: f64,
    /// Every channel's extinction is the same: spectral tracking is delta tracking.
    grey: bool,
    /// The density's majorants over blocks of a few voxels (free flights and ratio
    /// tracking step through these); `None` when the grid's budget would make its blocks
    /// larger (a grid of more than 2²¹ blocks of 4 voxels): the tree's cells serve then.
    /// A moving volume's are padded by the farthest displacement in the shutter, so they
    /// bound its density at every time.
    majorants: Option<std::sync::Arc<MajorantGrid>>,
    /// The camera ray's exact opacity and depth on the pixel's first `n` samples only,
    /// alpha weighted by `weight` (spp / n); `None`: on every sample.
    opacity_samples: Option<OpacitySamples>,
}

/// On how many of a pixel's samples the camera ray's exact opacity is computed.
#[derive(Clone, Copy, Debug, PartialEq)]
struct OpacitySamples {
    n: u32,
    weight: f64,
}

/// [`PathTracer::spans`]: the majorant grid's blocks or the tree's cells.
enum MajorantStretches<'a> {
    Blocks(MajorantSpans<'a>),
    Cells(Spans<'a>),
}

impl Iterator for MajorantStretches<'_> {
    type Item = MajorantSpan;

    #[inline]
    fn next(&mut self) -> Option<MajorantSpan> {
        match self {
            MajorantStretches::Blocks(b) => b.next(),
            MajorantStretches::Cells(c) => c.next().map(|s| MajorantSpan {
                t0: s.t0,
                t1: s.t1,
                range: s.range,
            }),
        }
    }
}

/// Where a flight ended.
struct Collision {
    /// World point.
    x: DVec3,
}

impl<'a> PathTracer<'a> {
    /// `emits`: the emission layer is written; `lights`: sun and point lights with their
    /// names; `environment`: a uniform dome's radiance and its name.
    pub fn new(
        volume: &'a Volume<'a>,
        emits: bool,
        lights: Option<(&'a dyn Illumination, Vec<String>)>,
        environment: Option<(DVec3, String)>,
        settings: PathSettings,
    ) -> Self {
        let scatters = volume.medium.scatters();
        let lights = lights.filter(|(l, _)| scatters && l.light_count() > 0);
        let environment = environment.filter(|_| scatters);
        let mut names: Vec<String> = lights.as_ref().map(|(_, n)| n.clone()).unwrap_or_default();
        names.extend(environment.iter().map(|(_, n)| n.clone()));
        let passes = ScatterPasses::new(&ScatterPassSpec {
            emits,
            lights: names,
            indirect: true,
            shadow: false,
            ground_visible: false,
            volumes: volume.mattes.map(|m| m.names.to_vec()).unwrap_or_default(),
        });
        let sigma_t = volume.medium.sigma_t();
        let majorants = moving::majorants(volume, MAJORANT_BLOCK);
        PathTracer {
            volume,
            n_lights: lights.as_ref().map_or(0, |(l, _)| l.light_count()),
            lights: lights.map(|(l, _)| l),
            environment: environment.map(|(e, _)| e),
            settings: PathSettings {
                bounces: settings.bounces.max(1),
                ..settings
            },
            passes: std::sync::Arc::new(passes),
            sigma_t,
            sigma_s: volume.medium.sigma_s_scaled(),
            sigma_t_max: sigma_t.max_element(),
            grey: sigma_t.x == sigma_t.y && sigma_t.y == sigma_t.z,
            opacity_samples: None,
            majorants: Some(majorants)
                .filter(|m| m.block() <= MAJORANT_BLOCK)
                .map(std::sync::Arc::new),
        }
    }

    /// `A` and `Z` from the first `n` of a pixel's `spp` samples (the exact integral of
    /// the camera ray costs more than the rest of a sample on a grid: a walk over every
    /// voxel it crosses), anti-aliased by those `n` jittered rays as `single` is at
    /// `--spp n`. The scattered light still uses every sample.
    /// Not for a moving volume: a pixel's first samples hold the shutter's first times.
    pub fn with_opacity_samples(mut self, n: u32, spp: u32) -> Self {
        let moves = self.volume.motion.is_some() || self.volume.keyed.is_some();
        self.opacity_samples = (n >= 1 && n < spp && !moves).then(|| OpacitySamples {
            n,
            weight: spp as f64 / n as f64,
        });
        self
    }

    /// The stretches of `ray` over `[t_min, t_max]` with the density's range over each:
    /// the majorant grid's blocks, or the tree's cells.
    fn spans(&self, ray: IndexRay, t_min: f64, t_max: f64) -> MajorantStretches<'_> {
        match &self.majorants {
            Some(m) => MajorantStretches::Blocks(m.spans(ray, t_min, t_max)),
            None => MajorantStretches::Cells(Spans::new(self.volume.density, ray, t_min, t_max)),
        }
    }

    /// σs at a point (the colour grid tints it).
    #[inline]
    fn sigma_s_at(&self, p: DVec3, x: DVec3) -> DVec3 {
        match &self.volume.color {
            Some(c) => self.sigma_s * c.at(p, x),
            None => self.sigma_s,
        }
    }

    /// Flies from `origin` along `dir` (unit) over `[t_min, t_max]`: the first scattering
    /// event, with `beta` weighted for it, or `None` when the path leaves the volume.
    /// Emission along the flight is added to `emitted`, weighted by the throughput.
    #[allow(clippy::too_many_arguments)]
    fn fly(
        &self,
        origin: DVec3,
        dir: DVec3,
        t_min: f64,
        t_max: f64,
        beta: &mut DVec3,
        rng: &mut SplitMix64,
        emitted: &mut DVec3,
        samples: &mut u64,
    ) -> Option<Collision> {
        let density = self.volume.density;
        let ray = IndexRay::new(density, origin, dir);
        let emission = self.volume.emission.as_ref().filter(|e| e.is_active());
        // Emission is integrated over the pieces between tentative collisions.
        let mut piece = t_min;
        let mut emit = |a: f64, b: f64, beta: DVec3| {
            if let Some(e) = emission
                && b > a
            {
                *emitted += beta * self.emission_over(e, &ray, origin, dir, a, b);
            }
        };
        for span in self.spans(ray, t_min, t_max) {
            let maj = self.sigma_t_max * span.range.max as f64;
            if !(maj > 0.0) {
                continue;
            }
            let mut t = span.t0;
            let mut tries = 0u32;
            loop {
                if dense::too_many(tries, maj * (span.t1 - t)) {
                    // The rest of the span by its integral (the flight goes on from a
                    // tentative collision as a fresh one would).
                    let Some((tc, w)) =
                        self.dense_flight(&ray, t, span.t1, maj, beta, rng, samples)
                    else {
                        break;
                    };
                    let (p, x) = (ray.at(tc), origin + dir * tc);
                    emit(piece, tc, *beta);
                    *beta *= self.sigma_s_at(p, x) * w;
                    return Some(Collision { x });
                }
                tries += 1;
                t -= (1.0 - rng.next_f64()).ln() / maj;
                if t >= span.t1 {
                    break;
                }
                let p = ray.at(t);
                let rho = (density.value_at_index(p) as f64).max(0.0);
                *samples += 1;
                let st = self.sigma_t * rho;
                let sn = (DVec3::splat(maj) - st).max(DVec3::ZERO);
                let p_real = if self.grey {
                    st.x / maj
                } else {
                    (*beta * st).element_sum() / (maj * beta.element_sum()).max(1e-300)
                }
                .clamp(0.0, 1.0);
                let u = rng.next_f64();
                emit(piece, t, *beta);
                piece = t;
                if u < p_real {
                    let x = origin + dir * t;
                    let ss = self.sigma_s_at(p, x) * rho;
                    *beta *= ss / (maj * p_real);
                    return Some(Collision { x });
                }
                if !self.grey {
                    *beta *= sn / (maj * (1.0 - p_real));
                }
            }
        }
        if emission.is_some() {
            // Past the density, emission on its lattice may still glow.
            let end = clip_to_box(
                &IndexRay::new(self.volume.traversal, origin, dir),
                &self.volume.traversal.active_bounds(),
                t_min,
                t_max,
            )
            .map_or(piece, |(_, t1)| t1);
            emit(piece, end, *beta);
        }
        None
    }

    /// `∫ε dt` over `[a, b]` of the ray, in pieces of at most one voxel (the blackbody
    /// term is taken at each piece's midpoint; the emission grid's term is exact).
    fn emission_over(
        &self,
        e: &super::Emission,
        ray: &IndexRay,
        origin: DVec3,
        dir: DVec3,
        a: f64,
        b: f64,
    ) -> DVec3 {
        let speed = ray.index_speed().max(1e-300);
        let n = (((b - a) * speed).ceil() as usize).clamp(1, 1 << 16);
        let h = (b - a) / n as f64;
        let mut sum = DVec3::ZERO;
        for i in 0..n {
            let (s0, s1) = (a + h * i as f64, a + h * (i + 1) as f64);
            let mid = 0.5 * (s0 + s1);
            sum += e.mean(ray, s0, s1, ray.at(mid), origin + dir * mid) * h;
        }
        sum
    }

    /// Transmittance from `x` toward a light `dist` away along `toward`, by ratio tracking.
    fn ratio_tracking(
        &self,
        x: DVec3,
        toward: DVec3,
        dist: f64,
        rng: &mut SplitMix64,
        samples: &mut u64,
    ) -> DVec3 {
        let density = self.volume.density;
        let ray = IndexRay::new(density, x, toward);
        let mut tr = DVec3::ONE;
        for span in self.spans(ray, 0.0, dist) {
            let rho_max = span.range.max as f64;
            if span.range.is_constant() {
                // A constant cell: its transmittance is exact.
                tr *= (-self.sigma_t * rho_max * (span.t1 - span.t0)).exp();
            } else if self.sigma_t_max * rho_max * (span.t1 - span.t0) > dense::DENSE_SPAN {
                tr *= self.dense_transmittance(&ray, span.t0, span.t1);
            } else {
                let maj = self.sigma_t_max * rho_max;
                if !(maj > 0.0) {
                    continue;
                }
                let mut t = span.t0;
                loop {
                    t -= (1.0 - rng.next_f64()).ln() / maj;
                    if t >= span.t1 {
                        break;
                    }
                    let rho = (density.value_at_index(ray.at(t)) as f64).max(0.0);
                    *samples += 1;
                    tr *= (DVec3::ONE - self.sigma_t * (rho / maj)).max(DVec3::ZERO);
                    let m = tr.max_element();
                    if m < RATIO_ROULETTE {
                        if rng.next_f64() >= m {
                            return DVec3::ZERO;
                        }
                        tr /= m;
                    }
                }
            }
            if tr.max_element() <= 0.0 {
                return DVec3::ZERO;
            }
        }
        tr
    }

    /// Next-event estimation at `x` (the path arrived along `dir` with weight `beta`,
    /// after `events` events): each sun and point light's light scattered toward `−dir`.
    /// `point` tells this event's shadow rays' streams apart.
    #[allow(clippy::too_many_arguments)]
    fn next_event(
        &self,
        lights: &dyn Illumination,
        x: DVec3,
        dir: DVec3,
        beta: DVec3,
        events: u32,
        rng: &SampleRng,
        point: u64,
        acc: &mut [f64],
        samples: &mut u64,
    ) {
        for l in 0..self.n_lights {
            let (irradiance, travel) = lights.incident(l, x);
            if irradiance == DVec3::ZERO {
                continue;
            }
            let phase = self.volume.phase.eval(travel.dot(-dir));
            let tr = match self.settings.transmittance {
                // A map's τ may undershoot 0 by its tolerance: at a huge σt that would
                // be a transmittance far over 1.
                LightTransmittance::Lookup => {
                    (-self.sigma_t * lights.density_to_light(l, x).max(0.0)).exp()
                }
                LightTransmittance::RatioTracking => {
                    let mut s = rng.stream(shadow_stream(events, l) ^ (point << 24));
                    let dist = lights.distance_to_light(l, x);
                    self.ratio_tracking(x, -travel, dist, &mut s, samples)
                }
            };
            let v = beta * phase * irradiance * tr;
            if v.is_finite() {
                self.passes.add_scattered(acc, l, events, v);
            }
        }
    }
}

impl Integrator for PathTracer<'_> {
    type Scratch = PathScratch;

    fn passes(&self) -> &PassLayout {
        self.passes.layout()
    }

    fn scratch(&self) -> PathScratch {
        PathScratch::default()
    }

    /// A moving volume's sample is traced through it as it is at the sample's time
    /// ([`moving`]).
    fn sample(
        &self,
        camera: &CameraSample,
        rng: &mut SampleRng,
        scratch: &mut PathScratch,
        acc: &mut [f64],
    ) -> u64 {
        self.sample_at_its_time(camera, rng, scratch, acc)
    }
}

impl PathTracer<'_> {
    /// [`Integrator::sample`] through the volume as it is at the frame's time.
    fn sample_still(
        &self,
        camera: &CameraSample,
        rng: &mut SampleRng,
        scratch: &mut PathScratch,
        acc: &mut [f64],
    ) -> u64 {
        let p = &self.passes;
        let ray = camera.ray;
        let mut samples = 0u64;
        let scatters = self.n_lights > 0 || self.environment.is_some();
        let emits = self.volume.emission.as_ref().is_some_and(|e| e.is_active());
        if let Some(w) = self.alpha_weight(rng.sample_index()) {
            let (depth, half_t) =
                self.camera_ray(ray.origin, ray.dir, ray.t_min, ray.t_max, scratch);
            let alpha = (DVec3::ONE - (-self.sigma_t * depth).exp()).element_sum() / 3.0;
            p.add_alpha(acc, alpha.clamp(0.0, 1.0) * w);
            if let Some(m) = self.volume.mattes.filter(|_| p.has_mattes()) {
                // No termination: the camera ray's alpha above is exact to the end.
                let alphas = m.alphas(
                    self.sigma_t,
                    ray.origin,
                    ray.dir,
                    ray.t_min,
                    ray.t_max,
                    0.0,
                    &mut scratch.mattes,
                );
                p.add_mattes(acc, alphas, w);
            }
            if let Some(t) = half_t {
                p.add_depth(acc, t * camera.depth_rate);
            }
        }
        if !(emits || scatters) {
            return samples;
        }
        let (mut origin, mut dir) = (ray.origin, ray.dir);
        let (mut t_min, mut t_max) = (ray.t_min, ray.t_max);
        let mut beta = DVec3::ONE;
        let mut events = 0u32;
        loop {
            let mut stream = rng.stream(flight_stream(events));
            let mut emitted = DVec3::ZERO;
            let hit = self.fly(
                origin,
                dir,
                t_min,
                t_max,
                &mut beta,
                &mut stream,
                &mut emitted,
                &mut samples,
            );
            if emitted != DVec3::ZERO {
                if events == 0 {
                    p.add_emission(acc, emitted);
                } else {
                    p.add_scattered_emission(acc, events, emitted);
                }
            }
            let Some(Collision { x }) = hit else {
                if let Some(env) = self.environment
                    && events > 0
                {
                    p.add_scattered(acc, self.n_lights, events, beta * env);
                }
                break;
            };
            events += 1;
            if let Some(lights) = self.lights {
                self.next_event(lights, x, dir, beta, events, rng, 0, acc, &mut samples);
            }
            if events >= self.settings.bounces {
                // The last event: the dome's light through it, by ratio tracking along
                // a phase-sampled direction (no further event may follow).
                if let Some(env) = self.environment {
                    let s = self
                        .volume
                        .phase
                        .sample(dir, [stream.next_f64(), stream.next_f64()]);
                    let mut sh = rng.stream(shadow_stream(events, self.n_lights));
                    let tr = self.ratio_tracking(x, s.dir, f64::INFINITY, &mut sh, &mut samples);
                    p.add_scattered(acc, self.n_lights, events, beta * s.weight * tr * env);
                }
                break;
            }
            if events >= ROULETTE_AFTER {
                let q = beta.max_element();
                if q < 1.0 {
                    if !(stream.next_f64() < q) {
                        break;
                    }
                    beta /= q;
                }
            }
            let s = self
                .volume
                .phase
                .sample(dir, [stream.next_f64(), stream.next_f64()]);
            beta *= s.weight;
            if !(beta.max_element() > 0.0) || !beta.is_finite() {
                break;
            }
            origin = x;
            dir = s.dir;
            t_min = 0.0;
            t_max = f64::INFINITY;
        }
        samples
    }
}
