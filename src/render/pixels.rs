//! The pixel loop: 16×16 tiles in parallel (rayon), each pixel's samples integrated by
//! an [`Integrator`] into the buffer its passes lay out, then averaged.

use crate::integrate::WorldRay;
use crate::integrate::deep::{DeepAov, DeepPoint};
use crate::integrate::deep_pixel::{DeepPixel, PixelAovs, pixel_samples};
use crate::integrate::integrator::{
    CameraSample, Integrator, SampleRng, shutter_time, unit_random,
};
use crate::integrate::pass::{PassKind, PassLayout};
use crate::output::{DeepImage, DeepSample};
use crate::scene::camera::{Camera, CameraFrame};
use crate::scene::camera_motion::CameraMotion;
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
    /// With deep output: each pixel's deep samples (and AOVs), row-major (empty outside
    /// the rows).
    pub deep: Option<Vec<DeepPixel>>,
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
    /// Edge antialiasing at one sample a pixel: a pixel whose alpha differs from a
    /// neighbour's by more than [`EDGE_ALPHA`] is sampled again on an `antialias ×
    /// antialias` stratified grid (0 or 1: pixel centres only). See [`render_pixels`].
    pub antialias: u32,
    /// Deep output with this merge tolerance (`--deep-tolerance`): the integrator must
    /// keep its rays' records ([`Integrator::deep_trace`]).
    pub deep: Option<f64>,
    /// With deep output: the layers each deep sample carries too (`--deep-aovs`); the
    /// integrator must keep them in its records ([`Integrator::deep_aovs`]).
    pub deep_aovs: &'a [DeepAov],
    /// `--holdout-depth`: per pixel, the camera-space depth at which its rays stop.
    pub holdout: Option<&'a [f32]>,
    /// `--shutter`: open and close in frames from the frame; each sample is taken at a
    /// time in it ([`shutter_time`]). `None`: every sample at the frame's time.
    pub shutter: Option<(f64, f64)>,
    /// With the shutter: the camera's motion while it is open (`None`: still).
    pub camera_motion: Option<&'a CameraMotion>,
    /// Every sample at the pixel's centre, `spp` of them spread over the shutter: how
    /// `--max-error` samples a moving scene (edges are antialiased at one sample a
    /// pixel only, as without it).
    pub centred: bool,
    /// The frame's overscan (x, y): random streams are keyed by the pixel's place in
    /// the image, so that an overscanned frame holds the image's pixels unchanged.
    pub overscan: (usize, usize),
}

