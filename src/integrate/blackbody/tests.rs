//! Unit tests of `blackbody.rs`, compiled only under #[cfg(test)].

use super::*;

fn chromaticity(xyz: [f64; 3]) -> (f64, f64) {
    let s = xyz[0] + xyz[1] + xyz[2];
    (xyz[0] / s, xyz[1] / s)
}

/// Kim et al. (2002) cubic-spline approximation of the CIE 1931 Planckian locus,
/// valid 1667–25000 K, an independent reference for the chromaticities.
fn planckian_locus_kim(t: f64) -> (f64, f64) {
    let (t1, t2, t3) = (1e3 / t, 1e6 / (t * t), 1e9 / (t * t * t));
    let x = if t <= 4000.0 {
        -0.266_123_9 * t3 - 0.234_358_9 * t2 + 0.877_695_6 * t1 + 0.179_910
    } else {
        -3.025_846_9 * t3 + 2.107_037_9 * t2 + 0.222_634_7 * t1 + 0.240_390
    };
    let y = if t <= 2222.0 {
        -1.106_381_4 * x.powi(3) - 1.348_110_20 * x * x + 2.185_558_32 * x - 0.202_196_83
    } else if t <= 4000.0 {
        -0.954_947_6 * x.powi(3) - 1.374_185_93 * x * x + 2.091_370_15 * x - 0.167_488_67
    } else {
        3.081_758_0 * x.powi(3) - 5.873_386_70 * x * x + 3.751_129_97 * x - 0.370_014_83
    };
    (x, y)
}

#[test]
fn cmf_fit_shape() {
    // ȳ peaks near 555 nm at ≈ 1; the fit's known values there.
    let y555 = cie_xyz_cmf(555.0)[1];
    assert!((y555 - 1.0).abs() < 0.01, "{y555}");
    // Equal-energy white has x ≈ y ≈ 1/3 (each CMF integrates to ~106.9 nm).
    let mut s = [0.0; 3];
    for (_, c) in cmf_table() {
        for k in 0..3 {
            s[k] += c[k];
        }
    }
    for k in 0..3 {
        assert!((s[k] - 106.86).abs() < 1.0, "{s:?}");
    }
    let (x, y) = chromaticity(s);
    assert!(
        (x - 1.0 / 3.0).abs() < 0.003 && (y - 1.0 / 3.0).abs() < 0.003,
        "{x} {y}"
    );
}

#[test]
fn planck_matches_closed_form_and_wien() {
    // Direct evaluation at a moderate point.
    let (l, t): (f64, f64) = (500.0, 5000.0);
    let lm = l * 1e-9;
    let direct = C1L / lm.powi(5) / ((C2 / (lm * t)).exp() - 1.0) * 1e-9;
    assert!((planck_spectral_radiance(l, t) / direct - 1.0).abs() < 1e-13);
    // Sun-like 5778 K peaks near Wien's λ = 2.8978e-3/T ≈ 501.5 nm.
    let t = 5778.0;
    let peak = (400..700)
        .map(|l| l as f64)
        .max_by(|a, b| planck_spectral_radiance(*a, t).total_cmp(&planck_spectral_radiance(*b, t)));
    assert_eq!(peak, Some(502.0));
    assert_eq!(planck_spectral_radiance(500.0, 0.0), 0.0);
    assert_eq!(planck_spectral_radiance(500.0, f64::NAN), 0.0);
    assert!(planck_spectral_radiance(500.0, 1e9).is_finite());
}

#[test]
fn planck_integrates_to_stefan_boltzmann() {
    // σ from the exact constants.
    let pi = std::f64::consts::PI;
    let sigma =
        2.0 * pi.powi(5) * BOLTZMANN_K.powi(4) / (15.0 * PLANCK_H.powi(3) * SPEED_OF_LIGHT.powi(2));
    assert!((sigma / STEFAN_BOLTZMANN - 1.0).abs() < 1e-9, "{sigma}");
    // ∫ B_λ dλ over all wavelengths, in x = ln λ (trapezoid on a wide log grid).
    for t in [300.0, 1500.0, 6000.0] {
        let (lo, hi, n) = ((1.0f64).ln(), (1e7f64).ln(), 20_000);
        let h = (hi - lo) / n as f64;
        let total: f64 = (0..=n)
            .map(|i| {
                let l = (lo + h * i as f64).exp();
                let w = if i == 0 || i == n { 0.5 } else { 1.0 };
                w * planck_spectral_radiance(l, t) * l * h
            })
            .sum();
        assert!(
            (total / total_radiance(t) - 1.0).abs() < 1e-6,
            "T={t}: {total} vs {}",
            total_radiance(t)
        );
    }
    assert_eq!(total_radiance(-5.0), 0.0);
    assert_eq!(total_radiance(f64::NAN), 0.0);
    assert!(total_radiance(f64::MAX).is_finite());
}

