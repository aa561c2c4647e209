//! murk's Lorenz–Mie phase function against miepython's (PyPI; nobody here wrote it),
//! computed by `scripts/mie_reference.py` into `fixtures/reference.json` under
//! `water_drop_mie`, with the same refractive index fit and radius averaging.

use murk::integrate::phase::mie::{
    RADIUS_SAMPLES, RADIUS_SPREAD, averaged_phase, averaged_radii, water_refractive_index,
};
use serde_json::Value;

#[test]
fn mie_phase_matches_miepython() {
    let root = env!("CARGO_MANIFEST_DIR");
    let text = std::fs::read_to_string(format!("{root}/fixtures/reference.json")).unwrap();
    let json: Value = serde_json::from_str(&text).unwrap();
    let reference = &json["water_drop_mie"];
    assert_eq!(reference["radius_spread"].as_f64(), Some(RADIUS_SPREAD));
    assert_eq!(
        reference["radius_samples"].as_u64(),
        Some(RADIUS_SAMPLES as u64)
    );
    let cases = reference["cases"].as_array().expect("cases");
    assert!(cases.len() >= 4);
    let mut worst: f64 = 0.0;
    for case in cases {
        let r = case["radius_um"].as_f64().unwrap();
        let lambda = case["wavelength_nm"].as_f64().unwrap();
        let m = case["m"].as_f64().unwrap();
        assert!(
            (water_refractive_index(lambda) - m).abs() < 1e-12,
            "{lambda} nm"
        );
        let angles: Vec<f64> = case["angles_deg"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        assert!(angles.len() >= 50);
        let expected: Vec<f64> = case["phase"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let mu: Vec<f64> = angles.iter().map(|a| a.to_radians().cos()).collect();
        let got = averaged_phase(m, lambda, &averaged_radii(r * 1e3), &mu).unwrap();
        for ((a, e), g) in angles.iter().zip(&expected).zip(&got) {
            let rel = (g - e).abs() / e.abs();
            worst = worst.max(rel);
            assert!(
                rel < 1e-3,
                "r={r} µm λ={lambda} nm θ={a}°: murk {g}, miepython {e}"
            );
        }
    }
    eprintln!("largest relative difference from miepython: {worst:.2e}");
}
