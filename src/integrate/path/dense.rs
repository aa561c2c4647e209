//! Spans too dense to track collision by collision. Delta and ratio tracking take about
//! `σ̄·ℓ` tentative collisions over a span of majorant `σ̄` and length `ℓ`, each a density
//! lookup: at `--sigma-s 1e12` a path would never end, though the transmittance is
//! zero to f64 a hair into the medium. Over a span whose majorant optical depth passes
//! [`DENSE_SPAN`] the tracer uses the density's integral instead (exact per voxel on a
//! grid), so the cost is bounded by the spans crossed, not by the extinction (a free
//! flight first tracks a few collisions, [`too_many`]):
//!
//! - the transmittance toward a light is `e^{−σt·∫ρ}` over the span, exactly;
//! - a free flight picks a channel with probability `q` proportional to the path's
//!   throughput `β` in it, samples its collision with that channel's extinction
//!   (regular tracking: the optical depth to it is exponential, the point found by
//!   bisection on the integral) and weights every channel by one-sample MIS over the
//!   channels (balance heuristic): `σs·e^{−σt·∫ρ} / Σ q_k σt_k e^{−σt_k·∫ρ}` at a
//!   collision, `e^{−σt·∫ρ} / Σ q_k e^{−σt_k·∫ρ}` when it passes the span. That is
//!   unbiased in every channel with weights bounded by `Σβ / β`, and exactly delta
//!   tracking's distribution in a grey medium (weights `σs/σt` and 1).
//!
//! Emission along such a span is gathered with the throughput at its end; with
//! coloured extinction that is approximate inside the span (where the medium is
//! opaque within a fraction of a voxel anyway).

use super::PathTracer;
use crate::accel::IndexRay;
use crate::field::random::SplitMix64;
use glam::DVec3;

/// Majorant optical depth of a span above which it is crossed by its integral (ratio
/// tracking), or the rest of it once a flight has taken [`TRACKED`] tentative
/// collisions in it (delta tracking: where the density is near the majorant a
/// collision comes within a few, cheaper than the bisection's integrals).
pub(super) const DENSE_SPAN: f64 = 256.0;

/// Tentative collisions a flight takes in a dense span before [`too_many`] stops it.
const TRACKED: u32 = 8;

/// Tentative collisions a flight takes in any span before [`too_many`] stops it (where
/// the steps no longer move `t`; a span under [`DENSE_SPAN`] never takes this many).
const TRACKED_AT_MOST: u32 = 1024;

/// Whether a flight that has taken `tries` tentative collisions in a span, with `depth`
/// of majorant optical depth left in it, goes on by the integral.
pub(super) fn too_many(tries: u32, depth: f64) -> bool {
    (tries >= TRACKED && depth > DENSE_SPAN) || tries >= TRACKED_AT_MOST
}

/// Steps at most of each search for a collision (growing the bracket, then narrowing it).
const BISECTIONS: u32 = 64;

/// Per channel `e^{−σt·I}` divided by `Σ q_k w_k e^{−σt_k·I}` (`w` = σt at a collision,
/// 1 for a pass), computed relative to the smallest exponent so nothing underflows;
/// 0 where a channel's own term does (or the sum is 0).
fn mis_weight(sigma_t: DVec3, q: DVec3, w: DVec3, integral: f64) -> DVec3 {
    let expo = |s: f64| if s == 0.0 { 0.0 } else { s * integral };
    let e = DVec3::new(expo(sigma_t.x), expo(sigma_t.y), expo(sigma_t.z));
    let m = (0..3)
        .filter(|&k| q[k] > 0.0 && w[k] > 0.0)
        .map(|k| e[k])
        .fold(f64::INFINITY, f64::min);
    if !m.is_finite() {
        return DVec3::ZERO;
    }
    let rel = DVec3::new((m - e.x).exp(), (m - e.y).exp(), (m - e.z).exp());
    let sum = (q * w * rel).element_sum();
    if sum > 0.0 { rel / sum } else { DVec3::ZERO }
}

