//! The shutter's sampling noise under `--max-error`: when something moves while the
//! shutter is open, a pixel's value is the mean of its samples over the shutter (and
//! over the pixel), and a few samples leave noise that no march setting removes. Its
//! share of the error chooses the samples a pixel.
//!
//! The samples are taken at the pixel's centre and spread over the shutter only
//! (`PixelJob::centred`): the sharp render's pixel, blurred. Jittered over the pixel
//! they would also average its area, a noise the sharp render never pays (on the pyro
//! at 0.02 that took 31 samples a pixel against 2). With `--spp` given they are
//! jittered as usual.
//!
//! The noise of `n` samples a pixel is measured, not assumed: a lattice of about
//! [`NOISE_PILOT_PIXELS`] pixels is rendered with the render's own estimator (its
//! stratified shutter times, its camera motion) at `n` samples under two
//! independent seeds, the render's and another. The two estimates differ by √2 times
//! the noise of one, so the noise is `‖A − B‖ / (√2 ‖(A + B)/2‖)`, relative to the
//! pilot's radiance as the rest of the budget is. It is measured at 1, 2 and 8 samples;
//! its order (error ∝ n^−p: ½ for independent samples, more for the stratified, mirrored
//! times of a smooth motion) is fitted from 2 and 8, the fewest samples the fit says
//! meet the share are measured in turn, and more are taken until the measurement meets
//! it (at most [`ROUNDS`] times). The error reported is the one measured at the chosen
//! count.

use crate::integrate::integrator::{Integrator, SampleRng, shutter_time};
use crate::render::pixels::PixelJob;
use crate::scene::camera::Camera;
use crate::scene::camera_motion::CameraMotion;
use crate::scene::pilot::{beauty_per_pixel, pixel_lattice};
use serde::Serialize;

/// Pixels the noise pilot renders (a regular lattice over the image).
pub const NOISE_PILOT_PIXELS: usize = 1024;
/// The most samples a pixel `--max-error` takes (as `--spp` allows).
pub const MAX_SPP: u32 = 4096;
/// Measurements after the first three, each with more samples, before the last count is
/// taken whatever it measured.
pub const ROUNDS: usize = 4;
/// Added to the render's seed for the pilot's second, independent estimate.
const SECOND_SEED: u64 = 0x6A09_E667_F3BC_C908;
/// The fitted order is kept within these (a noisy measurement of a noise).
const ORDERS: (f64, f64) = (0.25, 2.0);

/// How the pixels are sampled while the shutter is open: what the pilot renders with.
#[derive(Clone, Copy)]
pub struct Shutter<'a> {
    pub shutter: (f64, f64),
    pub camera_motion: Option<&'a CameraMotion>,
    pub overscan: (usize, usize),
    /// `--spp` as given: it wins; its noise is measured and reported.
    pub given_spp: Option<u32>,
}

/// What the shutter's noise chose (the stats' `error_budget.shutter_noise`).
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct NoiseReport {
    /// Samples a pixel: chosen, or `--spp` as given.
    pub spp: u32,
    pub spp_given: bool,
    /// The samples are taken at each pixel's centre, spread over the shutter only (edges
    /// antialiased as at one sample a pixel); false with `--spp` given (jittered over
    /// the pixel as without `--max-error`).
    pub centred: bool,
    /// The noise's share of the error, and the noise measured at `spp`.
    pub share: f64,
    pub error: f64,
    /// The fitted order p (error ∝ spp^−p), from 2 and 8 samples (null when 1 or 2
    /// sufficed or `--spp` was given).
    pub order: Option<f64>,
    /// Every count measured, with its noise.
    pub measured: Vec<(u32, f64)>,
    pub pilot_pixels: usize,
}

/// Chooses the samples a pixel for a noise of at most `share`, measuring the noise of
/// `integrator`'s samples over the shutter (see the module's text).
pub fn choose_spp<I: Integrator>(
    integrator: &I,
    camera: &Camera,
    seed: u64,
    shutter: Shutter,
    share: f64,
) -> NoiseReport {
    let pixels = pixel_lattice(camera.width, camera.height, NOISE_PILOT_PIXELS);
    let mut measured = Vec::new();
    let mut measure = |n: u32| {
        let e = noise(integrator, camera, seed, &shutter, &pixels, n);
        measured.push((n, e));
        e
    };
    let (spp, error, order) = match shutter.given_spp {
        Some(n) => (n, measure(n), None),
        None => search(share, &mut measure),
    };
    NoiseReport {
        spp,
        spp_given: shutter.given_spp.is_some(),
        centred: shutter.given_spp.is_none(),
        share,
        error,
        order,
        measured,
        pilot_pixels: pixels.len(),
    }
}

