//! What `murk converge` concludes from its measurements: the fitted order of each
//! sweep, the error each reaches at a common time, the time each needs to reach 1e-3;
//! and the CSV and Markdown it writes.

use super::converge::{DSM_SWEEP_STEP, Measured, TERMINATION_SWEEP_STEP, fmt_value};
use super::fit_slope;

/// The sweeps, in table order.
pub const SWEEPS: [&str; 6] = [
    "step",
    "dsm_tolerance",
    "termination",
    "max_error",
    "path_spp",
    "fast_bounces",
];

/// The error the tables call "reached".
pub const TARGET_ERROR: f64 = 1e-3;

/// A sweep's summary.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepSummary {
    pub sweep: String,
    /// Fitted order and the number of points it was fitted on.
    pub order: Option<(f64, usize)>,
    /// The error at the sweep's finest setting.
    pub finest_error: f64,
    /// Error at [`Summary::equal_time`], if the sweep spans that time.
    pub error_at_equal_time: Option<f64>,
    /// Time to reach [`TARGET_ERROR`], if it does.
    pub time_to_target: Option<f64>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// The common time the sweeps' errors are compared at: the latest of their
    /// shortest times, so that every sweep has a point at or before it.
    pub equal_time: f64,
    pub sweeps: Vec<SweepSummary>,
}

fn rows_of<'a>(rows: &'a [Measured], sweep: &str) -> Vec<&'a Measured> {
    rows.iter().filter(|r| r.sweep == sweep).collect()
}

/// The fitted order of a sweep: the least-squares slope of log error against log value
/// over its asymptotic points. A sweep that has levelled off (its two finest errors
/// within 1.5× of each other) has reached a floor set by the settings it keeps fixed;
/// only points at least 3× above that floor count. Steps above one voxel are not
/// asymptotic and never count.
pub fn fitted_order(rows: &[Measured], sweep: &str) -> Option<(f64, usize)> {
    let mut pts: Vec<&Measured> = rows_of(rows, sweep)
        .into_iter()
        .filter(|r| r.value > 0.0 && r.rel_rmse > 0.0)
        .collect();
    pts.sort_by(|a, b| b.value.total_cmp(&a.value));
    let n = pts.len();
    let floor = match (n >= 2).then(|| (pts[n - 2].rel_rmse, pts[n - 1].rel_rmse)) {
        Some((coarser, finest)) if coarser < 1.5 * finest => finest,
        _ => 0.0,
    };
    let points: Vec<(f64, f64)> = pts
        .into_iter()
        .filter(|r| r.rel_rmse >= 3.0 * floor)
        .filter(|r| sweep != "step" || r.value <= 1.0)
        .map(|r| (r.value.ln(), r.rel_rmse.ln()))
        .collect();
    let slope = fit_slope(&points);
    slope.is_finite().then_some((slope, points.len()))
}

/// `(time, error)` of a sweep sorted by time.
fn curve(rows: &[Measured], sweep: &str) -> Vec<(f64, f64)> {
    let mut c: Vec<(f64, f64)> = rows_of(rows, sweep)
        .into_iter()
        .map(|r| (r.total_seconds, r.rel_rmse))
        .filter(|(t, e)| *t > 0.0 && *e > 0.0)
        .collect();
    c.sort_by(|a, b| a.0.total_cmp(&b.0));
    c
}

/// Linear interpolation in log–log between `(x0, y0)` and `(x1, y1)` at `x`.
fn log_interp(x0: f64, y0: f64, x1: f64, y1: f64, x: f64) -> f64 {
    if x1 == x0 {
        return y0.min(y1);
    }
    let s = (x.ln() - x0.ln()) / (x1.ln() - x0.ln());
    (y0.ln() + s * (y1.ln() - y0.ln())).exp()
}

/// The error of a time-sorted curve at `t`, if `t` lies within it (the best error
/// reached by then).
pub fn error_at_time(c: &[(f64, f64)], t: f64) -> Option<f64> {
    let (first, last) = (c.first()?, c.last()?);
    if t < first.0 || t > last.0 {
        return None;
    }
    let mut best = f64::INFINITY;
    for w in c.windows(2) {
        best = best.min(w[0].1);
        if t >= w[0].0 && t <= w[1].0 {
            return Some(best.min(log_interp(w[0].0, w[0].1, w[1].0, w[1].1, t)));
        }
    }
    Some(best.min(last.1))
}

/// When a time-sorted curve first reaches `target`, interpolated in log–log.
pub fn time_to_reach(c: &[(f64, f64)], target: f64) -> Option<f64> {
    let first = c.first()?;
    if first.1 <= target {
        return Some(first.0);
    }
    for w in c.windows(2) {
        let ((t0, e0), (t1, e1)) = (w[0], w[1]);
        if e1 <= target {
            // Solve the log–log line for the target (e0 > target ≥ e1).
            let s = (target.ln() - e0.ln()) / (e1.ln() - e0.ln());
            return Some((t0.ln() + s * (t1.ln() - t0.ln())).exp());
        }
    }
    None
}