impl PathTracer<'_> {
    /// The transmittance over `[t0, t1]` of `ray`, from the density's integral.
    pub(super) fn dense_transmittance(&self, ray: &IndexRay, t0: f64, t1: f64) -> DVec3 {
        let i = self.volume.density.integral(ray, t0, t1).max(0.0);
        let t = |s: f64| if s == 0.0 { 1.0 } else { (-s * i).exp() };
        DVec3::new(t(self.sigma_t.x), t(self.sigma_t.y), t(self.sigma_t.z))
    }

    /// A free flight over the dense span `[t0, t1]` of `ray` (majorant `maj`: the largest
    /// channel's σt times the largest density): the collision's `t` and
    /// the factor the throughput takes there (without `σs`, which the caller takes at
    /// the point, tinted), or `None` when the flight passes the span (the throughput
    /// weighted for that already).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn dense_flight(
        &self,
        ray: &IndexRay,
        t0: f64,
        t1: f64,
        maj: f64,
        beta: &mut DVec3,
        rng: &mut SplitMix64,
        samples: &mut u64,
    ) -> Option<(f64, DVec3)> {
        let density = self.volume.density;
        let total = beta.element_sum();
        if !(total > 0.0) {
            return None;
        }
        let q = *beta / total;
        let c = if self.grey {
            self.sigma_t.x
        } else {
            let u = rng.next_f64();
            let k = if u < q.x {
                0
            } else if u < q.x + q.y {
                1
            } else {
                2
            };
            self.sigma_t[k]
        };
        let mut depth = |t: f64| {
            *samples += 1;
            density.integral(ray, t0, t).max(0.0)
        };
        let whole = depth(t1);
        let target = -(1.0 - rng.next_f64()).ln();
        if !(c * whole > target) {
            *beta *= mis_weight(self.sigma_t, q, DVec3::ONE, whole);
            return None;
        }
        // The first t where c·∫ρ reaches the target (c·∫ρ is non-decreasing in t): a
        // bracket grown from the shortest distance it can be (the majorant bounds ρ, and
        // a step below t's resolution is no step), then regula falsi (Illinois) to 1e-9
        // of the distance (or a few steps of t's resolution).
        let f = |t: f64, depth: &mut dyn FnMut(f64) -> f64| c * depth(t) - target;
        let ulp = (t0.abs().max(t1.abs()) * f64::EPSILON).max(f64::MIN_POSITIVE);
        let mut h = (target * self.sigma_t_max / (c * maj)).max(4.0 * ulp);
        let (mut a, mut fa) = (t0, -target);
        let (mut b, mut fb) = (t1, c * whole - target);
        for _ in 0..BISECTIONS {
            if !(t0 + h < b) {
                break;
            }
            let fh = f(t0 + h, &mut depth);
            if fh > 0.0 {
                (b, fb) = (t0 + h, fh);
                break;
            }
            (a, fa) = (t0 + h, fh);
            h *= 8.0;
        }
        let mut kept = 0i8;
        for _ in 0..BISECTIONS {
            if !(b - a > (1e-9 * (b - t0)).max(4.0 * ulp)) {
                break;
            }
            let mut m = (a * fb - b * fa) / (fb - fa);
            if !(m > a && m < b) {
                m = 0.5 * (a + b);
                if !(m > a && m < b) {
                    break;
                }
            }
            let fm = f(m, &mut depth);
            if fm > 0.0 {
                (b, fb) = (m, fm);
                if kept == -1 {
                    fa *= 0.5;
                }
                kept = -1;
            } else {
                (a, fa) = (m, fm);
                if kept == 1 {
                    fb *= 0.5;
                }
                kept = 1;
            }
        }
        let t = 0.5 * (a + b);
        Some((t, mis_weight(self.sigma_t, q, self.sigma_t, depth(t))))
    }
}
