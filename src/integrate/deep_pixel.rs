//! A pixel's deep samples from its rays' records (`integrate::deep`): the mean of the
//! rays' curves, thinned by [`simplify`], each kept interval one sample `(Z, ZBack,
//! colour, alpha)`; and with deep AOVs, each sample's share of every AOV
//! (`integrate::deep_aovs`), split in depth as the colour is.

use glam::DVec3;

use super::deep::{DeepPoint, simplify};
use super::deep_aovs::DeepAov;

/// One deep sample as written: camera-space depths and premultiplied colour and alpha.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DeepSample {
    pub z: f32,
    pub z_back: f32,
    pub rgb: [f32; 3],
    pub alpha: f32,
}

/// One pixel's deep output: its samples, front to back, and with deep AOVs each
/// sample's AOV values (three a selected AOV, in its order), sample after sample.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DeepPixel {
    pub samples: Vec<DeepSample>,
    pub aovs: Vec<f32>,
}

impl DeepPixel {
    pub fn clear(&mut self) {
        self.samples.clear();
        self.aovs.clear();
    }
}

/// What a pixel's rays recorded for its AOVs: per ray its AOV values (`width` per
/// point of its curve), and the AOVs wanted.
pub struct PixelAovs<'a> {
    pub rows: &'a [Vec<f64>],
    pub width: usize,
    pub wanted: &'a [DeepAov],
}

/// The AOVs of a pixel's samples: its rays' curves (in depth) with their AOV values, and
/// the AOVs wanted. Each sample's value of an AOV is what the AOV's curve (the mean of the
/// rays', each split by OpenEXR's rule like colour) gains over the sample, over the
/// transmittance in front of it, so each AOV flattens to the mean of the rays' totals:
/// the flat layer.
struct AovWalk<'a> {
    curves: &'a [Vec<DeepPoint>],
    rows: &'a [Vec<f64>],
    width: usize,
    wanted: &'a [DeepAov],
    cursors: Vec<usize>,
    /// What the samples so far add up to, flattened.
    done: Vec<f64>,
    now: Vec<f64>,
}

impl AovWalk<'_> {
    /// The AOVs' cumulative values at `depth` (growing over calls) into `now`.
    fn at(&mut self, depth: f64) {
        self.now.iter_mut().for_each(|v| *v = 0.0);
        let n = self.curves.len().max(1) as f64;
        for ((curve, rows), cur) in self.curves.iter().zip(self.rows).zip(&mut self.cursors) {
            let (i, j, share) = match locate(curve, depth, cur) {
                Where::Zero => continue,
                Where::Hold(i) => (i, i, 0.0),
                Where::Between(i, j, f) => (i, j, split(&curve[i], &curve[j], f).1),
            };
            let at = |k: usize| curve[k].row as usize * self.width;
            let (Some(ri), Some(rj)) = (rows.get(at(i)..), rows.get(at(j)..)) else {
                continue;
            };
            for (k, aov) in self.wanted.iter().enumerate() {
                for &r in &aov.rows {
                    for c in 0..3 {
                        let (a, b) = (ri[r + c], rj[r + c]);
                        self.now[3 * k + c] += (a + (b - a) * share) / n;
                    }
                }
            }
        }
    }

    /// The sample that ends at `depth` with transmittance `t0` in front of it.
    fn sample(&mut self, depth: f64, t0: f64, out: &mut Vec<f32>) {
        self.at(depth);
        for (d, v) in self.done.iter_mut().zip(&self.now) {
            out.push(((v - *d) / t0) as f32);
            *d = *v;
        }
    }
}

/// The deep samples of a kept curve: one per interval inside a run, front to back,
/// leaving out those that add nothing. A sample behind full opacity adds nothing either.
pub fn samples_of(curve: &[DeepPoint], out: &mut Vec<DeepSample>) {
    samples_with(curve, out, None);
}

