use super::*;
use crate::integrate::deep::{DeepTrace, simplify};

/// The trace a march through a uniform slab `[z0, z1]` of extinction `sigma_t` records
/// in steps of `h`, with a colour of `k` per unit opacity.
fn slab(z0: f64, z1: f64, sigma_t: f64, h: f64, k: f64) -> DeepTrace {
    let mut tr = DeepTrace::default();
    let mut a = z0;
    while a < z1 {
        let b = (a + h).min(z1);
        let (a0, c0) = tr.last();
        let a1 = 1.0 - (-sigma_t * (b - z0)).exp();
        tr.segment(a, b, a0, c0, a1, DVec3::splat(k * a1));
        a = b;
    }
    tr
}

/// The deep samples of a pixel whose rays made `curves`, without AOVs.
fn samples(curves: &[Vec<DeepPoint>], tolerance: f64) -> Vec<DeepSample> {
    let mut out = DeepPixel::default();
    pixel_samples(curves, tolerance, None, &mut out);
    out.samples
}

/// Opacity of deep samples in front of depth `d`, each split there by OpenEXR's rule.
fn alpha_before(samples: &[DeepSample], d: f64) -> f64 {
    let mut t = 1.0;
    for s in samples {
        let (z, zb, a) = (s.z as f64, s.z_back as f64, s.alpha as f64);
        if d <= z {
            break;
        }
        let f = if zb > z {
            ((d - z) / (zb - z)).min(1.0)
        } else {
            1.0
        };
        t *= (1.0 - a).powf(f);
    }
    1.0 - t
}

#[test]
fn a_uniform_slab_splits_as_its_closed_form() {
    let (z0, z1, sigma_t) = (2.0, 6.0, 0.8);
    let tr = slab(z0, z1, sigma_t, 0.01, 1.0);
    let out = samples(&[tr.to_depth(1.0)], 0.01);
    // Uniform: ln T is linear, so one sample holds it all.
    assert_eq!(out.len(), 1, "{out:?}");
    for i in 0..=400 {
        let d = z0 - 0.5 + 5.0 * i as f64 / 400.0;
        let want = 1.0 - (-sigma_t * (d.clamp(z0, z1) - z0)).exp();
        let got = alpha_before(&out, d);
        assert!((got - want).abs() < 0.01, "d {d}: {got} against {want}");
    }
}

/// A cloud-like ray: density that changes along it, with a gap, and colour that does
/// not follow opacity.
fn lumpy(seed: u64) -> DeepTrace {
    let mut tr = DeepTrace::default();
    let mut tau = 0.0f64;
    let mut c = DVec3::ZERO;
    let mut z = 1.0 + (seed % 7) as f64 * 0.01;
    for i in 0..600 {
        let h = 0.02;
        let x = i as f64 * 0.05 + seed as f64;
        let rho = if (200..260).contains(&i) {
            0.0
        } else {
            (x.sin() * 0.5 + 0.6).max(0.0) * 2.0
        };
        let (a0, c0) = tr.last();
        let t0 = (-tau).exp();
        tau += rho * h;
        let a1 = 1.0 - (-tau).exp();
        c += DVec3::new(1.0, 0.5 + 0.4 * (x * 0.3).cos(), 0.2) * (t0 - (1.0 - a1));
        tr.segment(z, z + h, a0, c0, a1, c);
        z += h;
    }
    tr
}

fn check_tidy(samples: &[DeepSample]) {
    for w in samples.windows(2) {
        assert!(w[0].z <= w[0].z_back && w[0].z_back <= w[1].z, "{w:?}");
    }
    if let Some(s) = samples.last() {
        assert!(s.z <= s.z_back);
    }
}

#[test]
fn flattening_gives_back_the_flat_pixel() {
    for seed in 0..5 {
        let tr = lumpy(seed);
        let (a, c) = tr.last();
        let out = samples(&[tr.to_depth(1.3)], 0.01);
        check_tidy(&out);
        let f = flatten(&out);
        assert!((f[3] - a).abs() < 1e-5, "alpha {} against {a}", f[3]);
        for ch in 0..3 {
            assert!((f[ch] - c[ch]).abs() < 1e-5, "{f:?} against {c}");
        }
        assert!(out.len() < 60, "{} samples", out.len());
    }
}

