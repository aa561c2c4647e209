//! The pixel loop: 16×16 tiles in parallel (rayon), each pixel integrated by the march.

use super::camera::Camera;
use super::ground::{ALBEDO, Ground};
use crate::field::random::{mix64, unit_f64};
use crate::integrate::{Illumination, MarchSettings, Scratch, Volume, WorldRay, march};
use indicatif::ProgressBar;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

pub const TILE: usize = 16;

/// Per-pixel results, one flat array per quantity.
#[derive(Clone, Debug, Default)]
pub struct PixelPasses {
    pub width: usize,
    pub height: usize,
    pub alpha: Vec<f32>,
    pub emission: [Vec<f32>; 3],
    pub scatter: [Vec<f32>; 3],
    /// Per light, RGB.
    pub per_light: Vec<[Vec<f32>; 3]>,
    /// Camera-space depth where opacity crosses 0.5, +inf where it never does.
    pub depth: Vec<f32>,
    /// With a ground plane: the fraction of light it receives (RGB), 1 off the plane.
    pub shadow: Option<[Vec<f32>; 3]>,
    /// With a visible ground plane: its radiance behind the volume (RGB, premultiplied).
    pub ground: Option<[Vec<f32>; 3]>,
    pub rays: u64,
    pub samples: u64,
}

/// A deterministic hash of a pixel sample to [0, 1) (SplitMix64's mixer).
pub fn unit_random(seed: u64, x: usize, y: usize, s: u32, k: u32) -> f64 {
    let z = seed
        .wrapping_add((x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15))
        .wrapping_add((y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F))
        .wrapping_add(((s as u64) << 32 | k as u64).wrapping_mul(0x1656_67B1_9E37_79F9));
    unit_f64(mix64(z))
}

pub struct PixelJob<'a> {
    pub volume: &'a Volume<'a>,
    pub lights: Option<&'a dyn Illumination>,
    /// A ground plane and the lights that reach it (with their shadows).
    pub ground: Option<(Ground, &'a dyn Illumination)>,
    pub light_count: usize,
    pub camera: &'a Camera,
    pub settings: MarchSettings,
    pub spp: u32,
    pub seed: u64,
}

