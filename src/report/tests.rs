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

/// Each sweep point renders what it says: the shadow-map sweep with the map at each
/// tolerance, the step and termination sweeps with exact marched shadows, `default`
/// with murk's defaults whatever flags were given.
#[test]
fn sweep_points_plan_what_they_sweep() {
    use super::converge::{DSM_SWEEP_STEP, TERMINATION_SWEEP_STEP, plan_of, sweep_points};
    use crate::integrate::MarchSettings;
    use crate::render::RenderOptions;
    use crate::scene::plan::ShadowMode;
    use crate::shadow::ShadowQuadrature;
    let user = RenderOptions {
        step: Some(3.0),
        termination: Some(0.2),
        shadows: Some("none".into()),
        ..Default::default()
    };
    let input = std::path::Path::new("cloud.vdb");
    let points = sweep_points();
    assert_eq!(points.len(), 7 + 5 + 6 + 4 + 1);
    for p in &points {
        let plan = plan_of(&user, input, p).unwrap();
        match p.sweep {
            "step" => {
                assert_eq!(
                    plan.march_settings(),
                    MarchSettings {
                        step_voxels: p.value,
                        termination: 0.0
                    }
                );
                assert_eq!(
                    (plan.shadows.mode, plan.shadow_quadrature()),
                    (ShadowMode::March, ShadowQuadrature::Exact)
                );
            }
            "dsm_tolerance" => {
                assert_eq!(plan.shadows.mode, ShadowMode::Dsm);
                assert_eq!(plan.shadows.dsm_tolerance, p.value);
                assert_eq!(
                    plan.march_settings(),
                    MarchSettings {
                        step_voxels: DSM_SWEEP_STEP,
                        termination: 0.0
                    }
                );
            }
            "termination" => {
                assert_eq!(
                    plan.march_settings(),
                    MarchSettings {
                        step_voxels: TERMINATION_SWEEP_STEP,
                        termination: p.value
                    }
                );
                assert_eq!(plan.shadow_quadrature(), ShadowQuadrature::Exact);
            }
            "max_error" => {
                // murk chooses: the map's tolerance now, the step and termination at
                // render time; the user's --step and --termination do not reach it.
                assert_eq!(plan.march.max_error, Some(p.value));
                assert_eq!(plan.shadows.mode, ShadowMode::Dsm);
                assert!((plan.shadows.dsm_tolerance - p.value / 3f64.sqrt()).abs() < 1e-15);
            }
            "default" => {
                assert_eq!(plan.march_settings(), MarchSettings::default());
                assert_eq!(
                    (plan.shadows.mode, plan.shadows.dsm_tolerance),
                    (ShadowMode::Dsm, 1e-3)
                );
            }
            other => panic!("unknown sweep {other}"),
        }
        assert!(plan.outputs.quiet);
    }
}

#[test]
fn swept_values_print_short_and_exact_ones_whole() {
    use super::converge::fmt_value;
    assert_eq!(fmt_value(0.015625), "0.015625");
    assert_eq!(fmt_value(0.5), "0.5");
    assert_eq!(fmt_value(4.0), "4");
    assert_eq!(fmt_value(2.8934280302755813), "2.8934");
    assert_eq!(fmt_value(5.773502691896258e-3), "5.77e-3");
    assert_eq!(fmt_value(1e-3), "1e-3");
    assert_eq!(fmt_value(0.0), "0");
    assert_eq!(fmt_value(f64::NAN), "-");
}
