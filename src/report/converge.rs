//! `murk converge`: error against run time. Renders the input at a sweep of step
//! sizes, shadow-map tolerances and termination thresholds, times each (median of N
//! runs, shadow bake and render apart), and compares every image with the reference
//! render (`--reference`) on radiance and alpha.
//!
//! Each sweep varies one setting and keeps the others fine, so that its error is that
//! setting's own and its order of convergence can be fitted:
//! - `step`: the march step, with exact marched shadows and no termination (the
//!   reference's settings but the step);
//! - `dsm_tolerance`: the deep shadow map's tolerance, at step 1/16 voxel, no termination;
//! - `termination`: the termination threshold, with exact marched shadows at step 0.5;
//! - `max_error`: `--max-error E`, murk choosing all three (`render::error_budget`):
//!   the measured error should stay below E and fall with it (order ≈ 1).
//!
//! - `path_spp`: the path tracer's samples per pixel, against a path-traced reference
//!   ([`super::converge_path`]);
//! - `fast_bounces`: the fast approximation's `--bounces`, against the same reference
//!   ([`super::converge_fast`]).
//!
//! The row `default` is the render with murk's defaults (step 0.5, shadow map at 1e-3,
//! termination 1e-4).

use super::ReportError;
use super::check::plan_scatter_bound;
pub use super::measure::{Measured, bound_violations, count_nan_inf, max_alpha_error, rel_rmse};
use crate::render::stats::RenderStats;
use crate::render::{RenderOptions, RenderPlan, render_image};
use crate::scene::progress::Progress;
use std::path::Path;

type Result<T> = std::result::Result<T, ReportError>;

/// The swept values.
pub const STEPS: [f64; 7] = [4.0, 2.0, 1.0, 0.5, 0.25, 0.125, 0.0625];
pub const DSM_TOLERANCES: [f64; 5] = [1e-1, 1e-2, 1e-3, 1e-4, 1e-5];
pub const TERMINATIONS: [f64; 6] = [1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6];
/// `--max-error` values of its sweep: what it asks for against what it measures.
pub const MAX_ERRORS: [f64; 4] = [3e-2, 1e-2, 3e-3, 1e-3];

/// The step of the shadow-map sweep.
pub const DSM_SWEEP_STEP: f64 = 0.0625;
/// The step of the termination sweep.
pub const TERMINATION_SWEEP_STEP: f64 = 0.5;

/// One render configuration of a sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// `step`, `dsm_tolerance`, `termination`, `max_error`, `default` or `reference`.
    pub sweep: &'static str,
    /// The swept setting's value.
    pub value: f64,
    pub step: Option<f64>,
    pub dsm_tolerance: Option<f64>,
    pub termination: Option<f64>,
    /// Exact marched shadows (the reference's), else the deep shadow map.
    pub exact_shadows: bool,
    /// `--max-error`: murk chooses step, tolerance and termination itself.
    pub max_error: Option<f64>,
}

/// Every point of every sweep, then `default`.
pub fn sweep_points() -> Vec<Point> {
    let point = |sweep, value, step, dsm_tolerance, termination, exact_shadows| Point {
        sweep,
        value,
        step: Some(step),
        dsm_tolerance,
        termination: Some(termination),
        exact_shadows,
        max_error: None,
    };
    let mut v = Vec::new();
    for s in STEPS {
        v.push(point("step", s, s, None, 0.0, true));
    }
    for t in DSM_TOLERANCES {
        v.push(point(
            "dsm_tolerance",
            t,
            DSM_SWEEP_STEP,
            Some(t),
            0.0,
            false,
        ));
    }
    for t in TERMINATIONS {
        v.push(point(
            "termination",
            t,
            TERMINATION_SWEEP_STEP,
            None,
            t,
            true,
        ));
    }
    for e in MAX_ERRORS {
        v.push(Point {
            sweep: "max_error",
            value: e,
            step: None,
            dsm_tolerance: None,
            termination: None,
            exact_shadows: false,
            max_error: Some(e),
        });
    }
    v.push(Point {
        sweep: "default",
        value: f64::NAN,
        step: None,
        dsm_tolerance: None,
        termination: None,
        exact_shadows: false,
        max_error: None,
    });
    v
}

