//! Deep samples: what a camera ray passes through, kept in depth instead of summed.
//!
//! With `--deep` on, the march records a [`DeepTrace`] per camera ray: at the end of
//! every segment that holds anything, the ray's opacity so far (`A`, the same mean over
//! the channels as the flat alpha) and premultiplied colour so far (`C`). Empty space
//! between such segments is a gap. The pixel loop turns the traces of a pixel's rays
//! into deep samples ([`pixel_samples`]): the mean of the rays' curves, thinned by
//! [`simplify`], each kept interval one sample `(Z, ZBack, colour, alpha)` with
//! `alpha = 1 − T₁/T₀` and `colour = (C₁ − C₀)/T₀` (`T = 1 − A`). Flattening the samples
//! front to back with "over" gives back the curves' last point, the flat pixel, exactly:
//! every kept point is a point of the mean curve.

use glam::DVec3;

pub use super::deep_aovs::{
    AOV_EMISSION, AOV_INDIRECT, AOV_LIGHTS, DeepAov, aov_width, select_aovs,
};

/// One point of a ray's or a pixel's cumulative curves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeepPoint {
    /// Ray parameter (in a [`DeepTrace`]) or camera-space depth (in a curve).
    pub depth: f64,
    /// Opacity from the camera to here.
    pub alpha: f64,
    /// Premultiplied colour from the camera to here.
    pub color: DVec3,
    /// The first point of a run: empty space lies between it and the point before.
    pub starts_run: bool,
    /// Its place in its ray's trace (where its AOV values are); 0 in a mean of curves.
    pub row: u32,
}

/// The record of one camera ray: runs of points, each run contiguous, gaps between.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DeepTrace {
    pub points: Vec<DeepPoint>,
    /// With deep AOVs: per point, `aov_width` cumulative premultiplied values (as
    /// `color` is), laid out as [`AOV_EMISSION`], [`AOV_INDIRECT`], [`AOV_LIGHTS`] say.
    pub aovs: Vec<f64>,
    /// Values per point in `aovs` (0: no AOVs recorded).
    pub aov_width: usize,
}

impl DeepTrace {
    pub fn clear(&mut self) {
        self.points.clear();
        self.aovs.clear();
    }

    /// Records the segment `[a, b]` of the ray that took the curves from `(a0, c0)` to
    /// `(a1, c1)`; a segment that changed neither is left out (a gap). Returns the
    /// points added (0, 1, or 2 where the segment starts a run): with AOVs, the caller
    /// gives the last one's with [`DeepTrace::aovs_now`].
    #[inline]
    pub fn segment(&mut self, a: f64, b: f64, a0: f64, c0: DVec3, a1: f64, c1: DVec3) -> usize {
        if a1 == a0 && c1 == c0 {
            return 0;
        }
        let joined = self.points.last().is_some_and(|p| p.depth == a);
        if !joined {
            self.points.push(DeepPoint {
                depth: a,
                alpha: a0,
                color: c0,
                starts_run: true,
                row: self.points.len() as u32,
            });
        }
        self.points.push(DeepPoint {
            depth: b,
            alpha: a1,
            color: c1,
            starts_run: false,
            row: self.points.len() as u32,
        });
        if joined { 1 } else { 2 }
    }

    /// After [`DeepTrace::segment`] added `added` points: the AOV values of a run's first
    /// point (the last point's, zero before any), and room for the segment's end, which
    /// the caller fills (the returned slice, zeroed). Nothing without AOVs.
    #[inline]
    pub fn aovs_now(&mut self, added: usize) -> &mut [f64] {
        let w = self.aov_width;
        if w == 0 || added == 0 {
            return &mut [];
        }
        let n = self.aovs.len();
        if added == 2 {
            if n >= w {
                self.aovs.extend_from_within(n - w..n);
            } else {
                self.aovs.resize(n + w, 0.0);
            }
        }
        let n = self.aovs.len();
        self.aovs.resize(n + w, 0.0);
        &mut self.aovs[n..]
    }

