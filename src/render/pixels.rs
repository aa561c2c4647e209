//! The pixel loop: 16×16 tiles in parallel (rayon), each pixel's samples integrated by
//! an [`Integrator`] into the buffer its passes lay out, then averaged.

use crate::integrate::WorldRay;
use crate::integrate::integrator::{CameraSample, Integrator, SampleRng, unit_random};
use crate::integrate::pass::{PassKind, PassLayout};
use crate::scene::camera::Camera;
use crate::scene::progress::Progress;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

pub const TILE: usize = 16;

/// Per-pixel results: for every pass, its planes (3 for colour, 1 for alpha and depth),
/// row-major, top row first.
#[derive(Clone, Debug, Default)]
pub struct PixelPasses {
    pub width: usize,
    pub height: usize,
    pub layout: PassLayout,
    /// `planes[i]`: the planes of pass `i`.
    pub planes: Vec<Vec<Vec<f32>>>,
    pub rays: u64,
    pub samples: u64,
}

impl PixelPasses {
    /// The planes of the pass named `name`.
    pub fn pass(&self, name: &str) -> Option<&[Vec<f32>]> {
        self.layout.find(name).map(|i| self.planes[i].as_slice())
    }
}

/// The pixels of a frame that one render computes: all of them, or a band.
pub struct PixelJob<'a, I: Integrator> {
    pub integrator: &'a I,
    pub camera: &'a Camera,
    pub spp: u32,
    pub seed: u64,
    /// The rows rendered (all: `0..height`); other pixels stay empty. A pixel's value
    /// depends only on its position and the seed, never on which rows are rendered.
    pub rows: std::ops::Range<usize>,
}

/// Renders every pixel of the job's rows.
pub fn render_pixels<I: Integrator>(job: &PixelJob<I>, progress: &dyn Progress) -> PixelPasses {
    let (w, h) = (job.camera.width, job.camera.height);
    let layout = job.integrator.passes().clone();
    let stride = layout.slots();
    let alpha_at = layout.offset_of_kind(PassKind::Alpha);
    let depth_at = layout.offset_of_kind(PassKind::Depth);
    let tiles_x = w.div_ceil(TILE);
    let (r0, r1) = (job.rows.start.min(h), job.rows.end.min(h));
    let tiles = tiles_x * r1.saturating_sub(r0).div_ceil(TILE);
    let frame = job.camera.frame();
    let samples = AtomicU64::new(0);
    let results: Vec<(usize, Vec<f32>)> = (0..tiles)
        .into_par_iter()
        .map_init(
            || (job.integrator.scratch(), vec![0f64; stride]),
            |(scratch, acc), tile| {
                let (x0, y0) = ((tile % tiles_x) * TILE, r0 + (tile / tiles_x) * TILE);
                let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(r1));
                let mut out = vec![0f32; (x1 - x0) * (y1 - y0) * stride];
                let mut tile_samples = 0;
                for y in y0..y1 {
                    for x in x0..x1 {
                        let px = &mut out[((y - y0) * (x1 - x0) + (x - x0)) * stride..][..stride];
                        acc.fill(0.0);
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
                            let sample = CameraSample {
                                ray: WorldRay::new(o, d),
                                depth_rate: d.dot(frame.forward),
                            };
                            let mut rng = SampleRng::new(job.seed, x, y, s);
                            tile_samples += job.integrator.sample(&sample, &mut rng, scratch, acc);
                        }
                        let inv = 1.0 / job.spp as f64;
                        for (dst, a) in px.iter_mut().zip(acc.iter()) {
                            let v = (a * inv) as f32;
                            *dst = if v.is_finite() { v } else { 0.0 };
                        }
                        // Z follows the pixel's opacity: finite only where the mean alpha
                        // reaches 0.5 (then at least one sample crossed it), the mean of
                        // the crossings.
                        if let Some(d) = depth_at {
                            let opaque = alpha_at.is_none_or(|a| acc[a] * inv >= 0.5);
                            px[d] = if acc[d + 1] > 0.0 && opaque {
                                (acc[d] / acc[d + 1]) as f32
                            } else {
                                f32::INFINITY
                            };
                        }
                    }
                }
                samples.fetch_add(tile_samples, Ordering::Relaxed);
                progress.advance(1);
                (tile, out)
            },
        )
        .collect();
    let n = w * h;
    let mut planes: Vec<Vec<Vec<f32>>> = layout
        .passes()
        .iter()
        .map(|p| match p.kind {
            PassKind::Rgb => vec![vec![0f32; n]; 3],
            PassKind::Alpha => vec![vec![0f32; n]],
            PassKind::Depth => vec![vec![f32::INFINITY; n]],
        })
        .collect();
    for (tile, out) in results {
        let (x0, y0) = ((tile % tiles_x) * TILE, r0 + (tile / tiles_x) * TILE);
        let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(r1));
        for y in y0..y1 {
            for x in x0..x1 {
                let px = &out[((y - y0) * (x1 - x0) + (x - x0)) * stride..][..stride];
                let i = y * w + x;
                for (p, pass_planes) in planes.iter_mut().enumerate() {
                    let at = layout.offset(p);
                    for (c, plane) in pass_planes.iter_mut().enumerate() {
                        plane[i] = px[at + c];
                    }
                }
            }
        }
    }
    PixelPasses {
        width: w,
        height: h,
        layout,
        planes,
        rays: ((r1.saturating_sub(r0) * w) as u64) * job.spp as u64,
        samples: samples.load(Ordering::Relaxed),
    }
}