/// How converge runs.
#[derive(Clone, Debug)]
pub struct ConvergeSettings {
    pub runs: usize,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn stage(stats: &RenderStats, name: &str) -> f64 {
    stats.scene.stages.get(name).map_or(0.0, |s| s.seconds)
}

/// The plan of a point: the user's options with the point's settings, quiet.
pub(super) fn plan_of(options: &RenderOptions, input: &Path, p: &Point) -> Result<RenderPlan> {
    let mut o = options.clone();
    o.quiet = true;
    o.output = Some(input.with_extension("converge.exr"));
    o.preview = None;
    o.stats = None;
    o.step = p.step;
    o.dsm_tolerance = p.dsm_tolerance.or(o.dsm_tolerance);
    // --max-error chooses the step and the tolerance itself (and refuses them).
    o.max_error = p.max_error;
    if p.max_error.is_some() {
        o.dsm_tolerance = None;
    }
    o.reference = p.exact_shadows;
    // The reference refuses a termination; a sweep point sets it on the plan.
    o.termination = None;
    // The march's sweeps measure the march: single scattering unless asked otherwise
    // (its bound is single scattering's; fast and path have sweeps of their own).
    o.scattering = o
        .scattering
        .or(Some(crate::integrate::ScatteringMode::Single));
    // Exact shadows come with the reference's settings; every other point (`default`
    // included) uses the deep shadow map, murk's default.
    o.shadows = (!p.exact_shadows).then(|| "dsm".to_string());
    let mut plan = RenderPlan::new(&o, input.to_path_buf())?;
    if let Some(t) = p.termination {
        plan.march.termination = t;
    }
    Ok(plan)
}

/// Renders the reference once and every point `runs` times; `progress` counts renders.
pub fn run(
    options: &RenderOptions,
    input: &Path,
    settings: &ConvergeSettings,
    progress: &dyn Progress,
) -> Result<(Measured, Vec<Measured>)> {
    let runs = settings.runs.max(1);
    let points = sweep_points();
    progress.start(
        "converge",
        1 + (points.len() * runs) as u64 + super::converge_path::renders(runs),
        "renders",
    );
    progress.note("reference");
    let reference_point = Point {
        sweep: "reference",
        value: f64::NAN,
        step: None,
        dsm_tolerance: None,
        termination: None,
        exact_shadows: true,
        max_error: None,
    };
    let ref_plan = plan_of(options, input, &reference_point)?;
    let reference = render_image(&ref_plan)?;
    progress.advance(1);
    let ref_frame = reference.frame;
    let ref_row = Measured {
        sweep: "reference".into(),
        value: f64::NAN,
        step: ref_plan.march.step,
        dsm_tolerance: f64::NAN,
        termination: ref_plan.march.termination,
        shadows: "march (exact)".into(),
        bake_seconds: stage(&reference.stats, "shadows"),
        render_seconds: stage(&reference.stats, "render"),
        total_seconds: stage(&reference.stats, "shadows") + stage(&reference.stats, "render"),
        runs: 1,
        rel_rmse: 0.0,
        max_alpha_error: 0.0,
        nan_inf: count_nan_inf(&ref_frame),
        bound_violations: 0,
    };
    let mut rows = Vec::new();
    for p in &points {
        progress.note(&format!("{} {}", p.sweep, fmt_value(p.value)));
        let plan = plan_of(options, input, p)?;
        let (mut bakes, mut renders) = (Vec::new(), Vec::new());
        let mut frame = None;
        // What --max-error chose (else the plan's step and termination).
        let mut chosen = (plan.march.step, plan.march.termination);
        for _ in 0..runs {
            let image = render_image(&plan)?;
            if let Some(b) = &image.stats.error_budget {
                // In voxels of the grid as read (a density level's are 2^level of them).
                chosen = (
                    b.step_voxels * f64::from(1u32 << b.density_level),
                    b.termination,
                );
            }
            bakes.push(stage(&image.stats, "shadows"));
            renders.push(stage(&image.stats, "render"));
            let emits = image
                .stats
                .scene
                .stages
                .get("emission")
                .is_some_and(|s| s.status == "ran");
            frame = Some((image.frame, emits));
            progress.advance(1);
        }
        let (frame, emits) = frame.expect("at least one run");
        let bound = if emits {
            f64::INFINITY
        } else {
            plan_scatter_bound(&plan)
        };
        let (bake, render) = (median(bakes), median(renders));
        rows.push(Measured {
            sweep: p.sweep.into(),
            value: p.value,
            step: chosen.0,
            dsm_tolerance: plan.shadows.dsm_tolerance,
            termination: chosen.1,
            shadows: if p.exact_shadows {
                "march (exact)".into()
            } else if plan.shadows.mode == crate::scene::plan::ShadowMode::Dsm {
                "dsm".into()
            } else {
                format!("{:?}", plan.shadows.mode).to_lowercase()
            },
            bake_seconds: bake,
            render_seconds: render,
            total_seconds: bake + render,
            runs,
            rel_rmse: rel_rmse(&frame, &ref_frame),
            max_alpha_error: max_alpha_error(&frame, &ref_frame),
            nan_inf: count_nan_inf(&frame),
            bound_violations: bound_violations(&frame, bound),
        });
    }
    rows.extend(super::converge_path::run(options, input, runs, progress)?);
    Ok((ref_row, rows))
}

/// A swept value as the tables print it.
pub fn fmt_value(v: f64) -> String {
    if v.is_nan() {
        "-".into()
    } else if v == 0.0 {
        "0".into()
    } else if (1e-2..1e3).contains(&v) {
        // Five significant digits at most (a chosen step such as 2.8934…), exact
        // values (0.5, 0.015625) as they are.
        let digits = (4 - v.log10().floor() as i32).max(0) as usize;
        let s = format!("{v:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        // Three significant digits: 5.77e-3, 1e-3.
        let s = format!("{v:.2e}");
        let (mantissa, exp) = s.split_once('e').unwrap_or((&s, "0"));
        let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
        format!("{mantissa}e{exp}")
    }
}