fn samples_with(
    curve: &[DeepPoint],
    out: &mut Vec<DeepSample>,
    mut aovs: Option<(&mut AovWalk, &mut Vec<f32>)>,
) {
    out.reserve(curve.len().saturating_sub(1));
    for w in curve.windows(2) {
        let (p, q) = (w[0], w[1]);
        if q.starts_run {
            continue;
        }
        let t0 = 1.0 - p.alpha;
        if !(t0 > 0.0) {
            break;
        }
        let alpha = (1.0 - (1.0 - q.alpha) / t0).clamp(0.0, 1.0);
        let color = (q.color - p.color) / t0;
        if alpha == 0.0 && color == DVec3::ZERO {
            continue;
        }
        out.push(DeepSample {
            z: p.depth as f32,
            z_back: q.depth.max(p.depth) as f32,
            rgb: [color.x as f32, color.y as f32, color.z as f32],
            alpha: alpha as f32,
        });
        if let Some((walk, values)) = aovs.as_mut() {
            walk.sample(q.depth, t0, values);
        }
    }
}

/// Where `depth` falls on a curve: before it (zero), on or after point `i` with nothing
/// changing until the next (its value), or inside the interval from point `i` to point
/// `j` at fraction `f` of its depth. `cursor` walks forward over calls with growing depths.
enum Where {
    Zero,
    Hold(usize),
    Between(usize, usize, f64),
}

fn locate(curve: &[DeepPoint], depth: f64, cursor: &mut usize) -> Where {
    while *cursor < curve.len() && curve[*cursor].depth <= depth {
        *cursor += 1;
    }
    let i = *cursor;
    if i == 0 {
        return Where::Zero;
    }
    if i == curve.len() || curve[i].starts_run {
        return Where::Hold(i - 1);
    }
    let (p, q) = (&curve[i - 1], &curve[i]);
    Where::Between(
        i - 1,
        i,
        ((depth - p.depth) / (q.depth - p.depth)).clamp(0.0, 1.0),
    )
}

/// Inside the interval from `p` to `q` at fraction `f` of its depth, by OpenEXR's split
/// rule (ln T linear in depth): the opacity, and the share of the interval's opacity (of
/// its colour, which follows opacity; of its depth where it has no opacity) in front.
fn split(p: &DeepPoint, q: &DeepPoint, f: f64) -> (f64, f64) {
    let (t0, t1) = (1.0 - p.alpha, 1.0 - q.alpha);
    let t = if t0 > 0.0 {
        t0 * (t1 / t0).powf(f)
    } else {
        0.0
    };
    let alpha = 1.0 - t;
    let da = q.alpha - p.alpha;
    let share = if da > 0.0 {
        ((alpha - p.alpha) / da).clamp(0.0, 1.0)
    } else {
        f
    };
    (alpha, share)
}

/// A curve's value at `depth`: inside an interval by OpenEXR's split rule (ln T linear in
/// depth, colour in proportion to opacity), in a gap or past the end its last value.
/// `cursor` walks forward over calls with growing depths.
fn value_at(curve: &[DeepPoint], depth: f64, cursor: &mut usize) -> (f64, DVec3) {
    match locate(curve, depth, cursor) {
        Where::Zero => (0.0, DVec3::ZERO),
        Where::Hold(i) => (curve[i].alpha, curve[i].color),
        Where::Between(i, j, f) => {
            let (p, q) = (&curve[i], &curve[j]);
            let (alpha, share) = split(p, q, f);
            (alpha, p.color + (q.color - p.color) * share)
        }
    }
}