    /// After [`DeepTrace::segment`] added `added` points that changed no AOV (an opaque
    /// floor, not a layer): the last point's values for them.
    pub fn hold_aovs(&mut self, added: usize) {
        let w = self.aov_width;
        let n = self.aovs.len();
        if w == 0 || added == 0 {
            return;
        }
        if n >= w {
            for _ in 0..added {
                self.aovs.extend_from_within(n - w..n);
            }
        } else {
            self.aovs.resize(n + added * w, 0.0);
        }
    }

    /// The curves so far (zero before the first point).
    pub fn last(&self) -> (f64, DVec3) {
        self.points
            .last()
            .map_or((0.0, DVec3::ZERO), |p| (p.alpha, p.color))
    }

    /// The trace with ray parameters turned into depths (`t × rate`).
    pub fn to_depth(&self, rate: f64) -> Vec<DeepPoint> {
        let mut out = Vec::with_capacity(self.points.len());
        self.to_depth_into(rate, &mut out);
        out
    }

    /// [`DeepTrace::to_depth`] into `out` (cleared first), reusing its room.
    pub fn to_depth_into(&self, rate: f64, out: &mut Vec<DeepPoint>) {
        out.clear();
        out.extend(self.points.iter().map(|p| DeepPoint {
            depth: p.depth * rate,
            ..*p
        }));
    }
}

/// One deep sample as written: camera-space depths and premultiplied colour and alpha.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DeepSample {
    pub z: f32,
    pub z_back: f32,
    pub rgb: [f32; 3],
    pub alpha: f32,
}

/// How far apart, as a fraction of a split point's distance from the sample's front, the
/// depth at which a merged sample reaches that point's opacity may be from the point.
pub const DEPTH_FRACTION: f64 = 0.5;

/// The points of `curve` (one or more runs) kept when segments are merged: the first and
/// last of each run, and as few others as keep every dropped point within `tolerance`
/// of the merged sample split there by OpenEXR's rule (`1 − T(d) = 1 − T₀ (T₁/T₀)^f`,
/// colour in proportion to opacity): opacity within `tolerance`, colour within
/// `tolerance × color_scale`, and, for a point whose opacity is more than `tolerance`
/// past the front's, the depth at which the merged sample reaches that opacity within
/// [`DEPTH_FRACTION`] of the point's distance from its front.
/// Greedy from the front, O(points): each dropped point narrows the range of slopes
/// (of `ln T` against depth, and of colour against opacity) the merged sample may have.
pub fn simplify(curve: &[DeepPoint], tolerance: f64, color_scale: f64) -> Vec<DeepPoint> {
    let mut out = Vec::new();
    let mut start = 0;
    for end in 1..=curve.len() {
        if end == curve.len() || curve[end].starts_run {
            simplify_run(&curve[start..end], tolerance, color_scale, &mut out);
            start = end;
        }
    }
    out
}

/// The slopes a merged sample from `s` may have, narrowed by each dropped point.
struct Cone {
    s: DeepPoint,
    ln_t: f64,
    slope: (f64, f64),
    color: [(f64, f64); 3],
    /// A dropped point had no opacity past `s` and a colour out of tolerance: nothing
    /// fits (a sample without opacity cannot place colour in depth).
    closed: bool,
}

fn ln_t(alpha: f64) -> f64 {
    (1.0 - alpha).max(0.0).ln()
}

impl Cone {
    /// The cone from `s`, whose `ln T` is `ln_t_s`.
    fn new(s: DeepPoint, ln_t_s: f64) -> Self {
        Cone {
            s,
            ln_t: ln_t_s,
            slope: (f64::NEG_INFINITY, f64::INFINITY),
            color: [(f64::NEG_INFINITY, f64::INFINITY); 3],
            closed: false,
        }
    }