pub fn summarise(rows: &[Measured]) -> Summary {
    let equal_time = SWEEPS
        .iter()
        .filter_map(|s| curve(rows, s).first().map(|p| p.0))
        .fold(0.0, f64::max);
    let sweeps = SWEEPS
        .iter()
        .map(|s| {
            let c = curve(rows, s);
            SweepSummary {
                sweep: s.to_string(),
                order: fitted_order(rows, s),
                finest_error: rows_of(rows, s)
                    .into_iter()
                    .min_by(|a, b| a.value.total_cmp(&b.value))
                    .map_or(f64::NAN, |r| r.rel_rmse),
                error_at_equal_time: error_at_time(&c, equal_time),
                time_to_target: time_to_reach(&c, TARGET_ERROR),
            }
        })
        .collect();
    Summary { equal_time, sweeps }
}

const CSV_HEADER: &str = "sweep,value,step,dsm_tolerance,termination,shadows,bake_seconds,render_seconds,total_seconds,runs,rel_rmse,max_alpha_error,nan_inf,bound_violations";

pub fn csv(reference: &Measured, rows: &[Measured]) -> String {
    let mut s = format!("{CSV_HEADER}\n");
    for r in std::iter::once(reference).chain(rows) {
        let num = |v: f64| {
            if v.is_nan() {
                String::new()
            } else {
                format!("{v:e}")
            }
        };
        s += &format!(
            "{},{},{},{},{},{},{:.6},{:.6},{:.6},{},{},{},{},{}\n",
            r.sweep,
            num(r.value),
            num(r.step),
            num(r.dsm_tolerance),
            num(r.termination),
            r.shadows,
            r.bake_seconds,
            r.render_seconds,
            r.total_seconds,
            r.runs,
            num(r.rel_rmse),
            num(r.max_alpha_error),
            r.nan_inf,
            r.bound_violations
        );
    }
    s
}

fn opt(v: Option<f64>, f: impl Fn(f64) -> String, none: &str) -> String {
    v.map_or(none.to_string(), f)
}

/// The summary table (fitted order, error at equal time, time to 1e-3).
pub fn summary_table(s: &Summary) -> String {
    let mut t = format!(
        "| sweep | fitted order | error at the finest setting | error at {:.2} s | time to reach {TARGET_ERROR:.0e} |\n|---|---|---|---|---|\n",
        s.equal_time
    );
    for w in &s.sweeps {
        t += &format!(
            "| {} | {} | {:.2e} | {} | {} |\n",
            w.sweep,
            opt(
                w.order.map(|o| o.0),
                |o| format!("{o:.2} ({} points)", w.order.map_or(0, |o| o.1)),
                "n/a (flat)"
            ),
            w.finest_error,
            opt(
                w.error_at_equal_time,
                |e| format!("{e:.2e}"),
                "outside its times"
            ),
            opt(w.time_to_target, |t| format!("{t:.3} s"), "not reached"),
        );
    }
    t
}

/// Every measured row.
pub fn rows_table(reference: &Measured, rows: &[Measured]) -> String {
    let mut t = String::from(
        "| sweep | value | step | dsm tol | termination | bake s | render s | rel. RMSE | max α err | NaN/Inf | bound viol. |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in std::iter::once(reference).chain(rows) {
        t += &format!(
            "| {} | {} | {} | {} | {} | {:.3} | {:.3} | {:.2e} | {:.2e} | {} | {} |\n",
            r.sweep,
            fmt_value(r.value),
            fmt_value(r.step),
            if r.shadows == "dsm" {
                fmt_value(r.dsm_tolerance)
            } else {
                r.shadows.clone()
            },
            fmt_value(r.termination),
            r.bake_seconds,
            r.render_seconds,
            r.rel_rmse,
            r.max_alpha_error,
            r.nan_inf,
            r.bound_violations
        );
    }
    t
}

/// `converge.md`: what was run, the summary, every row.
pub fn markdown(
    input: &str,
    resolution: (usize, usize),
    reference: &Measured,
    rows: &[Measured],
    summary: &Summary,
) -> String {
    format!(
        "# murk converge: {input}\n\n\
         {w}×{h} pixels; times are the median of {runs} runs (shadow-map bake and render timed apart; \
         loading excluded). Errors are against the reference render (`--reference`: step {rs} voxel, \
         exact marched shadows, no termination), which took {rt:.1} s. Each sweep varies one setting \
         and keeps the others fine: `step` with exact marched shadows and no termination; \
         `dsm_tolerance` at step {ds} voxel, no termination; `termination` with exact marched shadows \
         at step {ts} voxel; `max_error` asks `--max-error` for the value and lets murk choose step, \
         tolerance and termination (the step and termination columns show its choice: an order near 1 \
         and errors below the values say its model holds). `default` is murk's defaults (step 0.5, `--shadows dsm`, \
         `--dsm-tolerance 1e-3`, `--termination 1e-4`). Relative RMSE is over R, G, B of every pixel; \
         the fitted order is the slope of log error against log setting above the sweep's floor.\n\n\
         ## Summary\n\n{}\n## Every render\n\n{}\n![error against time](converge.png)\n",
        summary_table(summary),
        rows_table(reference, rows),
        w = resolution.0,
        h = resolution.1,
        runs = rows.first().map_or(0, |r| r.runs),
        rs = fmt_value(reference.step),
        rt = reference.total_seconds,
        ds = DSM_SWEEP_STEP,
        ts = TERMINATION_SWEEP_STEP,
    )
}