impl<I: Integrator> PixelJob<'_, I> {
    /// The pixel `(x, y)` of the frame as its random streams know it: its place in the
    /// image, whatever the overscan (wrapping left of and above the image).
    pub(super) fn stream_pixel(&self, x: usize, y: usize) -> (usize, usize) {
        (
            x.wrapping_sub(self.overscan.0),
            y.wrapping_sub(self.overscan.1),
        )
    }

    /// Sample `s` of the pixel whose streams are keyed by `(sx, sy)`: its jitter inside
    /// the pixel and its stream. `grid` > 0: one sample in each cell of a `grid`²
    /// stratified grid, on streams 1.. (the centre's is 0); else `spp` samples, the
    /// pixel's centre alone at one sample a pixel or when `centred`.
    pub(super) fn sample_point(&self, sx: usize, sy: usize, grid: u32, s: u32) -> (f64, f64, u32) {
        let stream = sample_stream(grid, s);
        if grid > 0 {
            (
                ((s % grid) as f64 + unit_random(self.seed, sx, sy, stream, 1)) / grid as f64,
                ((s / grid) as f64 + unit_random(self.seed, sx, sy, stream, 2)) / grid as f64,
                stream,
            )
        } else if self.spp == 1 || self.centred {
            (0.5, 0.5, stream)
        } else {
            (
                unit_random(self.seed, sx, sy, stream, 1),
                unit_random(self.seed, sx, sy, stream, 2),
                stream,
            )
        }
    }

    /// The camera ray through `(x + jx, y + jy)`, cut to the camera's clipping planes
    /// and to the pixel's holdout depth, taken at `time` in the shutter (frames from the
    /// frame; a moving camera is where it is then).
    pub(super) fn camera_sample(
        &self,
        frame: &CameraFrame,
        x: usize,
        y: usize,
        jx: f64,
        jy: f64,
        time: Option<f64>,
    ) -> CameraSample {
        let moved = match (self.camera_motion, time) {
            (Some(m), Some(t)) => {
                let c = m.at(t);
                Some((c, c.frame()))
            }
            _ => None,
        };
        let (camera, frame) = match &moved {
            Some((c, f)) => (c, f),
            None => (self.camera, frame),
        };
        let (o, d) = camera.ray(frame, x as f64 + jx, y as f64 + jy);
        let mut ray = WorldRay::new(o, d);
        (ray.t_min, ray.t_max) = camera.clip(frame, ray.dir);
        ray.time = time.unwrap_or(0.0);
        let depth_rate = d.dot(frame.forward);
        if let Some(depth) = self.holdout.and_then(|h| h.get(y * self.camera.width + x)) {
            // Depth is t × depth_rate along the ray.
            let t = *depth as f64 / depth_rate;
            if t < ray.t_max {
                ray.t_max = t.max(0.0);
            }
        }
        CameraSample { ray, depth_rate }
    }

    /// Whether edges are antialiased: one sample a pixel, `antialias` > 1, and an alpha
    /// pass to find them by.
    pub(super) fn edges(&self) -> bool {
        self.spp == 1
            && self.antialias > 1
            && self
                .integrator
                .passes()
                .offset_of_kind(PassKind::Alpha)
                .is_some()
    }

    /// The rows whose centres are rendered: the job's, and with edge antialiasing one
    /// more on each side for the neighbours.
    pub(super) fn centre_rows(&self) -> (usize, usize) {
        let h = self.camera.height;
        let (r0, r1) = (self.rows.start.min(h), self.rows.end.min(h));
        if self.edges() && r1 > r0 {
            (r0.saturating_sub(1), (r1 + 1).min(h))
        } else {
            (r0, r1)
        }
    }

    /// The tiles the render reports progress in.
    pub fn tiles(&self) -> usize {
        let (c0, c1) = self.centre_rows();
        self.camera.width.div_ceil(TILE) * c1.saturating_sub(c0).div_ceil(TILE)
    }
}

/// The random stream of sample `s` of a pixel sampled on a `grid`² stratified grid
/// (0: the job's samples): its index, one more on the grid (the centre's is 0).
pub(super) fn sample_stream(grid: u32, s: u32) -> u32 {
    if grid > 0 { s + 1 } else { s }
}

/// The alpha difference to a neighbour above which a pixel is an edge (0.05 resampled
/// 3 % of the demo cloud's pixels at 640×360, its fBm detail, for +77 % CPU; 0.1 0.2 %
/// for +6 %; on dense clouds' silhouettes at 80×45 0.05, 0.1 and 0.2 found the same
/// pixels). Alpha is what decides because the march integrates optical depth exactly:
/// it does not move with the step, the shadow tolerance or the scattering mode, so the
/// same pixels are resampled in a render and in its `--reference`.
pub const EDGE_ALPHA: f32 = 0.1;

