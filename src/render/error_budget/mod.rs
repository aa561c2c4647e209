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
//! - When something moves while the shutter is open (a velocity, a keyed or advected
//!   `[[volume]]`, a moving camera), the shutter's sampling noise is a fourth source:
//!   each of the four gets `E/2`, and the samples a pixel are chosen for the noise's
//!   share by measuring it on a pilot ([`noise`]). An explicit `--spp` wins: its noise
//!   is measured and counted in the prediction, which may then exceed `E`. Without
//!   motion nothing changes.
//!
//! What was chosen, what the pilot measured and the predicted error go into the stats
//! (`error_budget`) and a note.

pub mod noise;

use super::RenderStats;
use crate::integrate::MarchSettings;
use crate::integrate::integrator::Integrator;
use crate::scene::camera::Camera;
use crate::scene::pilot::{pilot_pixels, render_pilot};
use crate::scene::plan::{MarchPlan, ShadowMode};
use crate::scene::{RenderPlan, Scene};
pub use noise::NoiseReport;
use serde::Serialize;

pub use crate::scene::pilot::{PILOT_PIXELS, relative_rmse};
/// The pilot's first step, voxels: coarse, so that its error is well above the floor.
pub const PILOT_STEP: f64 = 2.0;
/// The finest and the coarsest step `--max-error` chooses, voxels.
pub const MIN_STEP: f64 = 1.0 / 16.0;
pub const MAX_STEP: f64 = 8.0;
/// Terminations tried, largest first (the first within budget is taken).
const TERMINATIONS: [f64; 10] = [0.2, 0.1, 0.05, 0.02, 0.01, 5e-3, 2e-3, 1e-3, 1e-4, 0.0];

/// What `--max-error` chose and why (the stats' `error_budget`).
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct ErrorBudgetReport {
    pub max_error: f64,
    /// The density's level (`scene::density_level`; 0: its own voxels) and the error its
    /// pilot measured: the step, the termination and the map share what it leaves.
    pub density_level: u8,
    pub density_level_error: f64,
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
    /// When something moves while the shutter is open: the samples a pixel and the
    /// shutter's noise measured at them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shutter_noise: Option<NoiseReport>,
    /// √(level² + step² + termination² + tolerance² + noise²), each source's predicted
    /// error.
    pub predicted_error: f64,
    pub pilot_seconds: f64,
}

impl ErrorBudgetReport {
    /// One line for the stats' notes.
    pub fn note(&self) -> String {
        let noise = self.shutter_noise.as_ref().map_or(String::new(), |n| {
            format!(
                ", {} samples a pixel {} (the shutter's noise {:.2e} against its share {:.2e}, measured on {} pixels)",
                n.spp,
                if n.spp_given { "as --spp gave" } else { "for the shutter's noise" },
                n.error,
                n.share,
                n.pilot_pixels
            )
        });
        format!(
            "--max-error {}: density level {}, step {:.3} of its voxels, termination {}, shadow map tolerance {}{noise} (a pilot of {} pixels in {:.2} s; predicted error {:.2e})",
            self.max_error,
            self.density_level,
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

/// The camera march's settings: the plan's, or with `--max-error` those a pilot render
/// through the integrators `make` builds chose, and where something moves while the
/// shutter is open the samples a pixel (`st.spp`; recorded in the stats).
pub(super) fn march_settings<I: Integrator>(
    plan: &RenderPlan,
    scene: &Scene,
    st: &mut RenderStats,
    make: impl Fn(MarchSettings) -> I,
) -> MarchSettings {
    let Some(max_error) = plan.march.max_error else {
        return plan.march_settings();
    };
    let level = scene
        .density_level
        .as_ref()
        .map_or((0, 0.0), |l| (l.level, l.error));
    let shutter = plan
        .motion
        .shutter
        .filter(|_| scene.moves())
        .map(|shutter| noise::Shutter {
            shutter,
            camera_motion: scene.camera_motion.as_ref(),
            overscan: plan.camera.overscan,
            given_spp: plan.sampling.spp_given.then_some(plan.sampling.spp),
        });
    // The map was baked to its share of what the level and the noise left (the plan's
    // own share without either).
    let tolerance = (plan.shadows.mode == ShadowMode::Dsm && !scene.lights.is_empty()).then(|| {
        if level.0 > 0 || shutter.is_some() {
            MarchPlan::tolerance_of(MarchPlan::march_error(
                max_error,
                level.1,
                shutter.is_some(),
            ))
        } else {
            plan.shadows.dsm_tolerance
        }
    });
    let (march, report) = choose(
        max_error,
        level,
        tolerance,
        &scene.camera,
        plan.sampling.seed,
        shutter,
        make,
    );
    if let Some(n) = &report.shutter_noise {
        st.spp = n.spp;
    }
    st.error_budget = Some(report);
    march
}

/// Chooses the step and termination for `max_error` by rendering the pilot through the
/// integrators `make` builds from march settings. `level` is the density's level and its
/// measured error; `dsm_tolerance` is what the map was baked to (its share of the error
/// is counted in the prediction). With `shutter` (something moves while it is open) the
/// samples a pixel too, for the shutter's noise.
pub fn choose<I: Integrator>(
    max_error: f64,
    level: (u8, f64),
    dsm_tolerance: Option<f64>,
    camera: &Camera,
    seed: u64,
    shutter: Option<noise::Shutter>,
    make: impl Fn(MarchSettings) -> I,
) -> (MarchSettings, ErrorBudgetReport) {
    let start = std::time::Instant::now();
    let remaining = MarchPlan::remaining_error(max_error, level.1);
    let budget = MarchPlan::error_share(MarchPlan::march_error(
        max_error,
        level.1,
        shutter.is_some(),
    ));
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
    let shutter_noise = shutter.map(|shutter| {
        let settings = MarchSettings {
            step_voxels: step,
            termination,
        };
        noise::choose_spp(
            &make(settings),
            camera,
            seed,
            shutter,
            MarchPlan::noise_share(remaining),
        )
    });
    let noise_error = shutter_noise.as_ref().map_or(0.0, |n| n.error);
    let report = ErrorBudgetReport {
        max_error,
        density_level: level.0,
        density_level_error: level.1,
        step_voxels: step,
        termination,
        dsm_tolerance,
        pilot_pixels: pixels.len(),
        pilot_step_error: step_error,
        pilot_termination_error: termination_error,
        shutter_noise,
        predicted_error: (level.1.powi(2)
            + predicted_step.powi(2)
            + termination_error.powi(2)
            + tolerance_error.powi(2)
            + noise_error.powi(2))
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