/// The mean of several curves (each a pixel sample's, in depth), as one curve whose
/// points are the union of theirs: exact at every one of their points.
pub fn mean_curve(curves: &[Vec<DeepPoint>]) -> Vec<DeepPoint> {
    let mut depths: Vec<f64> = curves.iter().flatten().map(|p| p.depth).collect();
    depths.sort_by(f64::total_cmp);
    depths.dedup();
    let n = curves.len().max(1) as f64;
    let mut cursors = vec![0usize; curves.len()];
    let mut out: Vec<DeepPoint> = Vec::with_capacity(depths.len());
    for &z in &depths {
        let (mut a, mut c) = (0.0, DVec3::ZERO);
        for (curve, cur) in curves.iter().zip(cursors.iter_mut()) {
            let (ai, ci) = value_at(curve, z, cur);
            a += ai;
            c += ci;
        }
        let point = DeepPoint {
            depth: z,
            alpha: a / n,
            color: c / n,
            starts_run: false,
            row: 0,
        };
        match out.last_mut() {
            // Nothing changed since the last point: empty space (or its end).
            Some(last) if last.alpha == point.alpha && last.color == point.color => {
                let start = DeepPoint {
                    starts_run: true,
                    ..point
                };
                if last.starts_run {
                    *last = start;
                } else {
                    out.push(start);
                }
            }
            _ => out.push(point),
        }
    }
    if let Some(first) = out.first_mut() {
        first.starts_run = true;
    }
    // A point that starts a run after a gap and is followed by another run start is a
    // lone point of nothing: drop it.
    let mut kept: Vec<DeepPoint> = Vec::with_capacity(out.len());
    for (i, p) in out.iter().enumerate() {
        let alone = p.starts_run && out.get(i + 1).is_none_or(|q| q.starts_run);
        if !alone {
            kept.push(*p);
        }
    }
    kept
}

/// The deep samples of one pixel from its samples' curves (each in depth): each thinned
/// with half the tolerance, their mean thinned with the other half. With `aovs`, each
/// sample's AOV values too (they follow the samples the beauty's curves make).
pub fn pixel_samples(
    curves: &[Vec<DeepPoint>],
    tolerance: f64,
    aovs: Option<PixelAovs>,
    out: &mut DeepPixel,
) {
    let scale = |c: &[DeepPoint]| c.last().map_or(0.0, |p| p.color.max_element().max(0.0));
    // The curves the kept one is made of (each a subset of its ray's points), and it.
    let (thinned, kept) = match curves {
        [] => return,
        [one] => (Vec::new(), simplify(one, tolerance, scale(one))),
        many => {
            let half = 0.5 * tolerance;
            let thinned: Vec<Vec<DeepPoint>> =
                many.iter().map(|c| simplify(c, half, scale(c))).collect();
            let mean = mean_curve(&thinned);
            let kept = simplify(&mean, half, scale(&mean));
            (thinned, kept)
        }
    };
    // One ray: the kept curve is its thinned one.
    let thinned = if thinned.is_empty() {
        std::slice::from_ref(&kept)
    } else {
        thinned.as_slice()
    };
    match aovs.filter(|a| !a.wanted.is_empty() && a.rows.len() == curves.len()) {
        Some(a) => {
            let m = 3 * a.wanted.len();
            // On the same curves as the colour: at every kept point the AOVs add up to
            // the colour as the layers do.
            let mut walk = AovWalk {
                curves: thinned,
                rows: a.rows,
                width: a.width,
                wanted: a.wanted,
                cursors: vec![0; curves.len()],
                done: vec![0.0; m],
                now: vec![0.0; m],
            };
            samples_with(&kept, &mut out.samples, Some((&mut walk, &mut out.aovs)));
        }
        None => samples_with(&kept, &mut out.samples, None),
    }
}

/// Flattens deep samples front to back with "over": `(R, G, B, A)`.
pub fn flatten(samples: &[DeepSample]) -> [f64; 4] {
    let (mut c, mut t) = (DVec3::ZERO, 1.0);
    for s in samples {
        c += t * DVec3::new(s.rgb[0] as f64, s.rgb[1] as f64, s.rgb[2] as f64);
        t *= 1.0 - s.alpha as f64;
    }
    [c.x, c.y, c.z, 1.0 - t]
}

#[cfg(test)]
#[path = "deep_tests.rs"]
mod tests;
