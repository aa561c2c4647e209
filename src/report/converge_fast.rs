//! `murk converge`'s sweep of the fast approximation (`--scattering fast`): the orders it
//! models (`--bounces`), against the path tracer's reference of
//! [`super::converge_path::PATH_REFERENCE_SPP`] samples, so the table and the plot show
//! what each second of the lattice buys beside path tracing. Bounces 1 is single
//! scattering (no lattice); the error stops falling at the approximation's own bias.

use super::ReportError;
use super::measure::{Measured, bound_violations, count_nan_inf, max_alpha_error, rel_rmse};
use crate::integrate::ScatteringMode;
use crate::output::Frame;
use crate::render::{RenderOptions, RenderPlan, render_image};
use crate::scene::progress::Progress;
use std::path::Path;

type Result<T> = std::result::Result<T, ReportError>;

/// The swept `--bounces`.
pub const FAST_BOUNCES: [u32; 6] = [1, 2, 4, 8, 16, 24];
/// The sweep's name in the tables and the plot.
pub const SWEEP: &str = "fast_bounces";

/// Renders the sweep takes with `runs` runs per point.
pub fn renders(runs: usize) -> u64 {
    (FAST_BOUNCES.len() * runs) as u64
}

fn plan(options: &RenderOptions, input: &Path, bounces: u32) -> Result<RenderPlan> {
    let mut o = options.clone();
    o.quiet = true;
    o.output = Some(input.with_extension("converge.exr"));
    o.preview = None;
    o.stats = None;
    o.reference = false;
    o.termination = None;
    o.shadows = Some("dsm".into());
    o.scattering = Some(ScatteringMode::Fast);
    o.bounces = Some(bounces);
    o.spp = Some(1);
    Ok(RenderPlan::new(&o, input.to_path_buf())?)
}

fn seconds(stats: &crate::render::stats::RenderStats, name: &str) -> f64 {
    stats.scene.stages.get(name).map_or(0.0, |s| s.seconds)
}

/// One row per swept `--bounces` (median time of `runs`; the shadow map and the lattice
/// count as the bake), measured against `reference` (the path-traced one).
pub fn run(
    options: &RenderOptions,
    input: &Path,
    runs: usize,
    reference: &Frame,
    progress: &dyn Progress,
) -> Result<Vec<Measured>> {
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let mut rows = Vec::new();
    for bounces in FAST_BOUNCES {
        progress.note(&format!("{SWEEP} {bounces}"));
        let p = plan(options, input, bounces)?;
        let (mut bakes, mut renders, mut frame) = (Vec::new(), Vec::new(), None);
        for _ in 0..runs.max(1) {
            let image = render_image(&p)?;
            bakes.push(
                seconds(&image.stats, "shadows") + seconds(&image.stats, "multiple_scattering"),
            );
            renders.push(seconds(&image.stats, "render"));
            frame = Some(image.frame);
            progress.advance(1);
        }
        let frame = frame.expect("at least one run");
        let (bake, render) = (median(bakes), median(renders));
        rows.push(Measured {
            sweep: SWEEP.into(),
            value: bounces as f64,
            step: p.march_settings().step_voxels,
            dsm_tolerance: p.shadows.dsm_tolerance,
            termination: p.march_settings().termination,
            shadows: "dsm".into(),
            bake_seconds: bake,
            render_seconds: render,
            total_seconds: bake + render,
            runs,
            rel_rmse: rel_rmse(&frame, reference),
            max_alpha_error: max_alpha_error(&frame, reference),
            nan_inf: count_nan_inf(&frame),
            // Multiple scattering has no single-scattering bound: α and sign only.
            bound_violations: bound_violations(&frame, f64::INFINITY),
        });
    }
    Ok(rows)
}