#[test]
fn chromaticity_follows_the_planckian_locus() {
    for t in [
        1700.0, 2000.0, 2856.0, 4000.0, 5000.0, 6504.0, 10000.0, 20000.0,
    ] {
        let (x, y) = chromaticity(blackbody_xyz(t));
        let (kx, ky) = planckian_locus_kim(t);
        // The WSS fit drifts by ~0.003 at the red end, ≤ 0.0015 above 2500 K.
        let tol = if t < 2500.0 { 0.004 } else { 0.0015 };
        assert!(
            (x - kx).abs() < tol && (y - ky).abs() < tol,
            "T={t}: ({x}, {y}) vs ({kx}, {ky})"
        );
    }
    // CIE illuminant A (2856 K Planckian): (0.44757, 0.40745).
    let (x, y) = chromaticity(blackbody_xyz(2856.0));
    assert!(
        (x - 0.44757).abs() < 0.002 && (y - 0.40745).abs() < 0.002,
        "A: {x} {y}"
    );
}

#[test]
fn integration_step_is_converged() {
    // 5 nm trapezoid vs 0.5 nm on the same fit.
    for t in [800.0, 1500.0, 6504.0, 30000.0] {
        let mut fine = [0.0; 3];
        let n = 941;
        for i in 0..n {
            let l = 360.0 + 0.5 * i as f64;
            let w = if i == 0 || i == n - 1 { 0.25 } else { 0.5 };
            let b = planck_spectral_radiance(l, t);
            let c = cie_xyz_cmf(l);
            for k in 0..3 {
                fine[k] += w * b * c[k];
            }
        }
        let coarse = blackbody_xyz(t);
        for k in 0..3 {
            assert!(
                (coarse[k] / fine[k] - 1.0).abs() < 2e-3,
                "T={t} k={k}: {coarse:?} {fine:?}"
            );
        }
    }
}

#[test]
fn d65_temperature_is_near_white() {
    // A 6504 K blackbody is not D65 (D65 lies ~0.003 Δuv above the Planckian locus,
    // towards green), so in Rec.709 it comes out slightly magenta: G is the
    // smallest channel, and all three lie within ~5% of 1 after Y-normalisation.
    let c = blackbody_rgb_normalized(6504.0);
    let y = rec709_luminance(c);
    assert!((y - 1.0).abs() < 1e-12, "{y}");
    for ch in c {
        assert!((ch - 1.0).abs() < 0.06, "{c:?}");
    }
    assert!(c[1] < c[0] && c[1] < c[2], "{c:?}");
    let spread =
        c.iter().cloned().fold(f64::MIN, f64::max) / c.iter().cloned().fold(f64::MAX, f64::min);
    assert!(spread < 1.1, "{c:?}");
}

#[test]
fn low_temperatures_are_red_high_are_blue() {
    let c = blackbody_rgb_normalized(1500.0);
    assert!(c[0] > c[1] && c[1] > c[2], "{c:?}");
    assert!(c[0] > 2.0 * c[1], "{c:?}");
    let c = blackbody_rgb_normalized(15000.0);
    assert!(c[2] > c[0], "{c:?}");
    assert!(c[2] > c[1], "{c:?}");
    // Monotone hue: the blue/red ratio rises with temperature (where both > 0).
    let mut prev = 0.0;
    for i in 0..60 {
        let t = 2000.0 + 500.0 * i as f64;
        let c = blackbody_rgb_normalized(t);
        let r = c[2] / c[0];
        assert!(r > prev, "T={t}: {c:?}");
        prev = r;
    }
    // Below the gamut edge blue is clipped to zero, never negative.
    for t in [500.0, 900.0, 1200.0] {
        let c = blackbody_rgb_normalized(t);
        assert!(c.iter().all(|v| *v >= 0.0), "{c:?}");
        assert!((rec709_luminance(c) - 1.0).abs() < 1e-12);
    }
    let raw = xyz_to_linear_rec709(blackbody_xyz(1200.0));
    assert!(raw[2] < 0.0, "1200 K is outside Rec.709: {raw:?}");
}

#[test]
fn low_temperatures_plateau_at_pure_red() {
    // The computed colour is already pure red just above the imposed plateau...
    for t in [PURE_RED_BELOW, 750.0, 800.0, 850.0] {
        assert_eq!(blackbody_rgb_normalized(t)[1..], [0.0, 0.0], "{t}");
        assert!((blackbody_rgb_normalized(t)[0] - PURE_RED[0]).abs() < 1e-12);
    }
    // ...and stays so below it, where the CMF fit's tails would drift to green.
    for t in [1e-9, 1.0, 50.0, 200.0, 400.0, 699.0] {
        assert_eq!(blackbody_rgb_normalized(t), PURE_RED, "{t}");
        let a = blackbody_radiance_rgb(t);
        assert!(
            a[1] == 0.0 && a[2] == 0.0 && a[0] >= 0.0 && a[0].is_finite(),
            "{t}: {a:?}"
        );
    }
    assert!((rec709_luminance(PURE_RED) - 1.0).abs() < 1e-15);
    // Green appears continuously above ~855 K.
    let g = |t: f64| blackbody_rgb_normalized(t)[1];
    assert!(g(860.0) > 0.0 && g(860.0) < 0.01 && g(1000.0) > g(900.0));
}

