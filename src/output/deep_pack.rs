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
//! - **Landing on the flat file.** Given the flat file's stored pixel (its half floats),
//!   [`land_on`] then moves a few samples' half values (each change moving the opacity
//!   in front of any depth by at most a quarter of the tolerance) so the pixel flattens
//!   onto it, not within a rounding of it.

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
pub const HALF_MAX: f64 = 65504.0;

fn to_half(v: f64) -> f32 {
    f16::from_f64(v.clamp(-HALF_MAX, HALF_MAX)).to_f32()
}

/// One pixel's samples with half-float colour and opacity, chosen so the pixel flattens
/// (front to back, "over") to within one rounding of what `samples` flatten to. Samples
/// that add nothing once rounded, and those behind a rounded opacity of one, are left out.
pub fn round_colour(samples: &[DeepSample], out: &mut Vec<DeepSample>) {
    round_with_aovs(samples, &[], 0, out, &mut Vec::new());
}

/// [`round_colour`] for samples that carry `m` AOV values each (`aovs`, sample after
/// sample): theirs are rounded against what the rounded samples flatten to as well,
/// into `aovs_out`.
pub fn round_with_aovs(
    samples: &[DeepSample],
    aovs: &[f32],
    m: usize,
    out: &mut Vec<DeepSample>,
    aovs_out: &mut Vec<f32>,
) {
    out.clear();
    aovs_out.clear();
    // Flattened so far: exactly, and from the rounded samples.
    let (mut t, mut c) = (1.0f64, [0.0f64; 3]);
    let (mut tq, mut cq) = (1.0f64, [0.0f64; 3]);
    let (mut e, mut eq) = (vec![0.0f64; m], vec![0.0f64; m]);
    for (i, s) in samples.iter().enumerate() {
        if !(tq > 0.0) {
            break;
        }
        let a = s.rgba[3] as f64;
        for (k, ck) in c.iter_mut().enumerate() {
            *ck += t * s.rgba[k] as f64;
        }
        if let Some(v) = aovs.get(i * m..(i + 1) * m) {
            for (ek, vk) in e.iter_mut().zip(v) {
                *ek += t * *vk as f64;
            }
        }
        t *= 1.0 - a;
        let alpha = to_half((1.0 - t / tq).clamp(0.0, 1.0));
        // A grey pixel so far (a grey medium under white light): one rounding serves all.
        let rgb = if c[0] == c[1] && c[1] == c[2] && cq[0] == cq[1] && cq[1] == cq[2] {
            [to_half((c[0] - cq[0]) / tq); 3]
        } else {
            [0, 1, 2].map(|k| to_half((c[k] - cq[k]) / tq))
        };
        if alpha == 0.0 && rgb == [0.0; 3] {
            continue;
        }
        for (k, ck) in cq.iter_mut().enumerate() {
            *ck += tq * rgb[k] as f64;
        }
        for (ek, eqk) in e.iter().zip(eq.iter_mut()) {
            let v = to_half((ek - *eqk) / tq);
            *eqk += tq * v as f64;
            aovs_out.push(v);
        }
        tq *= 1.0 - alpha as f64;
        out.push(DeepSample {
            rgba: [rgb[0], rgb[1], rgb[2], alpha],
            ..*s
        });
    }
}

/// How far the front and the back of a sample of opacity `a` over `len` may move, with
/// transmittance `t` in front of it: where a split moves the opacity in front of it by
/// [`DEPTH_SHARE`] of `tol`, and at most a quarter of the sample.
fn limits(len: f64, a: f64, t: f64, tol: f64) -> (f64, f64) {
    if !(len > 0.0) || !(a < 1.0) {
        return (0.0, 0.0);
    }
    // Opacity in front of depth d inside the sample: 1 − T (1 − a)^((d − Z)/len); its
    // slope is T κ (1 − a)^f, the most at the front.
    let kappa = -(1.0 - a).ln() / len;
    let by_split = |slope: f64| {
        if slope > 0.0 {
            (DEPTH_SHARE * tol / slope).min(len / 4.0)
        } else {
            len / 4.0
        }
    };
    (by_split(t * kappa), by_split(t * (1.0 - a) * kappa))
}

/// Rounds `z` to the coarsest power-of-two grid that moves it by at most `most`.
fn round_depth(z: f32, most: f64) -> f32 {
    if !(most > 0.0) || !most.is_finite() || !z.is_finite() {
        return z;
    }
    let grid = pow2_floor(2.0 * most);
    if !grid.is_finite() {
        return z;
    }
    // Finer than the float's own spacing: nothing to round.
    if grid <= (z.abs() as f64) * f32::EPSILON as f64 {
        return z;
    }
    ((z as f64 / grid).round() * grid) as f32
}

/// The largest power of two not above `x` (positive): a normal float with its mantissa
/// bits cleared, without a logarithm (this runs for every depth of the file).
fn pow2_floor(x: f64) -> f64 {
    if x >= f64::MIN_POSITIVE {
        f64::from_bits(x.to_bits() & 0xfff0_0000_0000_0000)
    } else {
        x.log2().floor().exp2()
    }
}

