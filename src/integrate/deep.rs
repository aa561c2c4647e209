//! Deep samples: what a camera ray passes through, kept in depth instead of summed.
//!
//! With `--deep` on, the march records a [`DeepTrace`] per camera ray: at the end of
//! every segment that holds anything, the ray's opacity so far (`A`, the same mean over
//! the channels as the flat alpha) and premultiplied colour so far (`C`). Empty space
//! between such segments is a gap. The pixel loop turns the traces of a pixel's rays
//! into deep samples (`integrate::deep_pixel`'s `pixel_samples`): the mean of the
//! rays' curves, thinned by [`simplify`] (here), each kept interval one sample
//! `(Z, ZBack, colour, alpha)` with `alpha = 1 − T₁/T₀` and `colour = (C₁ − C₀)/T₀`
//! (`T = 1 − A`). Flattening the samples front to back with "over" gives back the
//! curves' last point, the flat pixel, exactly: every kept point is a point of the mean
//! curve.

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
    // Room for what a ray through a cloud keeps (a few more than the samples it makes),
    // so the list is not grown point by point.
    let mut out = Vec::with_capacity(curve.len().min(32));
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

/// `ln(t − tol)` and `ln(t + tol)` (the latter at most 0) from `ln_t = ln t`. Where
/// `tol ≤ t/4`, without a logarithm: `ln(1 ± x) = 2 atanh(±x/(2 ± x))`, its series to the
/// ninth power (the first term left out is under 1e-10 of the bound), every term of one
/// sign, so the bounds come out a little inside the true ones, never outside.
#[inline]
fn ln_bounds(t: f64, ln_t: f64, tol: f64) -> (f64, f64) {
    let hi_exact = || if t + tol >= 1.0 { 0.0 } else { (t + tol).ln() };
    if !(4.0 * tol <= t) || !ln_t.is_finite() {
        let lo = if t - tol <= 0.0 {
            f64::NEG_INFINITY
        } else {
            (t - tol).ln()
        };
        return (lo, hi_exact());
    }
    // u± = ±tol/(2t ± tol), over one division.
    let (p, m) = (2.0 * t + tol, 2.0 * t - tol);
    let r = tol / (p * m);
    let (u_hi, u_lo) = (m * r, -p * r);
    let atanh2 = |u: f64| {
        let u2 = u * u;
        let poly = (((u2 * (1.0 / 9.0) + 1.0 / 7.0) * u2 + 1.0 / 5.0) * u2 + 1.0 / 3.0) * u2 + 1.0;
        2.0 * u * poly
    };
    let hi = if t + tol >= 1.0 {
        0.0
    } else {
        (ln_t + atanh2(u_hi)).min(0.0)
    };
    (ln_t + atanh2(u_lo), hi)
}

/// A point `k` seen from a cone's front `s`: depth and opacity past it (and their
/// reciprocals), colour past it, `ln T` past it.
struct Past {
    dz: f64,
    inv_dz: f64,
    da: f64,
    inv_da: f64,
    dc: DVec3,
    dl: f64,
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

    /// Point `k` (its `ln T` is `ln_t_k`) from the front: the one division of depth and
    /// of opacity that [`Cone::fits`] and [`Cone::drop_point`] share.
    #[inline]
    fn past(&self, k: &DeepPoint, ln_t_k: f64) -> Past {
        let dz = k.depth - self.s.depth;
        let da = k.alpha - self.s.alpha;
        Past {
            dz,
            inv_dz: 1.0 / dz,
            da,
            inv_da: 1.0 / da,
            dc: k.color - self.s.color,
            dl: ln_t_k - self.ln_t,
        }
    }