#[test]
fn absolute_radiance_increases_with_temperature() {
    let mut prev = 0.0;
    let mut t = 300.0;
    while t < 1e8 {
        let y = rec709_luminance(blackbody_radiance_rgb(t));
        assert!(y > prev, "T={t}: {y} <= {prev}");
        // Luminance of the radiance is ∫ B ȳ dλ.
        let want = blackbody_xyz(t)[1];
        assert!((y / want - 1.0).abs() < 1e-12, "T={t}");
        prev = y;
        t *= 1.1;
    }
    // Orders of magnitude: ∫ B ȳ over the visible band.
    let y1500 = blackbody_xyz(1500.0)[1];
    let y6500 = blackbody_xyz(6500.0)[1];
    assert!(y1500 > 5.0 && y1500 < 30.0, "{y1500}");
    assert!(y6500 > 1e6 && y6500 < 1e7, "{y6500}");
    // Rayleigh–Jeans regime: doubling T doubles the visible radiance.
    let r = blackbody_xyz(2e9)[1] / blackbody_xyz(1e9)[1];
    assert!((r - 2.0).abs() < 1e-4, "{r}");
    // Wien regime (visible band far above the peak): Y(2T)/Y(T) is enormous.
    assert!(blackbody_xyz(1000.0)[1] / blackbody_xyz(500.0)[1] > 1e5);
}

#[test]
fn degenerate_temperatures() {
    for t in [0.0, -1.0, -1e9, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        assert_eq!(blackbody_rgb_normalized(t), [0.0; 3], "{t}");
        assert_eq!(blackbody_radiance_rgb(t), [0.0; 3], "{t}");
        assert_eq!(blackbody_xyz(t), [0.0; 3], "{t}");
    }
    for t in [1e-300, 1e-3, 0.5, 1.0, 10.0, 1e5, 1e9, 1e20, 1e40, f64::MAX] {
        let n = blackbody_rgb_normalized(t);
        let a = blackbody_radiance_rgb(t);
        assert!(
            n.iter().chain(a.iter()).all(|v| v.is_finite() && *v >= 0.0),
            "T={t}: {n:?} {a:?}"
        );
        assert!((rec709_luminance(n) - 1.0).abs() < 1e-12, "T={t}: {n:?}");
    }
    // Huge temperatures converge to the Rayleigh–Jeans colour (bluish).
    let a = blackbody_rgb_normalized(1e5);
    let b = blackbody_rgb_normalized(1e9);
    assert!(b[2] > b[0] && a[2] > a[0]);
    let c = blackbody_rgb_normalized(1e7);
    assert!((0..3).all(|k| (a[k] - b[k]).abs() < 0.1), "{a:?} {b:?}");
    assert!((0..3).all(|k| (c[k] - b[k]).abs() < 1e-3), "{c:?} {b:?}");
    assert_eq!(grid_value_to_kelvin(2.0, 1000.0, 300.0), 2300.0);
}

#[test]
fn table_matches_direct_evaluation() {
    // (range, samples, tolerance): the largest errors sit at the ~855 K kink where
    // green re-enters the gamut.
    for (lo, hi, n, tol) in [(500.0, 6000.0, 4096, 3e-4), (200.0, 40000.0, 2048, 2e-3)] {
        let table = BlackbodyTable::new(lo, hi, n);
        assert_eq!(table.range(), (lo, hi));
        let mut t = lo;
        while t <= hi {
            let (d, l) = (blackbody_radiance_rgb(t), table.radiance_rgb(t));
            let (dn, ln) = (blackbody_rgb_normalized(t), table.rgb_normalized(t));
            let scale = d.iter().cloned().fold(0.0, f64::max);
            for k in 0..3 {
                assert!((d[k] - l[k]).abs() <= tol * scale, "T={t}: {d:?} {l:?}");
                assert!((dn[k] - ln[k]).abs() <= tol, "T={t}: {dn:?} {ln:?}");
            }
            t *= 1.0007;
        }
        assert_eq!(table.rgb_normalized(hi), blackbody_rgb_normalized(hi));
    }
    let table = BlackbodyTable::new(500.0, 6000.0, 4096);
    // Outside the range and degenerate input fall back to the exact functions.
    assert_eq!(table.radiance_rgb(9000.0), blackbody_radiance_rgb(9000.0));
    assert_eq!(table.rgb_normalized(-3.0), [0.0; 3]);
    let empty = BlackbodyTable::new(10.0, 5.0, 100);
    assert_eq!(
        empty.rgb_normalized(3000.0),
        blackbody_rgb_normalized(3000.0)
    );
}