/// Rounds the depths of one pixel's tidy samples (see the module's notes); `tol` is the
/// deep tolerance.
pub fn round_depths(samples: &mut [DeepSample], tol: f64) {
    // Per sample how far its front and back may move for its own sake (one logarithm a
    // sample), then, both ends' depths rounded, written back.
    let mut lim: Vec<(f64, f64)> = Vec::with_capacity(samples.len());
    let mut t = 1.0f64;
    for s in samples.iter() {
        let a = s.rgba[3] as f64;
        lim.push(limits(s.z_back as f64 - s.z as f64, a, t, tol));
        t *= 1.0 - a;
    }
    let n = samples.len();
    // A front joined to the sample before moves as little as that one's back may; a gap
    // limits both ends beside it to a quarter of it.
    let mut back_before = 0.0;
    for i in 0..n {
        let (own_front, own_back) = lim[i];
        let mut front = own_front;
        if i > 0 {
            front = front.min(if samples[i - 1].z_back == samples[i].z {
                back_before
            } else {
                (samples[i].z as f64 - samples[i - 1].z_back as f64) / 4.0
            });
        }
        let mut back = own_back;
        if i + 1 < n {
            back = back.min(if samples[i].z_back == samples[i + 1].z {
                lim[i + 1].0
            } else {
                (samples[i + 1].z as f64 - samples[i].z_back as f64) / 4.0
            });
        }
        back_before = own_back;
        lim[i] = (front, back);
    }
    for (s, (front, back)) in samples.iter_mut().zip(lim) {
        let z = round_depth(s.z, front);
        s.z_back = round_depth(s.z_back, back).max(z);
        s.z = z;
    }
}

/// The spacing of half floats at `v`.
fn half_ulp(v: f64) -> f64 {
    let a = v.abs();
    if a < 6.103_515_625e-5 {
        5.960_464_477_539_063e-8 // 2⁻²⁴: subnormals
    } else {
        pow2_floor(a) / 1024.0
    }
}

/// The half float next to the half float `h`, up or down; `h` itself where that is past
/// the finite range.
fn half_step(h: f32, up: bool) -> f32 {
    let b = f16::from_f32(h).to_bits();
    let bits = if b & 0x7fff == 0 {
        if up { 0x0001 } else { 0x8001 }
    } else if (b & 0x8000 != 0) == up {
        b - 1
    } else {
        b + 1
    };
    let v = f16::from_bits(bits).to_f32();
    if v.is_finite() { v } else { h }
}

/// The two half floats about `v` (`v` rounded down and up; its nearest first). Through
/// a 32-bit float: a double rounding may pick the other one as the nearest, but the two
/// are the same.
fn bracket(v: f64) -> [f32; 2] {
    let h = f16::from_f32(v.clamp(-HALF_MAX, HALF_MAX) as f32).to_f32();
    [h, half_step(h, (h as f64) < v)]
}

/// Transmittance in front of each sample, and behind the last, into `t`.
fn t_front(samples: &[DeepSample], t: &mut Vec<f64>) {
    t.clear();
    t.push(1.0);
    let mut now = 1.0f64;
    for x in samples {
        now *= 1.0 - x.rgba[3] as f64;
        t.push(now);
    }
}

/// How many samples [`land_on`] may move per channel.
const LANDING_PASSES: usize = 4;

/// A change considered by [`land_on`]: its error after, how much it moves the opacity
/// (or colour) in front of a depth, the sample and its new value.
type Move = (f64, f64, usize, f32);

fn better(m: Move, best: Option<Move>, now: f64) -> bool {
    match best {
        None => m.0 < now,
        Some(b) => m.0 < b.0 - 1e-12 || (m.0 <= b.0 + 1e-12 && m.1 < b.1),
    }
}

/// How far the pixel of `samples` (with `t` its [`t_front`]) is from `target`, per
/// channel.
fn off(samples: &[DeepSample], t: &[f64], target: [f32; 4]) -> [f64; 4] {
    let mut out = [0.0f64; 4];
    for (c, o) in out.iter_mut().enumerate().take(3) {
        let sum: f64 = samples
            .iter()
            .zip(t)
            .map(|(x, t)| t * x.rgba[c] as f64)
            .sum();
        *o = (sum - target[c] as f64).abs();
    }
    out[3] = (1.0 - t[samples.len()] - target[3] as f64).abs();
    out
}

