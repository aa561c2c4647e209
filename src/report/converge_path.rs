//! `murk converge`'s sweep of the path tracer (`--scattering path`): samples per pixel
//! against a path-traced reference of [`PATH_REFERENCE_SPP`] samples, so the table and
//! the plot show what each second of path tracing buys, and the fitted order shows its
//! error falling as spp^−½.
//!
//! The reference has noise of its own, `1/√(PATH_REFERENCE_SPP/spp)` of a sweep point's:
//! at the sweep's largest spp (32) that adds 6 % to the error measured.

use super::ReportError;
use super::measure::{Measured, bound_violations, count_nan_inf, max_alpha_error, rel_rmse};
use crate::integrate::ScatteringMode;
use crate::render::{RenderOptions, RenderPlan, render_image};
use crate::scene::progress::Progress;
use std::path::Path;

type Result<T> = std::result::Result<T, ReportError>;

/// The swept samples per pixel.
pub const PATH_SPPS: [u32; 6] = [1, 2, 4, 8, 16, 32];
/// The path-traced reference's samples per pixel.
pub const PATH_REFERENCE_SPP: u32 = 256;
/// The sweep's name in the tables and the plot.
pub const SWEEP: &str = "path_spp";

/// Renders the sweep takes with `runs` runs per point.
pub fn renders(runs: usize) -> u64 {
    1 + (PATH_SPPS.len() * runs) as u64 + super::converge_fast::renders(runs)
}

fn plan(options: &RenderOptions, input: &Path, spp: u32, seed: u64) -> Result<RenderPlan> {
    let mut o = options.clone();
    o.quiet = true;
    o.output = Some(input.with_extension("converge.exr"));
    o.preview = None;
    o.stats = None;
    o.reference = false;
    o.termination = None;
    o.shadows = Some("dsm".into());
    o.scattering = Some(ScatteringMode::Path);
    o.spp = Some(spp);
    o.seed = Some(seed);
    Ok(RenderPlan::new(&o, input.to_path_buf())?)
}

fn seconds(stats: &crate::render::stats::RenderStats, name: &str) -> f64 {
    stats.scene.stages.get(name).map_or(0.0, |s| s.seconds)
}

/// The reference's row, then one row per swept spp (median time of `runs`; the sweep's
/// seed differs from the reference's so their noise is independent).
pub fn run(
    options: &RenderOptions,
    input: &Path,
    runs: usize,
    progress: &dyn Progress,
) -> Result<Vec<Measured>> {
    let row = |sweep: &str, value: f64, plan: &RenderPlan, bake: f64, render: f64| Measured {
        sweep: sweep.into(),
        value,
        step: f64::NAN,
        dsm_tolerance: plan.shadows.dsm_tolerance,
        termination: f64::NAN,
        shadows: "dsm".into(),
        bake_seconds: bake,
        render_seconds: render,
        total_seconds: bake + render,
        runs,
        rel_rmse: 0.0,
        max_alpha_error: 0.0,
        nan_inf: 0,
        bound_violations: 0,
    };
    progress.note("path reference");
    let ref_plan = plan(options, input, PATH_REFERENCE_SPP, 1)?;
    let reference = render_image(&ref_plan)?;
    progress.advance(1);
    let mut rows = vec![Measured {
        runs: 1,
        nan_inf: count_nan_inf(&reference.frame),
        ..row(
            "path_reference",
            PATH_REFERENCE_SPP as f64,
            &ref_plan,
            seconds(&reference.stats, "shadows"),
            seconds(&reference.stats, "render"),
        )
    }];
    for spp in PATH_SPPS {
        progress.note(&format!("{SWEEP} {spp}"));
        let p = plan(options, input, spp, 2)?;
        let (mut bakes, mut renders, mut frame) = (Vec::new(), Vec::new(), None);
        for _ in 0..runs.max(1) {
            let image = render_image(&p)?;
            bakes.push(seconds(&image.stats, "shadows"));
            renders.push(seconds(&image.stats, "render"));
            frame = Some(image.frame);
            progress.advance(1);
        }
        let frame = frame.expect("at least one run");
        let median = |mut v: Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        rows.push(Measured {
            rel_rmse: rel_rmse(&frame, &reference.frame),
            max_alpha_error: max_alpha_error(&frame, &reference.frame),
            nan_inf: count_nan_inf(&frame),
            // Multiple scattering has no single-scattering bound: α and sign only.
            bound_violations: bound_violations(&frame, f64::INFINITY),
            ..row(SWEEP, spp as f64, &p, median(bakes), median(renders))
        });
    }
    // The fast approximation against the same path-traced reference.
    rows.extend(super::converge_fast::run(
        options,
        input,
        runs,
        &reference.frame,
        progress,
    )?);
    Ok(rows)
}
