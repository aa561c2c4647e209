//! `--max-error E`: the march settings that meet a relative radiance error at least
//! cost, chosen from murk's own error model, measured on a pilot.
//!
//! The error of a render against `--reference` has three sources, which `murk converge`
//! measures one at a time: the source step (second order: the fitted order of the step
//! sweep is 2.00), early termination (about linear in the threshold) and the shadow
//! map's tolerance. They are independent, so their squares add: each gets `E/√3`.
//!
//! - The shadow map's tolerance is set before the bake (`scene::plan`), to `E/√3`: the
//!   map bounds the transmittance's absolute error by it, so a pixel's scattered light
//!   errs by at most that fraction of what an unshadowed light would give it.
//! - The step and the termination are measured on a pilot: a regular lattice of about
//!   [`PILOT_PIXELS`] pixel centres, rendered through the scene's own integrator (its
//!   lights, maps and multiple-scattering lattice). The step's error at `h₀` is
//!   Richardson's estimate `(4/3)‖L(h₀) − L(h₀/2)‖ / ‖L(h₀/2)‖`; the step is then
//!   `h₀ (E_step / err(h₀))^{1/2}`, kept within [[`MIN_STEP`], [`MAX_STEP`]] voxels. The
//!   termination is the largest of 0.1, 0.05, 0.02, 0.01, … whose measured error against
//!   no termination (at the chosen step) is within `E/√3`.
//!
//! What was chosen, what the pilot measured and the predicted error go into the stats
//! (`error_budget`) and a note.

use crate::integrate::integrator::{CameraSample, Integrator, SampleRng};
use crate::integrate::{MarchSettings, WorldRay};
use crate::scene::camera::Camera;
use crate::scene::plan::MarchPlan;
use rayon::prelude::*;
use serde::Serialize;

/// Pixels the pilot renders (a regular lattice over the image).
pub const PILOT_PIXELS: usize = 2048;
/// The pilot's first step, voxels: coarse, so that its error is well above the floor.
pub const PILOT_STEP: f64 = 2.0;
/// The finest and the coarsest step `--max-error` chooses, voxels.
pub const MIN_STEP: f64 = 1.0 / 16.0;
pub const MAX_STEP: f64 = 4.0;
/// Terminations tried, largest first (the first within budget is taken).
const TERMINATIONS: [f64; 9] = [0.1, 0.05, 0.02, 0.01, 5e-3, 2e-3, 1e-3, 1e-4, 0.0];

/// What `--max-error` chose and why (the stats' `error_budget`).
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct ErrorBudgetReport {
    pub max_error: f64,
    /// Chosen: the source step in voxels, the termination, the shadow map's tolerance
    /// (null without a map).
    pub step_voxels: f64,
    pub termination: f64,
    pub dsm_tolerance: Option<f64>,
    /// Pixels the pilot rendered, and what it measured: the step's error at
    /// [`PILOT_STEP`], the termination's error at the chosen one.
    pub pilot_pixels: usize,
    pub pilot_step_error: f64,
    pub pilot_termination_error: f64,
    /// √(step² + termination² + tolerance²), each source's predicted error.
    pub predicted_error: f64,
    pub pilot_seconds: f64,
}

impl ErrorBudgetReport {
    /// One line for the stats' notes.
    pub fn note(&self) -> String {
        format!(
            "--max-error {}: step {:.3} voxels, termination {}, shadow map tolerance {} (a pilot of {} pixels in {:.2} s; predicted error {:.2e})",
            self.max_error,
            self.step_voxels,
            self.termination,
            self.dsm_tolerance
                .map_or("none".into(), |t| format!("{t:.2e}")),
            self.pilot_pixels,
            self.pilot_seconds,
            self.predicted_error
        )
    }
}

