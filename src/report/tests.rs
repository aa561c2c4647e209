//! Unit tests of the converge summary: slope fit, log–log interpolation, floors.

use super::converge::Measured;
use super::converge_table::{error_at_time, fitted_order, time_to_reach};
use super::fit_slope;

fn row(sweep: &str, value: f64, seconds: f64, err: f64) -> Measured {
    Measured {
        sweep: sweep.into(),
        value,
        step: value,
        dsm_tolerance: 1e-3,
        termination: 0.0,
        shadows: "dsm".into(),
        bake_seconds: 0.0,
        render_seconds: seconds,
        total_seconds: seconds,
        runs: 1,
        rel_rmse: err,
        max_alpha_error: 0.0,
        nan_inf: 0,
        bound_violations: 0,
    }
}

#[test]
fn slope_of_a_power_law_is_its_exponent() {
    let pts: Vec<(f64, f64)> = [0.5f64, 0.25, 0.125, 0.0625]
        .iter()
        .map(|h| (h.ln(), (3.0 * h * h).ln()))
        .collect();
    assert!((fit_slope(&pts) - 2.0).abs() < 1e-12);
    assert!(fit_slope(&pts[..1]).is_nan());
    assert!(fit_slope(&[(1.0, 2.0), (1.0, 3.0)]).is_nan());
}

#[test]
fn order_is_fitted_above_the_floor_and_below_one_voxel() {
    // err = h² down to a floor of 1e-3 (h ≤ 1/64 sits on it); h = 4 is off the line.
    let mut rows: Vec<Measured> = [1.0f64, 0.5, 0.25, 0.125, 0.015625, 0.0078125]
        .iter()
        .map(|&h| row("step", h, 1.0 / h, (h * h).max(1e-3)))
        .collect();
    rows.push(row("step", 4.0, 0.25, 0.9));
    let (order, n) = fitted_order(&rows, "step").unwrap();
    assert!((order - 2.0).abs() < 1e-9, "{order}");
    assert_eq!(n, 4);
    // A flat sweep has no order.
    let flat: Vec<Measured> = [0.1, 0.01, 1e-3]
        .iter()
        .map(|&t| row("dsm_tolerance", t, 1.0, 2e-3))
        .collect();
    assert_eq!(fitted_order(&flat, "dsm_tolerance"), None);
}

#[test]
fn time_to_reach_and_error_at_time_interpolate_in_log_log() {
    // err = 1e-2 · (t / 1 s)^-2 at t = 1, 10.
    let c = [(1.0, 1e-2), (10.0, 1e-4)];
    let t = time_to_reach(&c, 1e-3).unwrap();
    assert!((t - 10f64.sqrt()).abs() < 1e-12, "{t}");
    assert_eq!(time_to_reach(&c, 1e-5), None);
    assert_eq!(time_to_reach(&c, 0.1), Some(1.0));
    let e = error_at_time(&c, 10f64.sqrt()).unwrap();
    assert!((e - 1e-3).abs() < 1e-15, "{e}");
    assert_eq!(error_at_time(&c, 0.5), None);
    assert_eq!(error_at_time(&c, 20.0), None);
}
