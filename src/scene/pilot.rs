//! The pilot of `--max-error`: a regular lattice of about [`PILOT_PIXELS`] pixel centres
//! rendered through an integrator, and the relative error between two such renders. The
//! render's error budget (`render::error_budget`) chooses the step and termination with
//! it, and the scene ([`super::density_level`]) the density's level.

use crate::integrate::WorldRay;
use crate::integrate::integrator::{CameraSample, Integrator, SampleRng};
use crate::integrate::pass::beauty_rgb;
use crate::scene::camera::Camera;
use rayon::prelude::*;

/// Pixels the pilot renders (a regular lattice over the image).
pub const PILOT_PIXELS: usize = 2048;

/// The pilot's pixels: centres of a regular lattice of about [`PILOT_PIXELS`], or every
/// pixel of a small image.
pub fn pilot_pixels(width: usize, height: usize) -> Vec<(usize, usize)> {
    pixel_lattice(width, height, PILOT_PIXELS)
}

/// Centres of a regular lattice of about `count` pixels over the image (every pixel of a
/// smaller one).
pub fn pixel_lattice(width: usize, height: usize, count: usize) -> Vec<(usize, usize)> {
    let stride = ((width * height) as f64 / count.max(1) as f64)
        .sqrt()
        .ceil()
        .max(1.0) as usize;
    let mut px = Vec::new();
    let mut y = stride / 2;
    while y < height {
        let mut x = stride / 2;
        while x < width {
            px.push((x, y));
            x += stride;
        }
        y += stride;
    }
    px
}

/// Beauty RGB of each pilot pixel (its centre, sample 0 of `seed`), flattened.
pub fn render_pilot<I: Integrator>(
    integrator: &I,
    camera: &Camera,
    seed: u64,
    pixels: &[(usize, usize)],
) -> Vec<f64> {
    let frame = camera.frame();
    beauty_per_pixel(integrator, pixels, |(x, y), scratch, acc| {
        let (o, d) = camera.ray(&frame, x as f64 + 0.5, y as f64 + 0.5);
        let mut ray = WorldRay::new(o, d);
        (ray.t_min, ray.t_max) = camera.clip(&frame, ray.dir);
        let sample = CameraSample {
            ray,
            depth_rate: d.dot(frame.forward),
        };
        let mut rng = SampleRng::new(seed, x, y, 0);
        integrator.sample(&sample, &mut rng, scratch, acc);
        1
    })
}

/// Each of `pixels`' beauty RGB, flattened, in parallel: `samples` adds a pixel's samples
/// into its (zeroed) accumulator and returns how many it took.
pub fn beauty_per_pixel<I: Integrator>(
    integrator: &I,
    pixels: &[(usize, usize)],
    samples: impl Fn((usize, usize), &mut I::Scratch, &mut [f64]) -> u32 + Sync,
) -> Vec<f64> {
    let layout = integrator.passes();
    let beauty = layout.beauty_offsets();
    pixels
        .par_iter()
        .map_init(
            || (integrator.scratch(), vec![0f64; layout.slots()]),
            |(scratch, acc), &pixel| {
                acc.fill(0.0);
                let n = samples(pixel, scratch, acc);
                beauty_rgb(acc, &beauty, n as f64)
            },
        )
        .flatten_iter()
        .collect()
}

/// ‖a − b‖₂ / ‖b‖₂ (0 where `b` is all dark: nothing to be wrong about).
pub fn relative_rmse(a: &[f64], b: &[f64]) -> f64 {
    let num: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
    let den: f64 = b.iter().map(|y| y * y).sum();
    if den > 0.0 { (num / den).sqrt() } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pilot_lattice_covers_the_image_evenly() {
        let px = pilot_pixels(960, 540);
        assert!(
            px.len() <= PILOT_PIXELS && px.len() >= PILOT_PIXELS / 2,
            "{}",
            px.len()
        );
        assert!(px.iter().all(|&(x, y)| x < 960 && y < 540));
        let (xs, ys): (Vec<_>, Vec<_>) = px.iter().copied().unzip();
        // Spread over the whole image, not a corner.
        assert!(*xs.iter().min().unwrap() < 20 && *xs.iter().max().unwrap() > 940);
        assert!(*ys.iter().min().unwrap() < 20 && *ys.iter().max().unwrap() > 520);
        // A small image is rendered whole.
        assert_eq!(pilot_pixels(40, 30).len(), 1200);
    }

    #[test]
    fn relative_rmse_is_the_norm_ratio() {
        assert_eq!(relative_rmse(&[1.0, 2.0], &[1.0, 2.0]), 0.0);
        let e = relative_rmse(&[1.0, 1.0], &[0.0, 2.0]);
        assert!((e - (2.0f64 / 4.0).sqrt()).abs() < 1e-15);
        assert_eq!(relative_rmse(&[1.0], &[0.0]), 0.0);
    }
}