/// The pilot's pixels: centres of a regular lattice of about [`PILOT_PIXELS`], or every
/// pixel of a small image.
fn pilot_pixels(width: usize, height: usize) -> Vec<(usize, usize)> {
    let stride = ((width * height) as f64 / PILOT_PIXELS as f64)
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
fn render_pilot<I: Integrator>(
    integrator: &I,
    camera: &Camera,
    seed: u64,
    pixels: &[(usize, usize)],
) -> Vec<f64> {
    let layout = integrator.passes().clone();
    let beauty: Vec<usize> = (0..layout.passes().len())
        .filter(|&i| layout.passes()[i].in_beauty)
        .map(|i| layout.offset(i))
        .collect();
    let frame = camera.frame();
    pixels
        .par_iter()
        .map_init(
            || (integrator.scratch(), vec![0f64; layout.slots()]),
            |(scratch, acc), &(x, y)| {
                acc.fill(0.0);
                let (o, d) = camera.ray(&frame, x as f64 + 0.5, y as f64 + 0.5);
                let mut ray = WorldRay::new(o, d);
                (ray.t_min, ray.t_max) = camera.clip(&frame, ray.dir);
                let sample = CameraSample {
                    ray,
                    depth_rate: d.dot(frame.forward),
                };
                let mut rng = SampleRng::new(seed, x, y, 0);
                integrator.sample(&sample, &mut rng, scratch, acc);
                let mut rgb = [0f64; 3];
                for &at in &beauty {
                    for (c, v) in rgb.iter_mut().enumerate() {
                        *v += acc[at + c];
                    }
                }
                rgb.map(|v| if v.is_finite() { v } else { 0.0 })
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

/// Chooses the step and termination for `max_error` by rendering the pilot through the
/// integrators `make` builds from march settings. `dsm_tolerance` is what the plan set
/// (its share of the error is counted in the prediction).
pub fn choose<I: Integrator>(
    max_error: f64,
    dsm_tolerance: Option<f64>,
    camera: &Camera,
    seed: u64,
    make: impl Fn(MarchSettings) -> I,
) -> (MarchSettings, ErrorBudgetReport) {
    let start = std::time::Instant::now();
    let budget = MarchPlan::error_share(max_error);
    let pixels = pilot_pixels(camera.width, camera.height);
    let render = |step_voxels: f64, termination: f64| {
        render_pilot(
            &make(MarchSettings {
                step_voxels,
                termination,
            }),
            camera,
            seed,
            &pixels,
        )
    };
    // The step, from Richardson's estimate at PILOT_STEP (second order).
    let coarse = render(PILOT_STEP, 0.0);
    let fine = render(PILOT_STEP / 2.0, 0.0);
    let step_error = 4.0 / 3.0 * relative_rmse(&coarse, &fine);
    let step = if step_error > 0.0 {
        (PILOT_STEP * (budget / step_error).sqrt()).clamp(MIN_STEP, MAX_STEP)
    } else {
        MAX_STEP
    };
    let predicted_step = step_error * (step / PILOT_STEP).powi(2);
    // The termination: the largest whose error against none is within its share.
    let exact = render(step, 0.0);
    let (mut termination, mut termination_error) = (0.0, 0.0);
    for t in TERMINATIONS {
        let e = if t > 0.0 {
            relative_rmse(&render(step, t), &exact)
        } else {
            0.0
        };
        if e <= budget {
            (termination, termination_error) = (t, e);
            break;
        }
    }
    let tolerance_error = dsm_tolerance.unwrap_or(0.0);
    let report = ErrorBudgetReport {
        max_error,
        step_voxels: step,
        termination,
        dsm_tolerance,
        pilot_pixels: pixels.len(),
        pilot_step_error: step_error,
        pilot_termination_error: termination_error,
        predicted_error: (predicted_step.powi(2)
            + termination_error.powi(2)
            + tolerance_error.powi(2))
        .sqrt(),
        pilot_seconds: start.elapsed().as_secs_f64(),
    };
    (
        MarchSettings {
            step_voxels: step,
            termination,
        },
        report,
    )
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
