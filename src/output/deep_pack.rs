//! Deep samples made compact for the file (the default; `--float` writes them as they
//! are): colour and opacity rounded to half floats, and depths rounded to a power-of-two
//! grid, so that the file's bytes compress.
//!
//! - **Half colour, without drift.** Each sample's half-float opacity and colour are
//!   chosen against what the samples already rounded flatten to, not rounded one by one:
//!   the error of the pixel flattened is one rounding of its last sample (a relative
//!   2⁻¹¹ of what that sample adds), never a sum of roundings along the ray.
//! - **Depths on a grid.** A depth keeps only as many bits as the samples around it need:
//!   it moves by at most the distance at which the opacity of a sample split there
//!   changes by [`DEPTH_SHARE`] of the tolerance (its colour, which follows opacity
//!   inside a sample, by that share of the sample's own), and by at most a quarter of
//!   the sample or gap beside it, so samples stay sorted and apart.
//!   Zeroed low bits are what makes 32-bit depths compress; a point shared by two
//!   samples (`ZBack` of one, `Z` of the next) is rounded once, so they stay joined.

use exr::prelude::f16;

/// One deep sample: camera-space depths and premultiplied colour and opacity.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DeepSample {
    pub z: f32,
    pub z_back: f32,
    pub rgba: [f32; 4],
}

/// The share of the deep tolerance a depth's rounding may move a split's opacity by.
pub const DEPTH_SHARE: f64 = 0.75;

/// The largest finite half float.
const HALF_MAX: f64 = 65504.0;

fn to_half(v: f64) -> f32 {
    f16::from_f64(v.clamp(-HALF_MAX, HALF_MAX)).to_f32()
}

/// One pixel's samples with half-float colour and opacity, chosen so the pixel flattens
/// (front to back, "over") to within one rounding of what `samples` flatten to. Samples
/// that add nothing once rounded, and those behind a rounded opacity of one, are left out.
pub fn round_colour(samples: &[DeepSample], out: &mut Vec<DeepSample>) {
    out.clear();
    // Flattened so far: exactly, and from the rounded samples.
    let (mut t, mut c) = (1.0f64, [0.0f64; 3]);
    let (mut tq, mut cq) = (1.0f64, [0.0f64; 3]);
    for s in samples {
        if !(tq > 0.0) {
            break;
        }
        let a = s.rgba[3] as f64;
        for (k, ck) in c.iter_mut().enumerate() {
            *ck += t * s.rgba[k] as f64;
        }
        t *= 1.0 - a;
        let alpha = to_half((1.0 - t / tq).clamp(0.0, 1.0));
        let rgb = [0, 1, 2].map(|k| to_half((c[k] - cq[k]) / tq));
        if alpha == 0.0 && rgb == [0.0; 3] {
            continue;
        }
        for (k, ck) in cq.iter_mut().enumerate() {
            *ck += tq * rgb[k] as f64;
        }
        tq *= 1.0 - alpha as f64;
        out.push(DeepSample {
            rgba: [rgb[0], rgb[1], rgb[2], alpha],
            ..*s
        });
    }
}

/// How far the front (`back == false`) or back of sample `i` may move.
fn limit(samples: &[DeepSample], t_before: &[f64], i: usize, back: bool, tol: f64) -> f64 {
    let s = samples[i];
    let len = s.z_back as f64 - s.z as f64;
    let a = s.rgba[3] as f64;
    if !(len > 0.0) || !(a < 1.0) {
        return 0.0;
    }
    // Opacity in front of depth d inside the sample: 1 − T (1 − a)^((d − Z)/len); its
    // slope is T κ (1 − a)^f, the most at the front.
    let kappa = -(1.0 - a).ln() / len;
    let t = if back { t_before[i + 1] } else { t_before[i] };
    let slope = t * kappa;
    let by_split = if slope > 0.0 {
        DEPTH_SHARE * tol / slope
    } else {
        f64::INFINITY
    };
    by_split.min(len / 4.0)
}

/// Rounds `z` to the coarsest power-of-two grid that moves it by at most `most`.
fn round_depth(z: f32, most: f64) -> f32 {
    if !(most > 0.0) || !most.is_finite() || !z.is_finite() {
        return z;
    }
    let grid = (2.0 * most).log2().floor().exp2();
    // Finer than the float's own spacing: nothing to round.
    if grid <= (z.abs() as f64) * f32::EPSILON as f64 {
        return z;
    }
    ((z as f64 / grid).round() * grid) as f32
}

/// Rounds the depths of one pixel's tidy samples (see the module's notes); `tol` is the
/// deep tolerance.
pub fn round_depths(samples: &mut [DeepSample], tol: f64) {
    let n = samples.len();
    let mut t_before = Vec::with_capacity(n + 1);
    t_before.push(1.0f64);
    for s in samples.iter() {
        let t = t_before[t_before.len() - 1];
        t_before.push(t * (1.0 - s.rgba[3] as f64));
    }
    let lim = |i: usize, back: bool| limit(samples, &t_before, i, back, tol);
    // Whether sample i's front is sample i − 1's back; the gap otherwise.
    let joined = |i: usize| i > 0 && samples[i - 1].z_back == samples[i].z;
    let gap = |i: usize| samples[i].z as f64 - samples[i - 1].z_back as f64;
    let moved: Vec<(f32, f32)> = (0..n)
        .map(|i| {
            let mut front = lim(i, false);
            if i > 0 {
                front = front.min(if joined(i) {
                    lim(i - 1, true)
                } else {
                    gap(i) / 4.0
                });
            }
            let mut back = lim(i, true);
            if i + 1 < n {
                back = back.min(if joined(i + 1) {
                    lim(i + 1, false)
                } else {
                    gap(i + 1) / 4.0
                });
            }
            let s = samples[i];
            (round_depth(s.z, front), round_depth(s.z_back, back))
        })
        .collect();
    for (s, (z, zb)) in samples.iter_mut().zip(moved) {
        s.z = z;
        s.z_back = zb.max(z);
    }
}

#[cfg(test)]
mod tests {
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
}