    /// Narrows the cone by point `k` (its `ln T` is `ln_t_k`), dropped inside the merged
    /// sample.
    fn drop_point(&mut self, k: &DeepPoint, ln_t_k: f64, tol: f64, ctol: f64) {
        let dz = k.depth - self.s.depth;
        if !(dz > 0.0) {
            self.closed = true;
            return;
        }
        let t = 1.0 - k.alpha;
        // Opacity: T at k within tol.
        let lo = if t - tol <= 0.0 {
            f64::NEG_INFINITY
        } else {
            (t - tol).ln()
        };
        let hi = if t + tol >= 1.0 { 0.0 } else { (t + tol).ln() };
        let mut smin = (lo - self.ln_t) / dz;
        let mut smax = (hi - self.ln_t) / dz;
        // Depth: the merged sample reaches ln T_k at s + (ΔL / slope); within
        // DEPTH_FRACTION × dz of k, where k's opacity differs from the front's by more
        // than the tolerance (where it does not, no depth sees the merged opacity off by
        // more than the tolerance, wherever it is placed).
        let dl = ln_t_k - self.ln_t;
        if dl.is_finite() && k.alpha - self.s.alpha > tol {
            let near = dz * (1.0 - DEPTH_FRACTION);
            let far = dz * (1.0 + DEPTH_FRACTION);
            smax = smax.min(dl / far);
            if near > 0.0 {
                smin = smin.max(dl / near);
            }
        }
        self.slope = (self.slope.0.max(smin), self.slope.1.min(smax));
        let da = k.alpha - self.s.alpha;
        let dcs = k.color - self.s.color;
        // A grey change (a grey medium under white light): one channel's bounds serve all.
        let channels = if is_grey(dcs) { 1 } else { 3 };
        for c in 0..channels {
            let dc = dcs[c];
            if da > 0.0 {
                let (a, b) = ((dc - ctol) / da, (dc + ctol) / da);
                let narrowed = if channels == 1 { 0..3 } else { c..c + 1 };
                for bound in &mut self.color[narrowed] {
                    *bound = (bound.0.max(a), bound.1.min(b));
                }
            } else if dc.abs() > ctol {
                self.closed = true;
            }
        }
    }

    /// Whether the merged sample from `s` to `j` (its `ln T` is `ln_t_j`) keeps every
    /// dropped point in tolerance.
    fn fits(&self, j: &DeepPoint, ln_t_j: f64) -> bool {
        let dz = j.depth - self.s.depth;
        if self.closed || !(dz > 0.0) {
            return false;
        }
        let slope = (ln_t_j - self.ln_t) / dz;
        let slope_ok = if slope == f64::NEG_INFINITY {
            self.slope.0 == f64::NEG_INFINITY
        } else {
            slope >= self.slope.0 && slope <= self.slope.1
        };
        if !slope_ok {
            return false;
        }
        let da = j.alpha - self.s.alpha;
        if !(da > 0.0) {
            // No opacity: every dropped point's colour was within tolerance (else the
            // cone is closed); the end's must be too.
            return self.color.iter().all(|(lo, hi)| lo <= hi)
                && (0..3).all(|c| (j.color[c] - self.s.color[c]).abs() == 0.0);
        }
        let dcs = j.color - self.s.color;
        if is_grey(dcs) {
            let sc = dcs.x / da;
            return self.color.iter().all(|(lo, hi)| sc >= *lo && sc <= *hi);
        }
        (0..3).all(|c| {
            let sc = dcs[c] / da;
            sc >= self.color[c].0 && sc <= self.color[c].1
        })
    }
}

/// All three channels the same.
#[inline]
fn is_grey(v: DVec3) -> bool {
    v.x == v.y && v.y == v.z
}

fn simplify_run(run: &[DeepPoint], tol: f64, color_scale: f64, out: &mut Vec<DeepPoint>) {
    let Some(first) = run.first() else {
        return;
    };
    let ctol = tol * color_scale;
    out.push(*first);
    // One logarithm a point: its ln T serves its test, its narrowing and its cone.
    let mut ln_before = ln_t(first.alpha);
    let mut cone = Cone::new(*first, ln_before);
    let mut s = 0;
    for j in 1..run.len() {
        let ln_j = ln_t(run[j].alpha);
        if j > s + 1 && !cone.fits(&run[j], ln_j) {
            s = j - 1;
            out.push(run[s]);
            cone = Cone::new(run[s], ln_before);
        }
        if j + 1 < run.len() {
            cone.drop_point(&run[j], ln_j, tol, ctol);
        }
        ln_before = ln_j;
    }
    if run.len() > 1 {
        out.push(run[run.len() - 1]);
    }
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