/// Renders every pixel of the job's rows.
///
/// With one sample a pixel it is the pixel's centre, which is the mean over the pixel
/// wherever the image is smooth on the scale of a pixel, but not across a silhouette: a
/// dense volume's edge, often its brightest part when it is lit from behind, would
/// alias. With `antialias` N > 1 the pixels whose alpha differs from one of their eight
/// neighbours' by more than [`EDGE_ALPHA`] are rendered again as the mean of N×N
/// samples, one jittered in each cell of an N×N grid over the pixel, which estimates the
/// pixel's mean (what a many-sample render converges to) at a fraction of the cost of
/// N² samples everywhere. The decision reads the centres of the neighbours, so a band of
/// rows renders the row above and below it too: a pixel's value never depends on which
/// rows or threads rendered it.
pub fn render_pixels<I: Integrator>(job: &PixelJob<I>, progress: &dyn Progress) -> PixelPasses {
    let (w, h) = (job.camera.width, job.camera.height);
    let layout = job.integrator.passes().clone();
    let stride = layout.slots();
    let alpha_at = layout.offset_of_kind(PassKind::Alpha);
    let depth_at = layout.offset_of_kind(PassKind::Depth);
    let (r0, r1) = (job.rows.start.min(h), job.rows.end.min(h));
    let edges = job.edges();
    let (c0, c1) = job.centre_rows();
    let frame = job.camera.frame();
    let samples = AtomicU64::new(0);
    // One pixel: the mean of `grid`² samples, stratified over the pixel (grid 0: its
    // centre alone), into `px`; returns the samples' count of march samples.
    let render_pixel = |x: usize,
                        y: usize,
                        grid: u32,
                        scratch: &mut I::Scratch,
                        acc: &mut [f64],
                        px: &mut [f32],
                        deep: &mut DeepPixel,
                        curves: &mut Vec<Vec<DeepPoint>>|
     -> u64 {
        acc.fill(0.0);
        // The rays' deep curves, in buffers a thread keeps from pixel to pixel.
        let mut n_curves = 0;
        let mut aov_rows: Vec<Vec<f64>> = Vec::new();
        let mut aov_width = 0;
        let mut n_samples = 0;
        let count = if grid == 0 { job.spp } else { grid * grid };
        let (sx, sy) = job.stream_pixel(x, y);
        for s in 0..count {
            let (jx, jy, stream) = job.sample_point(sx, sy, grid, s);
            let time = job
                .shutter
                .map(|shutter| shutter_time(job.seed, sx, sy, s, count, shutter));
            let sample = job.camera_sample(&frame, x, y, jx, jy, time);
            let mut rng = SampleRng::new(job.seed, sx, sy, stream);
            n_samples += job.integrator.sample(&sample, &mut rng, scratch, acc);
            if job.deep.is_some()
                && let Some(trace) = job.integrator.deep_trace(scratch)
            {
                if curves.len() == n_curves {
                    curves.push(Vec::new());
                }
                trace.to_depth_into(sample.depth_rate, &mut curves[n_curves]);
                n_curves += 1;
                if !job.deep_aovs.is_empty() {
                    aov_rows.push(trace.aovs.clone());
                    aov_width = trace.aov_width;
                }
            }
        }
        if let Some(tolerance) = job.deep {
            deep.clear();
            let aovs = (aov_width > 0).then_some(PixelAovs {
                rows: &aov_rows,
                width: aov_width,
                wanted: job.deep_aovs,
            });
            pixel_samples(&curves[..n_curves], tolerance, aovs, deep);
        }
        finish_pixel(px, acc, count as usize, alpha_at, depth_at);
        n_samples
    };
    // Pass 1: the centres (or the job's samples), 16×16 tiles in parallel, into one
    // row-major buffer of rows c0..c1.
    let tiles_x = w.div_ceil(TILE);
    let tiles = job.tiles();
    let results: Vec<(usize, Vec<f32>, Vec<DeepPixel>)> = (0..tiles)
        .into_par_iter()
        .map_init(
            || (job.integrator.scratch(), vec![0f64; stride], Vec::new()),
            |(scratch, acc, curves), tile| {
                let (x0, y0) = ((tile % tiles_x) * TILE, c0 + (tile / tiles_x) * TILE);
                let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(c1));
                let n = (x1 - x0) * (y1 - y0);
                let mut out = vec![0f32; n * stride];
                let mut deep = vec![DeepPixel::default(); if job.deep.is_some() { n } else { 0 }];
                let mut none = DeepPixel::default();
                let mut tile_samples = 0;
                for y in y0..y1 {
                    for x in x0..x1 {
                        let i = (y - y0) * (x1 - x0) + (x - x0);
                        let px = &mut out[i * stride..][..stride];
                        let d = deep.get_mut(i).unwrap_or(&mut none);
                        tile_samples += render_pixel(x, y, 0, scratch, acc, px, d, curves);
                    }
                }
                samples.fetch_add(tile_samples, Ordering::Relaxed);
                progress.advance(1);
                (tile, out, deep)
            },
        )
        .collect();
    let mut values = vec![0f32; w * (c1 - c0) * stride];
    let mut deep: Option<Vec<DeepPixel>> = job.deep.map(|_| vec![DeepPixel::default(); w * h]);
    // The tiles into the buffer, a band of a tile's height (a row of tiles) per task.
    values
        .par_chunks_mut((TILE * w * stride).max(1))
        .zip(results.par_chunks(tiles_x.max(1)))
        .for_each(|(band, row_of_tiles)| {
            for (tile, out, _) in row_of_tiles {
                let (x0, y0) = ((tile % tiles_x) * TILE, c0 + (tile / tiles_x) * TILE);
                let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(c1));
                for y in y0..y1 {
                    let src = &out[(y - y0) * (x1 - x0) * stride..][..(x1 - x0) * stride];
                    band[((y - y0) * w + x0) * stride..][..src.len()].copy_from_slice(src);
                }
            }
        });
    for (tile, _, tile_deep) in results {
        let (x0, y0) = ((tile % tiles_x) * TILE, c0 + (tile / tiles_x) * TILE);
        let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(c1));
        if let Some(d) = deep.as_mut() {
            let mut px = tile_deep.into_iter();
            for y in y0..y1 {
                for x in x0..x1 {
                    let samples = px.next().unwrap_or_default();
                    if (r0..r1).contains(&y) {
                        d[y * w + x] = samples;
                    }
                }
            }
        }
    }
    // Pass 2: the edges, again on the stratified grid.
    let mut resampled = 0u64;
    if let (true, Some(a)) = (edges && r1 > r0, alpha_at) {
        let alpha = |x: usize, y: usize| values[((y - c0) * w + x) * stride + a];
        let is_edge = |x: usize, y: usize| {
            let here = alpha(x, y);
            (y.saturating_sub(1)..(y + 2).min(h)).any(|ny| {
                (x.saturating_sub(1)..(x + 2).min(w))
                    .any(|nx| (alpha(nx, ny) - here).abs() > EDGE_ALPHA)
            })
        };
        let edge_pixels: Vec<(usize, usize)> = (r0..r1)
            .into_par_iter()
            .flat_map_iter(|y| (0..w).map(move |x| (x, y)).filter(|&(x, y)| is_edge(x, y)))
            .collect();
        let again: Vec<(usize, Vec<f32>, Vec<DeepPixel>)> = edge_pixels
            .par_chunks(TILE * TILE / 4)
            .enumerate()
            .map_init(
                || (job.integrator.scratch(), vec![0f64; stride], Vec::new()),
                |(scratch, acc, curves), (chunk, pixels)| {
                    let mut out = vec![0f32; pixels.len() * stride];
                    let mut deep = vec![DeepPixel::default(); pixels.len()];
                    let mut chunk_samples = 0;
                    for ((&(x, y), px), d) in pixels
                        .iter()
                        .zip(out.chunks_mut(stride))
                        .zip(deep.iter_mut())
                    {
                        chunk_samples +=
                            render_pixel(x, y, job.antialias, scratch, acc, px, d, curves);
                    }
                    samples.fetch_add(chunk_samples, Ordering::Relaxed);
                    (chunk, out, deep)
                },
            )
            .collect();
        for (chunk, out, chunk_deep) in again {
            let pixels = &edge_pixels[chunk * (TILE * TILE / 4)..];
            for ((&(x, y), px), d) in pixels.iter().zip(out.chunks(stride)).zip(chunk_deep) {
                values[((y - c0) * w + x) * stride..][..stride].copy_from_slice(px);
                if let Some(all) = deep.as_mut() {
                    all[y * w + x] = d;
                }
            }
        }
        resampled = edge_pixels.len() as u64;
    }
    let n = w * h;
    let mut planes: Vec<Vec<Vec<f32>>> = layout
        .passes()
        .iter()
        .map(|p| match p.kind {
            PassKind::Rgb => vec![vec![0f32; n]; 3],
            PassKind::Alpha | PassKind::Matte => vec![vec![0f32; n]],
            PassKind::Depth => vec![vec![f32::INFINITY; n]],
        })
        .collect();
    // Each plane's rows from the pixels' slots, planes and rows side by side.
    let mut targets: Vec<(usize, &mut Vec<f32>)> = Vec::new();
    for (p, pass_planes) in planes.iter_mut().enumerate() {
        let at = layout.offset(p);
        targets.extend(pass_planes.iter_mut().enumerate().map(|(c, v)| (at + c, v)));
    }
    targets.into_par_iter().for_each(|(slot, plane)| {
        plane[r0 * w..r1 * w]
            .par_chunks_mut(w.max(1))
            .enumerate()
            .for_each(|(r, row)| {
                let src = &values[(r0 + r - c0) * w * stride..];
                for (x, v) in row.iter_mut().enumerate() {
                    *v = src[x * stride + slot];
                }
            });
    });
    PixelPasses {
        width: w,
        height: h,
        layout,
        planes,
        rays: ((c1.saturating_sub(c0) * w) as u64) * job.spp as u64
            + resampled * (job.antialias as u64).pow(2),
        samples: samples.load(Ordering::Relaxed),
        deep,
    }
}

