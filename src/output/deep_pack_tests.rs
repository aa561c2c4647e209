//! Half colour without drift, depths on their grid and the landing on the flat file,
//! against what they promise.

use super::*;

fn sample(z: f32, z_back: f32, rgb: f32, a: f32) -> DeepSample {
    DeepSample {
        z,
        z_back,
        rgba: [rgb, rgb, rgb, a],
    }
}

fn flatten(s: &[DeepSample]) -> [f64; 4] {
    let (mut c, mut t) = ([0.0f64; 3], 1.0f64);
    for x in s {
        for (ck, v) in c.iter_mut().zip(&x.rgba) {
            *ck += t * *v as f64;
        }
        t *= 1.0 - x.rgba[3] as f64;
    }
    [c[0], c[1], c[2], 1.0 - t]
}

#[test]
fn pow2_floor_is_the_power_of_two_at_or_below() {
    for x in [1.0, 1.5, 0.75, 3.999, 4.0, 1e-300, 6.2e4, 1e-310, 0.1] {
        let p = pow2_floor(x);
        assert!(p <= x && 2.0 * p > x, "{x}: {p}");
        assert_eq!(p.log2().fract(), 0.0, "{x}: {p}");
    }
}

#[test]
fn the_bracket_is_the_two_half_floats_about_a_value() {
    for v in [
        0.0,
        1e-7,
        -3e-6,
        0.1,
        0.333_333,
        1.0,
        -1.0,
        2.0 - 1e-9,
        1000.5,
        65504.0,
    ] {
        let [a, b] = bracket(v);
        let (lo, hi) = (a.min(b) as f64, a.max(b) as f64);
        assert!(
            lo <= v && v <= hi && lo < hi || v == 65504.0,
            "{v}: {a} {b}"
        );
        // Adjacent: nothing half between them.
        let mid = to_half(0.5 * (lo + hi)) as f64;
        assert!(mid == lo || mid == hi, "{v}: {a} {b}");
        // The nearest first.
        assert!((a as f64 - v).abs() <= (b as f64 - v).abs(), "{v}: {a} {b}");
    }
}

#[test]
fn rounded_colour_does_not_drift_along_the_ray() {
    // 200 thin samples of alpha 0.0123…: rounded one by one, each alpha's rounding
    // (2.4e-4 relative) would add up along the ray.
    let samples: Vec<DeepSample> = (0..200)
        .map(|i| sample(i as f32 * 0.1, i as f32 * 0.1 + 0.1, 0.0071234, 0.0123457))
        .collect();
    let mut one_by_one = samples.clone();
    for s in &mut one_by_one {
        for v in &mut s.rgba {
            *v = to_half(*v as f64);
        }
    }
    let mut out = Vec::new();
    round_colour(&samples, &mut out);
    let (want, naive, got) = (flatten(&samples), flatten(&one_by_one), flatten(&out));
    for k in 0..4 {
        // One rounding of the last sample at most.
        assert!(
            (got[k] - want[k]).abs() < 2e-6,
            "{k}: {} against {}",
            got[k],
            want[k]
        );
    }
    assert!(
        (naive[3] - want[3]).abs() > 1e-5,
        "the test needs drift to show"
    );
    for s in &out {
        assert!(s.rgba.iter().all(|v| *v == to_half(*v as f64)));
    }
}