/// The fewest samples whose measured noise is within `share` (see the module's text):
/// the count, its noise, and the fitted order.
fn search(share: f64, measure: &mut impl FnMut(u32) -> f64) -> (u32, f64, Option<f64>) {
    let e1 = measure(1);
    if e1 <= share {
        return (1, e1, None);
    }
    let e2 = measure(2);
    if e2 <= share {
        return (2, e2, None);
    }
    let e8 = measure(8);
    let order = if e8 > 0.0 {
        ((e2 / e8).ln() / 4f64.ln()).clamp(ORDERS.0, ORDERS.1)
    } else {
        ORDERS.1
    };
    // The fewest the fit says meet the share, then more until one does.
    let want = |from: u32, e: f64| {
        let n = (from as f64 * (e / share).powf(1.0 / order) * (1.0 - 1e-12)).ceil();
        n.min(MAX_SPP as f64) as u32
    };
    let mut n = want(2, e2).clamp(3, MAX_SPP);
    if n == 8 {
        if e8 <= share {
            return (8, e8, Some(order));
        }
        n = 9;
    }
    let mut e = measure(n);
    for _ in 0..ROUNDS {
        if e <= share || n >= MAX_SPP {
            break;
        }
        n = want(n, e).max(n + 1).min(MAX_SPP);
        e = measure(n);
    }
    (n, e, Some(order))
}

/// The relative noise of `n` samples a pixel on `pixels`: two estimates under
/// independent seeds differ by √2 times the noise of one.
fn noise<I: Integrator>(
    integrator: &I,
    camera: &Camera,
    seed: u64,
    shutter: &Shutter,
    pixels: &[(usize, usize)],
    n: u32,
) -> f64 {
    let a = pixel_means(integrator, camera, seed, shutter, pixels, n);
    let b = pixel_means(
        integrator,
        camera,
        seed.wrapping_add(SECOND_SEED),
        shutter,
        pixels,
        n,
    );
    let diff: f64 = a.iter().zip(&b).map(|(x, y)| (x - y) * (x - y)).sum();
    let norm: f64 = a.iter().zip(&b).map(|(x, y)| (0.5 * (x + y)).powi(2)).sum();
    if norm > 0.0 {
        (diff / (2.0 * norm)).sqrt()
    } else {
        0.0
    }
}

/// Each pixel's beauty RGB as the render estimates it with `n` samples and `seed`
/// (the pixel loop's own sample points, shutter times and camera motion), flattened.
fn pixel_means<I: Integrator>(
    integrator: &I,
    camera: &Camera,
    seed: u64,
    shutter: &Shutter,
    pixels: &[(usize, usize)],
    n: u32,
) -> Vec<f64> {
    let job = PixelJob {
        integrator,
        camera,
        spp: n,
        seed,
        rows: 0..camera.height,
        antialias: 1,
        deep: None,
        deep_aovs: &[],
        holdout: None,
        shutter: Some(shutter.shutter),
        camera_motion: shutter.camera_motion,
        centred: shutter.given_spp.is_none(),
        overscan: shutter.overscan,
    };
    let frame = camera.frame();
    beauty_per_pixel(integrator, pixels, |(x, y), scratch, acc| {
        let (sx, sy) = job.stream_pixel(x, y);
        for s in 0..n {
            let (jx, jy, stream) = job.sample_point(sx, sy, 0, s);
            let time = shutter_time(seed, sx, sy, s, n, shutter.shutter);
            let sample = job.camera_sample(&frame, x, y, jx, jy, Some(time));
            let mut rng = SampleRng::new(seed, sx, sy, stream);
            integrator.sample(&sample, &mut rng, scratch, acc);
        }
        n
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A noise of `c / n^p`: the search takes the fewest counts that meet the share.
    fn chosen(c: f64, p: f64, share: f64) -> (u32, f64, Vec<u32>) {
        let mut counts = Vec::new();
        let (n, e, _) = search(share, &mut |n| {
            counts.push(n);
            c / (n as f64).powf(p)
        });
        (n, e, counts)
    }

    #[test]
    fn the_search_takes_the_fewest_samples_that_meet_the_share() {
        for (c, p, share) in [
            (0.1, 0.5, 0.2),
            (0.1, 0.5, 0.01),
            (0.1, 1.0, 0.003),
            (0.1, 1.5, 0.001),
            (0.3, 0.5, 0.05),
        ] {
            let (n, e, _) = chosen(c, p, share);
            let need = ((c / share).powf(1.0 / p) - 1e-9).ceil().max(1.0) as u32;
            assert!(e <= share, "{c} {p} {share}: {n} gives {e}");
            assert_eq!(n, need, "{c} {p} {share}");
        }
        // Nothing moves visibly: one sample.
        assert_eq!(chosen(0.0, 0.5, 1e-3).0, 1);
        // Never more than MAX_SPP, even for a share out of reach.
        let (n, e, counts) = chosen(1.0, 0.5, 1e-9);
        assert_eq!(n, MAX_SPP);
        assert!(e > 1e-9 && counts.len() <= 4 + ROUNDS, "{counts:?}");
    }
}
