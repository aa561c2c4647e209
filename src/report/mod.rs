//! Reports on the renderer itself: error against run time (`murk converge`) and
//! numerical stability on stiff and extreme inputs (`murk check-stability`).

pub mod check;
pub mod converge;
pub mod converge_fast;
pub mod converge_path;
pub mod converge_table;
mod error;
pub mod growth;
pub mod measure;
pub mod phase_plot;
pub mod plot;
pub mod stability;
pub mod stability_rendered;

pub use error::ReportError;

/// Least-squares slope of `y` against `x` (e.g. log error against log step: the order
/// of convergence). NaN with fewer than two distinct `x`.
pub fn fit_slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    if points.len() < 2 {
        return f64::NAN;
    }
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = points.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    if sxx > 0.0 { sxy / sxx } else { f64::NAN }
}

#[cfg(test)]
mod tests;