#[test]
fn several_rays_flatten_to_their_mean() {
    let traces: Vec<Vec<DeepPoint>> = (0..9)
        .map(|s| lumpy(s).to_depth(1.0 + 0.01 * s as f64))
        .collect();
    let out = samples(&traces, 0.01);
    check_tidy(&out);
    let n = traces.len() as f64;
    let a: f64 = traces.iter().map(|t| t.last().unwrap().alpha).sum::<f64>() / n;
    let c: DVec3 = traces
        .iter()
        .map(|t| t.last().unwrap().color)
        .sum::<DVec3>()
        / n;
    let f = flatten(&out);
    assert!((f[3] - a).abs() < 1e-5, "alpha {} against {a}", f[3]);
    for ch in 0..3 {
        assert!((f[ch] - c[ch]).abs() < 1e-5, "{f:?} against {c}");
    }
}

#[test]
fn merged_samples_split_within_the_tolerance() {
    // Every point of the trace, split from the samples, within the tolerance.
    for tol in [0.01, 0.002] {
        let tr = lumpy(3);
        let curve = tr.to_depth(1.0);
        let out = samples(std::slice::from_ref(&curve), tol);
        let exact = simplify(&curve, 0.0, 1.0);
        assert!(out.len() < exact.len(), "{} of {}", out.len(), exact.len());
        for p in &curve {
            let got = alpha_before(&out, p.depth);
            assert!(
                (got - p.alpha).abs() <= tol * 1.0001,
                "tol {tol}, depth {}: {got} against {}",
                p.depth,
                p.alpha
            );
        }
    }
}

#[test]
fn a_gap_stays_empty() {
    let out = samples(&[lumpy(1).to_depth(1.0)], 0.05);
    // Steps 200..260 are empty: depths 5.0..6.2 from z = 1.01.
    for s in &out {
        assert!(s.z_back <= 5.02 || s.z >= 6.2, "a sample in the gap: {s:?}");
    }
}

#[test]
fn rays_apart_in_depth_flatten_to_their_mean() {
    // Half the rays meet the medium far behind the others: the mean has a gap between.
    let traces: Vec<Vec<DeepPoint>> = (0..6)
        .map(|s| {
            let mut c = lumpy(s).to_depth(1.0);
            if s % 2 == 1 {
                c.iter_mut().for_each(|p| p.depth += 40.0);
            }
            c
        })
        .collect();
    let out = samples(&traces, 0.01);
    check_tidy(&out);
    let n = traces.len() as f64;
    let a: f64 = traces.iter().map(|t| t.last().unwrap().alpha).sum::<f64>() / n;
    let c: DVec3 = traces
        .iter()
        .map(|t| t.last().unwrap().color)
        .sum::<DVec3>()
        / n;
    let f = flatten(&out);
    assert!((f[3] - a).abs() < 1e-5, "alpha {} against {a}", f[3]);
    for ch in 0..3 {
        assert!((f[ch] - c[ch]).abs() < 1e-5, "{f:?} against {c}");
    }
}

#[test]
fn structure_behind_near_full_opacity_is_one_sample() {
    // A dense slab takes the ray past 1 − tol (T = e⁻⁶ = 0.0025), then lumpy density
    // behind it: no depth there sees the opacity move by as much as the tolerance, so
    // where it lies in depth is not kept either. Placing each lump in depth (as a
    // depth criterion that ignores how little opacity is left would) takes dozens.
    let mut tr = slab(1.0, 1.6, 10.0, 0.02, 1.0);
    let lumps = lumpy(2).to_depth(1.0);
    let (a0, c0) = tr.last();
    let t0 = 1.0 - a0;
    for w in lumps.windows(2) {
        let (p, q) = (w[0], w[1]);
        if q.starts_run || p.depth < 1.6 {
            continue;
        }
        let (pa, pc) = (a0 + t0 * p.alpha, c0 + t0 * p.color);
        let (qa, qc) = (a0 + t0 * q.alpha, c0 + t0 * q.color);
        tr.segment(p.depth, q.depth, pa, pc, qa, qc);
    }
    let curve = tr.to_depth(1.0);
    let out = samples(std::slice::from_ref(&curve), 0.01);
    check_tidy(&out);
    let behind = out.iter().filter(|s| s.z >= 1.6).count();
    assert!(behind <= 2, "{behind} samples behind the slab: {out:?}");
    let (a, c) = tr.last();
    let f = flatten(&out);
    assert!(
        (f[3] - a).abs() < 1e-5 && (f[0] - c.x).abs() < 1e-5,
        "{f:?}"
    );
    for p in &curve {
        let got = alpha_before(&out, p.depth);
        assert!(
            (got - p.alpha).abs() <= 0.01,
            "{}: {got} against {}",
            p.depth,
            p.alpha
        );
    }
}
