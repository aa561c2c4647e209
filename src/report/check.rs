//! What every stability case checks: no NaN or Inf, `0 ≤ α ≤ 1`, radiance under its
//! analytic bound, and the case's own error against its closed form (or against the
//! image it must equal).

use crate::integrate::RayResult;
use crate::output::{Frame, is_depth_channel, names};
use crate::scene::light::{Light, LightKind};
use crate::scene::plan::RenderPlan;
use serde::Serialize;

/// One case's verdict, as printed and written to `stability.json`.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct CaseResult {
    pub name: String,
    /// What the case does, in a line.
    pub what: String,
    pub pass: bool,
    /// Rays (or pixels) checked.
    pub samples: u64,
    /// NaN or ±Inf values found (depth's +inf "never opaque" excepted).
    pub nan_inf: u64,
    pub alpha_min: f64,
    pub alpha_max: f64,
    pub radiance_max: f64,
    /// Analytic upper bound on radiance for the case.
    pub radiance_bound: f64,
    /// Largest error against the closed form (relative unless `detail` says otherwise).
    pub max_error: f64,
    pub tolerance: f64,
    /// Why it failed, or what was measured.
    pub detail: String,
}

/// Accumulates the checks of one case.
pub struct Check {
    samples: u64,
    nan_inf: u64,
    alpha_min: f64,
    alpha_max: f64,
    radiance_max: f64,
    bound: f64,
    max_error: f64,
    tolerance: f64,
    failures: Vec<String>,
    notes: Vec<String>,
}

impl Check {
    /// A case whose radiance must stay under `bound` and whose errors under `tolerance`.
    pub fn new(bound: f64, tolerance: f64) -> Self {
        Check {
            samples: 0,
            nan_inf: 0,
            alpha_min: f64::INFINITY,
            alpha_max: f64::NEG_INFINITY,
            radiance_max: 0.0,
            bound,
            max_error: 0.0,
            tolerance,
            failures: Vec::new(),
            notes: Vec::new(),
        }
    }

    fn values(&mut self, alpha: f64, radiance: [f64; 3], others: &[f64]) {
        self.samples += 1;
        let bad = radiance
            .iter()
            .chain(others)
            .chain([alpha].iter())
            .filter(|v| !v.is_finite())
            .count();
        self.nan_inf += bad as u64;
        if alpha.is_finite() {
            self.alpha_min = self.alpha_min.min(alpha);
            self.alpha_max = self.alpha_max.max(alpha);
        }
        for r in radiance {
            if r.is_finite() {
                self.radiance_max = self.radiance_max.max(r);
                if r < 0.0 {
                    self.fail(format!("negative radiance {r}"));
                }
            }
        }
    }

    /// A marched ray: its opacity, radiance (emission + scatter) and transmittance.
    pub fn ray(&mut self, r: &RayResult) {
        let l = r.emission + r.scatter;
        let t = r.transmittance;
        self.values(r.alpha(), l.to_array(), &[t.x, t.y, t.z]);
        if t.min_element() < 0.0 || t.max_element() > 1.0 {
            self.fail(format!("transmittance {t} outside [0, 1]"));
        }
    }

    /// A rendered image: every pixel of R, G, B, A and every other channel but depth.
    pub fn frame(&mut self, f: &Frame) {
        let get = |n: &str| f.channel(n).unwrap_or(&[]);
        let (r, g, b, a) = (get(names::R), get(names::G), get(names::B), get(names::A));
        for i in 0..f.pixel_count() {
            let at = |c: &[f32]| c.get(i).map_or(0.0, |v| *v as f64);
            self.values(at(a), [at(r), at(g), at(b)], &[]);
        }
        for c in f.channels() {
            if !is_depth_channel(c.name())
                && ![names::R, names::G, names::B, names::A].contains(&c.name())
            {
                self.nan_inf += c.data().iter().filter(|v| !v.is_finite()).count() as u64;
            }
        }
    }

