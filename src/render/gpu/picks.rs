//! The camera samples the GPU takes: each pixel to render (a pick) and each of its
//! samples written as its pixel, holdout depth and index, and the uniform from which
//! rays.wgsl makes their rays (the camera's affine maps, the clipping planes, the
//! ground, the random streams' seed) as the CPU's pixel loop makes them
//! ([`crate::render::pixels`]: `sample_point`, `camera_sample`).

use crate::field::Field;
use crate::integrate::ground::Ground;
use crate::integrate::integrator::Integrator;
use crate::render::pixels::PixelJob;
use crate::scene::camera::CameraFrame;
use glam::DVec3;
use rayon::prelude::*;

/// One pixel to render: where and how it is sampled.
#[derive(Clone, Copy)]
pub(super) struct Pick {
    pub x: usize,
    pub y: usize,
    /// The stratified grid's size (0: the job's samples, or the centre).
    pub grid: u32,
}

/// How many samples pixel `p` takes.
pub(super) fn sample_count<I: Integrator>(job: &PixelJob<I>, p: Pick) -> u32 {
    if p.grid == 0 {
        job.spp
    } else {
        p.grid * p.grid
    }
}

/// Where each of `picks`' samples start when they are laid one pick after another (the
/// total last).
fn sample_starts<I: Integrator>(job: &PixelJob<I>, picks: &[Pick]) -> Vec<usize> {
    let mut starts = Vec::with_capacity(picks.len() + 1);
    let mut total = 0;
    for &p in picks {
        starts.push(total);
        total += sample_count(job, p) as usize;
    }
    starts.push(total);
    starts
}

/// Floats of a march sample's input: its pixel's x and y, the holdout's depth there (−1:
/// none), its index among the pixel's samples. The GPU makes its ray from them as
/// SingleScattering's own sample makes it (rays.wgsl, `camera_sample`).
pub(super) const PICK_FLOATS: usize = 4;

/// The binding of the camera's rays (rays.wgsl's `CameraRays`).
pub(super) const CAMERA_BINDING: u32 = 10;

/// The words of rays.wgsl's `CameraRays` for `job`'s camera seen in `frame`, the
/// samples of picks on a `grid`² stratified grid (0: the job's samples), `density`'s
/// index space and the ground where there is one.
pub(super) fn camera_rays<I: Integrator>(
    job: &PixelJob<I>,
    frame: &CameraFrame,
    grid: u32,
    density: &dyn Field,
    ground: Option<Ground>,
) -> Vec<u32> {
    let tr = density.transform();
    let rays = job.camera.ray_affine(frame);
    let [o0, ox, oy] = rays.origin;
    let index = [
        tr.world_to_index(o0),
        tr.world_dir_to_index(ox),
        tr.world_dir_to_index(oy),
    ];
    let columns = [DVec3::X, DVec3::Y, DVec3::Z].map(|e| tr.world_dir_to_index(e));
    let (clipped, (near, far)) = match job.camera.clip_planes() {
        Some(planes) => (1.0, planes),
        None => (0.0, (0.0, f64::INFINITY)),
    };
    let vec = |v: DVec3, w: f64| {
        [v.x, v.y, v.z, w].map(|c| (c.clamp(-F32_MAX, F32_MAX) as f32).to_bits())
    };
    let mut words = Vec::with_capacity(64);
    words.extend(vec(o0, if rays.diverge { 1.0 } else { 0.0 }));
    words.extend(vec(ox, clipped));
    words.extend(vec(oy, 0.0));
    for d in rays.dir {
        words.extend(vec(d, 0.0));
    }
    for v in index.into_iter().chain(columns) {
        words.extend(vec(v, 0.0));
    }
    words.extend(vec(frame.forward, 0.0));
    words.extend(vec(
        DVec3::new(near, far, ground.map_or(0.0, |g| g.height)),
        0.0,
    ));
    let wide = |v: usize| u32::try_from(v).unwrap_or(u32::MAX);
    words.extend([
        job.seed as u32,
        (job.seed >> 32) as u32,
        wide(job.overscan.0),
        wide(job.overscan.1),
    ]);
    words.extend([
        grid,
        u32::from(job.spp == 1 || job.centred),
        ground.map_or(0, |g| if g.visible { 2 } else { 1 }),
        0,
    ]);
    words
}

/// The largest finite f32, as f64.
const F32_MAX: f64 = f32::MAX as f64;

/// Writes the samples of `picks` into `input`, `floats` each (at least [`PICK_FLOATS`],
/// the rest left 0): each one's pick. Returns where each pick's samples start (the
/// total last).
pub(super) fn make_picks<I: Integrator>(
    job: &PixelJob<I>,
    picks: &[Pick],
    floats: usize,
    input: &mut Vec<f32>,
) -> Vec<usize> {
    let starts = sample_starts(job, picks);
    let total = starts.last().copied().unwrap_or(0);
    input.clear();
    input.resize(total * floats, 0.0);
    // Each pick's floats, filled on all threads.
    let mut rest = input.as_mut_slice();
    let mut pieces = Vec::with_capacity(picks.len());
    for k in 0..picks.len() {
        let (piece, after) = rest.split_at_mut((starts[k + 1] - starts[k]) * floats);
        pieces.push(piece);
        rest = after;
    }
    pieces.into_par_iter().zip(picks).for_each(|(piece, p)| {
        let holdout = job
            .holdout
            .and_then(|h| h.get(p.y * job.camera.width + p.x))
            .map_or(-1.0, |&d| holdout_input(d));
        for (s, out) in piece.chunks_exact_mut(floats).enumerate() {
            out[..PICK_FLOATS].copy_from_slice(&[p.x as f32, p.y as f32, holdout, s as f32]);
        }
    });
    starts
}

/// A holdout's depth as the GPU takes it: −1 where it cuts nothing (NaN or +∞, past any
/// ray's end), else the depth, at least 0 (a ray cut at a negative depth ends at 0).
fn holdout_input(depth: f32) -> f32 {
    if depth.is_nan() || depth == f32::INFINITY {
        -1.0
    } else {
        depth.max(0.0)
    }
}