    /// Narrows the cone by point `k` (seen from the front as `p`), dropped inside the
    /// merged sample.
    #[inline]
    fn drop_point(&mut self, k: &DeepPoint, ln_t_k: f64, p: &Past, tol: f64, ctol: f64) {
        if !(p.dz > 0.0) {
            self.closed = true;
            return;
        }
        // Opacity: T at k within tol.
        let (lo, hi) = ln_bounds(1.0 - k.alpha, ln_t_k, tol);
        let mut smin = (lo - self.ln_t) * p.inv_dz;
        let mut smax = (hi - self.ln_t) * p.inv_dz;
        // Depth: the merged sample reaches ln T_k at s + (ΔL / slope); within
        // DEPTH_FRACTION × dz of k, where k's opacity differs from the front's by more
        // than the tolerance (where it does not, no depth sees the merged opacity off by
        // more than the tolerance, wherever it is placed).
        if p.dl.is_finite() && p.da > tol {
            let per_dz = p.dl * p.inv_dz;
            smax = smax.min(per_dz * (1.0 / (1.0 + DEPTH_FRACTION)));
            if DEPTH_FRACTION < 1.0 {
                smin = smin.max(per_dz * (1.0 / (1.0 - DEPTH_FRACTION)));
            }
        }
        self.slope = (self.slope.0.max(smin), self.slope.1.min(smax));
        // A grey change (a grey medium under white light): one channel's bounds serve all.
        let channels = if is_grey(p.dc) { 1 } else { 3 };
        for c in 0..channels {
            let dc = p.dc[c];
            if p.da > 0.0 {
                let (a, b) = ((dc - ctol) * p.inv_da, (dc + ctol) * p.inv_da);
                let narrowed = if channels == 1 { 0..3 } else { c..c + 1 };
                for bound in &mut self.color[narrowed] {
                    *bound = (bound.0.max(a), bound.1.min(b));
                }
            } else if dc.abs() > ctol {
                self.closed = true;
            }
        }
    }

    /// Whether the merged sample from `s` to `j` (seen from the front as `p`) keeps every
    /// dropped point in tolerance.
    #[inline]
    fn fits(&self, j: &DeepPoint, p: &Past) -> bool {
        if self.closed || !(p.dz > 0.0) {
            return false;
        }
        let slope = p.dl * p.inv_dz;
        let slope_ok = if slope == f64::NEG_INFINITY {
            self.slope.0 == f64::NEG_INFINITY
        } else {
            slope >= self.slope.0 && slope <= self.slope.1
        };
        if !slope_ok {
            return false;
        }
        if !(p.da > 0.0) {
            // No opacity: every dropped point's colour was within tolerance (else the
            // cone is closed); the end's must be too.
            return self.color.iter().all(|(lo, hi)| lo <= hi)
                && (0..3).all(|c| (j.color[c] - self.s.color[c]).abs() == 0.0);
        }
        if is_grey(p.dc) {
            let sc = p.dc.x * p.inv_da;
            return self.color.iter().all(|(lo, hi)| sc >= *lo && sc <= *hi);
        }
        (0..3).all(|c| {
            let sc = p.dc[c] * p.inv_da;
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
        let mut past = cone.past(&run[j], ln_j);
        if j > s + 1 && !cone.fits(&run[j], &past) {
            s = j - 1;
            out.push(run[s]);
            cone = Cone::new(run[s], ln_before);
            past = cone.past(&run[j], ln_j);
        }
        if j + 1 < run.len() {
            cone.drop_point(&run[j], ln_j, &past, tol, ctol);
        }
        ln_before = ln_j;
    }
    if run.len() > 1 {
        out.push(run[run.len() - 1]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_opacity_bounds_without_logarithms_are_the_logarithms_or_just_inside() {
        for tol in [0.0, 0.002, 0.005, 0.01, 0.05] {
            for k in 0..=2000 {
                let t = k as f64 / 2000.0;
                let (lo, hi) = ln_bounds(t, t.ln(), tol);
                let lo_exact = if t - tol <= 0.0 {
                    f64::NEG_INFINITY
                } else {
                    (t - tol).ln()
                };
                let hi_exact = if t + tol >= 1.0 { 0.0 } else { (t + tol).ln() };
                let near = |a: f64, b: f64| a == b || (a - b).abs() <= 1e-10;
                assert!(
                    near(lo, lo_exact) && lo >= lo_exact - 1e-15,
                    "{t} {tol}: lo {lo} against {lo_exact}"
                );
                assert!(
                    near(hi, hi_exact) && hi <= hi_exact + 1e-15,
                    "{t} {tol}: hi {hi} against {hi_exact}"
                );
            }
        }
    }
}