    /// `got` against `want`, relatively (absolutely where `want` is 0).
    pub fn compare(&mut self, what: &str, got: f64, want: f64) {
        let err = if want == 0.0 {
            got.abs()
        } else {
            (got - want).abs() / want.abs()
        };
        let err = if err.is_nan() { f64::INFINITY } else { err };
        if err > self.max_error {
            self.max_error = err;
        }
        if !(err <= self.tolerance) {
            self.fail(format!("{what}: {got:e} vs {want:e}"));
        }
    }

    /// Two images: the largest difference over R, G, B, A, relative to the largest value
    /// of `want` (at least 1).
    pub fn compare_frames(&mut self, what: &str, got: &Frame, want: &Frame) {
        let mut scale: f64 = 1.0;
        let mut diff: f64 = 0.0;
        for n in [names::R, names::G, names::B, names::A] {
            match (got.channel(n), want.channel(n)) {
                (Some(x), Some(y)) if x.len() == y.len() => {
                    for (a, b) in x.iter().zip(y) {
                        scale = scale.max(b.abs() as f64);
                        let d = (*a as f64 - *b as f64).abs();
                        diff = if d.is_nan() {
                            f64::INFINITY
                        } else {
                            diff.max(d)
                        };
                    }
                }
                _ => self.fail(format!("{what}: channel {n} missing or of another size")),
            }
        }
        let err = diff / scale;
        self.max_error = self.max_error.max(err);
        if !(err <= self.tolerance) {
            self.fail(format!("{what}: images differ by {err:e}"));
        }
    }

    pub fn fail(&mut self, why: String) {
        if self.failures.len() < 3 {
            self.failures.push(why);
        }
    }

    pub fn note(&mut self, what: String) {
        self.notes.push(what);
    }

    pub fn finish(self, name: &str, what: &str) -> CaseResult {
        let mut failures = self.failures;
        if self.nan_inf > 0 {
            failures.push(format!("{} NaN/Inf values", self.nan_inf));
        }
        if self.samples > 0 && !(self.alpha_min >= 0.0 && self.alpha_max <= 1.0) {
            failures.push(format!("alpha in [{}, {}]", self.alpha_min, self.alpha_max));
        }
        if !(self.radiance_max <= self.bound * (1.0 + 1e-9)) {
            failures.push(format!(
                "radiance {:e} above its bound {:e}",
                self.radiance_max, self.bound
            ));
        }
        let pass = failures.is_empty();
        let detail = if pass {
            self.notes.join("; ")
        } else {
            failures.join("; ")
        };
        CaseResult {
            name: name.into(),
            what: what.into(),
            pass,
            samples: self.samples,
            nan_inf: self.nan_inf,
            alpha_min: if self.samples > 0 {
                self.alpha_min
            } else {
                0.0
            },
            alpha_max: if self.samples > 0 {
                self.alpha_max
            } else {
                0.0
            },
            radiance_max: self.radiance_max,
            radiance_bound: self.bound,
            max_error: self.max_error,
            tolerance: self.tolerance,
            detail,
        }
    }
}

/// Upper bound on single-scattered radiance from suns: Σ E·(σs/σt)·p_max per channel
/// (with `(1 − T) ≤ 1`), +∞ with a point light (its irradiance has no bound inside the
/// volume).
pub fn scatter_bound(lights: &[Light], sigma_a: f64, sigma_s: f64, g: f64) -> f64 {
    let albedo = if sigma_a + sigma_s > 0.0 {
        sigma_s / (sigma_a + sigma_s)
    } else {
        0.0
    };
    let p_max = crate::integrate::phase::hg(1.0, g.abs());
    lights
        .iter()
        .map(|l| match l.kind {
            LightKind::Sun { .. } => l.color.max_element() * l.intensity * albedo * p_max,
            LightKind::Point { .. } => f64::INFINITY,
        })
        .sum()
}

/// [`scatter_bound`] for a plan with grey σ.
pub fn plan_scatter_bound(plan: &RenderPlan) -> f64 {
    scatter_bound(
        &plan.lights,
        plan.medium.sigma_a.min_element(),
        plan.medium.sigma_s.max_element(),
        plan.medium.g,
    )
}