/// Renders every pixel.
pub fn render_pixels(job: &PixelJob, progress: &ProgressBar) -> PixelPasses {
    let (w, h) = (job.camera.width, job.camera.height);
    let nl = job.light_count;
    // alpha, emission, scatter, per light, shadow, ground, depth.
    let stride = 1 + 3 + 3 + 3 * nl + 3 + 3 + 1;
    let (shadow_at, ground_at) = (7 + 3 * nl, 10 + 3 * nl);
    let sigma_t = job.volume.medium.sigma_t();
    let tiles_x = w.div_ceil(TILE);
    let tiles = tiles_x * h.div_ceil(TILE);
    let frame = job.camera.frame();
    let samples = AtomicU64::new(0);
    let results: Vec<(usize, Vec<f32>)> = (0..tiles)
        .into_par_iter()
        .map_init(
            || Scratch::new(nl),
            |scratch, tile| {
                let (x0, y0) = ((tile % tiles_x) * TILE, (tile / tiles_x) * TILE);
                let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
                let mut out = vec![0f32; (x1 - x0) * (y1 - y0) * stride];
                let mut tile_samples = 0;
                let mut acc = vec![0f64; stride - 1];
                for y in y0..y1 {
                    for x in x0..x1 {
                        let px = &mut out[((y - y0) * (x1 - x0) + (x - x0)) * stride..][..stride];
                        acc.fill(0.0);
                        let (mut depth_sum, mut depth_n) = (0.0, 0u32);
                        for s in 0..job.spp {
                            let (jx, jy) = if job.spp == 1 {
                                (0.5, 0.5)
                            } else {
                                (
                                    unit_random(job.seed, x, y, s, 1),
                                    unit_random(job.seed, x, y, s, 2),
                                )
                            };
                            let (o, d) = job.camera.ray(&frame, x as f64 + jx, y as f64 + jy);
                            let u = unit_random(job.seed, x, y, s, 0);
                            let mut ray = WorldRay::new(o, d);
                            let hit = job.ground.and_then(|(g, lights)| {
                                let (t, n) = g.hit(ray.origin, ray.dir)?;
                                Some((
                                    g,
                                    t,
                                    g.light_at(ray.origin + ray.dir * t, n, lights, sigma_t),
                                ))
                            });
                            let visible = hit.filter(|(g, _, _)| g.visible);
                            if let Some((_, t, _)) = visible {
                                ray.t_max = t;
                            }
                            let r = march(job.volume, job.lights, &ray, &job.settings, u, scratch);
                            tile_samples += r.samples;
                            match hit {
                                Some((_, _, light)) => {
                                    for c in 0..3 {
                                        acc[shadow_at + c] += light.fraction[c];
                                    }
                                }
                                None => (0..3).for_each(|c| acc[shadow_at + c] += 1.0),
                            }
                            let mut half_t = r.half_opacity_t;
                            if let Some((_, t, light)) = visible {
                                // An opaque grey floor behind the volume.
                                let radiance = light.irradiance * (ALBEDO / std::f64::consts::PI);
                                for c in 0..3 {
                                    acc[ground_at + c] += r.transmittance[c] * radiance[c];
                                }
                                acc[0] += 1.0;
                                half_t = half_t.or(Some(t));
                            } else {
                                acc[0] += r.alpha();
                            }
                            for c in 0..3 {
                                acc[1 + c] += r.emission[c];
                                acc[4 + c] += r.scatter[c];
                            }
                            for (l, v) in scratch.per_light.iter().enumerate().take(nl) {
                                for c in 0..3 {
                                    acc[7 + 3 * l + c] += v[c];
                                }
                            }
                            if let Some(t) = half_t {
                                depth_sum += t * d.dot(frame.forward);
                                depth_n += 1;
                            }
                        }
                        let inv = 1.0 / job.spp as f64;
                        for (dst, a) in px.iter_mut().zip(&acc) {
                            let v = (a * inv) as f32;
                            *dst = if v.is_finite() { v } else { 0.0 };
                        }
                        // Z follows the pixel's opacity: finite only where the mean alpha reaches 0.5
                        // (then at least one sample crossed it), the mean of the crossings.
                        px[stride - 1] = if depth_n > 0 && acc[0] * inv >= 0.5 {
                            (depth_sum / depth_n as f64) as f32
                        } else {
                            f32::INFINITY
                        };
                    }
                }
                samples.fetch_add(tile_samples, Ordering::Relaxed);
                progress.inc(1);
                (tile, out)
            },
        )
        .collect();
    let n = w * h;
    let plane = || vec![0f32; n];
    let mut p = PixelPasses {
        width: w,
        height: h,
        alpha: plane(),
        emission: [plane(), plane(), plane()],
        scatter: [plane(), plane(), plane()],
        per_light: (0..nl).map(|_| [plane(), plane(), plane()]).collect(),
        depth: vec![f32::INFINITY; n],
        shadow: job
            .ground
            .map(|_| [vec![1f32; n], vec![1f32; n], vec![1f32; n]]),
        ground: job
            .ground
            .filter(|(g, _)| g.visible)
            .map(|_| [plane(), plane(), plane()]),
        rays: (n as u64) * job.spp as u64,
        samples: samples.load(Ordering::Relaxed),
    };
    for (tile, out) in results {
        let (x0, y0) = ((tile % tiles_x) * TILE, (tile / tiles_x) * TILE);
        let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
        for y in y0..y1 {
            for x in x0..x1 {
                let px = &out[((y - y0) * (x1 - x0) + (x - x0)) * stride..][..stride];
                let i = y * w + x;
                p.alpha[i] = px[0];
                for c in 0..3 {
                    p.emission[c][i] = px[1 + c];
                    p.scatter[c][i] = px[4 + c];
                }
                for l in 0..nl {
                    for c in 0..3 {
                        p.per_light[l][c][i] = px[7 + 3 * l + c];
                    }
                }
                p.depth[i] = px[stride - 1];
                if let Some(sh) = &mut p.shadow {
                    for c in 0..3 {
                        sh[c][i] = px[shadow_at + c];
                    }
                }
                if let Some(gr) = &mut p.ground {
                    for c in 0..3 {
                        gr[c][i] = px[ground_at + c];
                    }
                }
            }
        }
    }
    p
}