/// Moves the half-float values of one pixel's samples so it flattens onto `target` — the
/// flat file's stored `R, G, B, A` — instead of within a rounding of it (the flat
/// file's own rounding, 2⁻¹¹ of the value, is one the deep samples need not make).
/// Opacity first (it weighs the colour behind it): a few times, the one sample's alpha whose
/// half-float change brings the pixel's transmittance nearest the target's, among
/// changes that move the opacity in front of any depth by at most a quarter of the deep
/// tolerance; then each colour channel the same way (a change that moves the
/// flattened colour by the difference to the target moves it in front of any depth by
/// no more). A target more than a few half-float steps away is not a rounding of this
/// pixel: nothing moves. Where the moves leave the pixel's furthest channel further from
/// the target than it was, they are undone.
pub fn land_on(samples: &mut [DeepSample], target: [f32; 4], tolerance: f64) {
    if samples.is_empty() || target.iter().any(|v| !v.is_finite()) {
        return;
    }
    let reach = 0.25 * tolerance;
    let far = |want: f64| 4.0 * half_ulp(want) + 1e-6;
    // The moves made (sample, channel, value before), to undo them.
    let mut made: [(usize, usize, f32); 4 * LANDING_PASSES] = [(0, 0, 0.0); 4 * LANDING_PASSES];
    let mut n_made = 0;
    let mut t = Vec::with_capacity(samples.len() + 1);
    t_front(samples, &mut t);
    let off_before = off(samples, &t, target);
    let want_t = 1.0 - target[3] as f64;
    for pass in 0..LANDING_PASSES {
        if pass > 0 {
            t_front(samples, &mut t);
        }
        let t_end = t[samples.len()];
        let now = (t_end - want_t).abs();
        if now == 0.0 || now > far(target[3] as f64) {
            break;
        }
        let mut best: Option<Move> = None;
        for (i, s) in samples.iter().enumerate() {
            let a = s.rgba[3] as f64;
            let front = t[i] * (1.0 - a);
            if !(a < 1.0) || !(front > 0.0) {
                continue;
            }
            // What the samples behind let through.
            let behind = t_end / front;
            for h in bracket(1.0 - want_t / (t[i] * behind)) {
                let moved = t[i] * (h as f64 - a).abs();
                if !(0.0..=1.0).contains(&h) || moved > reach {
                    continue;
                }
                let m = (
                    (t[i] * (1.0 - h as f64) * behind - want_t).abs(),
                    moved,
                    i,
                    h,
                );
                if better(m, best, now) {
                    best = Some(m);
                }
            }
        }
        match best {
            Some((_, _, i, h)) => {
                made[n_made] = (i, 3, samples[i].rgba[3]);
                n_made += 1;
                samples[i].rgba[3] = h;
            }
            None => break,
        }
    }
    if n_made > 0 {
        t_front(samples, &mut t);
    }
    // A grey pixel and target (a grey medium under white light): the green and blue
    // channels would move as the red one does; it moves, and they are given its values.
    let grey = target[0] == target[1]
        && target[1] == target[2]
        && samples
            .iter()
            .all(|s| s.rgba[0] == s.rgba[1] && s.rgba[1] == s.rgba[2]);
    let made_before_colour = n_made;
    for c in 0..if grey { 1 } else { 3 } {
        let want = target[c] as f64;
        // Not a rounding away before the opacity moved: another pixel's value.
        if off_before[c] > far(want) {
            continue;
        }
        for _ in 0..LANDING_PASSES {
            let sum: f64 = samples
                .iter()
                .zip(&t)
                .map(|(s, t)| t * s.rgba[c] as f64)
                .sum();
            let now = (sum - want).abs();
            if now == 0.0 {
                break;
            }
            let mut best: Option<Move> = None;
            for (i, s) in samples.iter().enumerate() {
                let v = s.rgba[c] as f64;
                if !(t[i] > 0.0) {
                    continue;
                }
                let ideal = v + (want - sum) / t[i];
                if ideal.abs() > HALF_MAX {
                    continue;
                }
                for h in bracket(ideal) {
                    // Light stays light: no negative colour where there was none.
                    if v >= 0.0 && h < 0.0 {
                        continue;
                    }
                    let moved = t[i] * (h as f64 - v).abs();
                    let m = ((sum + t[i] * (h as f64 - v) - want).abs(), moved, i, h);
                    if better(m, best, now) {
                        best = Some(m);
                    }
                }
            }
            match best {
                Some((_, _, i, h)) => {
                    made[n_made] = (i, c, samples[i].rgba[c]);
                    n_made += 1;
                    samples[i].rgba[c] = h;
                }
                None => break,
            }
        }
    }
    let copy_red = |samples: &mut [DeepSample], moves: &[(usize, usize, f32)]| {
        for &(i, _, _) in moves {
            samples[i].rgba[1] = samples[i].rgba[0];
            samples[i].rgba[2] = samples[i].rgba[0];
        }
    };
    if grey {
        copy_red(samples, &made[made_before_colour..n_made]);
    }
    if n_made == 0 {
        return;
    }
    // Kept where it brings the pixel's furthest channel nearer: moving the opacity moves
    // the colour behind it, which the colour's own moves may not bring back to where it
    // was (a few large samples, as a mesh's cells give, have coarse half-float steps),
    // but to well within the opacity's own error before.
    let worst = |o: [f64; 4]| o.iter().copied().fold(0.0, f64::max);
    if worst(off(samples, &t, target)) > worst(off_before) {
        for &(i, c, v) in made[..n_made].iter().rev() {
            samples[i].rgba[c] = v;
        }
        if grey {
            copy_red(samples, &made[made_before_colour..n_made]);
        }
    }
}

#[cfg(test)]
#[path = "deep_pack_tests.rs"]
mod tests;