/// A pixel's values from the sums of its `count` samples: their means (non-finite ones 0),
/// and Z, which follows the pixel's opacity: finite only where the mean alpha reaches 0.5
/// (then at least one sample crossed it), the mean of the crossings.
pub(crate) fn finish_pixel(
    px: &mut [f32],
    acc: &[f64],
    count: usize,
    alpha_at: Option<usize>,
    depth_at: Option<usize>,
) {
    let inv = 1.0 / count.max(1) as f64;
    for (dst, a) in px.iter_mut().zip(acc.iter()) {
        let v = (a * inv) as f32;
        *dst = if v.is_finite() { v } else { 0.0 };
    }
    if let Some(d) = depth_at {
        let opaque = alpha_at.is_none_or(|a| acc[a] * inv >= 0.5);
        px[d] = if acc[d + 1] > 0.0 && opaque {
            (acc[d] / acc[d + 1]) as f32
        } else {
            f32::INFINITY
        };
    }
}

/// The deep image of a render's pixels (rows top to bottom), with the layers
/// `aov_layers` where the pixels carry AOV values.
pub fn deep_image(
    pixels: Vec<DeepPixel>,
    width: usize,
    height: usize,
    aov_layers: Vec<String>,
) -> DeepImage {
    // Half a million pixels' lists: on every thread.
    let (samples, values): (Vec<_>, Vec<_>) = pixels
        .into_par_iter()
        .map(|px| {
            let samples: Vec<DeepSample> = px
                .samples
                .iter()
                .map(|s| DeepSample {
                    z: s.z,
                    z_back: s.z_back,
                    rgba: [s.rgb[0], s.rgb[1], s.rgb[2], s.alpha],
                })
                .collect();
            (samples, px.aovs)
        })
        .unzip();
    let aovs = if aov_layers.is_empty() {
        Vec::new()
    } else {
        values
    };
    DeepImage {
        width,
        height,
        pixels: samples,
        aov_layers,
        aovs,
    }
}

#[cfg(test)]
#[path = "pixels_tests.rs"]
mod tests;