#[test]
fn rounded_depths_move_opacity_by_a_share_of_the_tolerance() {
    // A dense front sample, then fainter ones, joined, and one behind a gap.
    let mut s = vec![
        sample(17.123456, 17.345_678, 0.5, 0.9),
        sample(17.345_678, 18.987654, 0.05, 0.5),
        sample(18.987654, 19.5, 0.01, 0.3),
        sample(19.500001, 21.0, 0.01, 0.3),
    ];
    let orig = s.clone();
    round_depths(&mut s, 0.01);
    assert_eq!(s[0].z_back, s[1].z, "joined samples stay joined");
    assert_eq!(s[1].z_back, s[2].z);
    assert!(s[2].z_back <= s[3].z, "apart samples stay apart");
    let mut t = 1.0f64;
    for (r, o) in s.iter().zip(&orig) {
        let a = o.rgba[3] as f64;
        let kappa = -(1.0 - a).ln() / (o.z_back - o.z) as f64;
        // The opacity's slope at the front is T κ, at the back T (1 − α) κ.
        for (new, old, tt) in [(r.z, o.z, t), (r.z_back, o.z_back, t * (1.0 - a))] {
            let moved = (new as f64 - old as f64).abs();
            assert!(
                tt * kappa * moved <= DEPTH_SHARE * 0.01 * 1.0001,
                "{new} from {old}"
            );
        }
        t *= 1.0 - a;
    }
    // Something was rounded: the faint samples' depths have zero low bits.
    assert!(s[3].z_back.to_bits() & 0xff == 0, "{}", s[3].z_back);
}

#[test]
fn landing_puts_the_flattened_pixel_on_the_flat_files_value() {
    // Bright, dense samples: rounded against each other they flatten within a
    // rounding of the exact pixel, and the flat file's half value is another rounding
    // away; near full opacity only a dense sample's alpha can move the total.
    let samples: Vec<DeepSample> = (0..12)
        .map(|i| {
            let z = i as f32 * 0.1;
            sample(z, z + 0.1, 0.371_234_5 + i as f32 * 0.0123, 0.534_5)
        })
        .collect();
    let exact = flatten(&samples);
    let target = exact.map(to_half);
    let mut out = Vec::new();
    round_colour(&samples, &mut out);
    let before = flatten(&out);
    let off = |f: &[f64; 4]| {
        (0..4)
            .map(|k| (f[k] - target[k] as f64).abs())
            .fold(0.0, f64::max)
    };
    assert!(
        off(&before) > 2e-5,
        "the test needs a pixel off its flat value: {before:?}"
    );
    let rounded = out.clone();
    land_on(&mut out, target, 0.01);
    assert!(
        off(&flatten(&out)) < 1e-6,
        "{:?} against {target:?}",
        flatten(&out)
    );
    // A grey pixel stays grey.
    assert!(
        out.iter()
            .all(|s| s.rgba[0] == s.rgba[1] && s.rgba[1] == s.rgba[2])
    );
    // Half floats still, and the opacity in front of every sample within a quarter of
    // the tolerance of what it was.
    let (mut t0, mut t1) = (1.0f64, 1.0f64);
    for (a, b) in out.iter().zip(&rounded) {
        assert!(a.rgba.iter().all(|v| *v == to_half(*v as f64)));
        t0 *= 1.0 - a.rgba[3] as f64;
        t1 *= 1.0 - b.rgba[3] as f64;
        assert!((t0 - t1).abs() <= 0.0025, "{t0} against {t1}");
    }
}

#[test]
fn landing_the_opacity_of_a_few_large_samples_is_kept() {
    // A mixed-cell mesh's pixel: three large samples, rounded against each other,
    // 1.7e-4 from the flat file's alpha. Landing the opacity moves the colour behind
    // it by 2.4e-5, which the colour's steps (6e-5 and more) cannot take back to the
    // 1.2e-6 it was; the pixel is still far nearer the flat file than before.
    let mut s = vec![
        sample(3.039_062_5, 3.179_687_5, 0.106_567_38, 0.193_603_52),
        sample(3.179_687_5, 3.5625, 0.183_105_47, 0.408_935_55),
        sample(3.5625, 4.093_75, 0.206_787_11, 0.438_964_84),
    ];
    let target =
        [0.352_783_2, 0.352_783_2, 0.352_783_2, 0.732_421_9].map(|v: f32| to_half(v as f64));
    let off = |s: &[DeepSample]| {
        let f = flatten(s);
        (0..4)
            .map(|k| (f[k] - target[k] as f64).abs())
            .fold(0.0, f64::max)
    };
    assert!(off(&s) > 1.5e-4, "the test needs a pixel off: {}", off(&s));
    land_on(&mut s, target, 0.01);
    assert!(off(&s) < 5e-5, "{:?} against {target:?}", flatten(&s));
}
