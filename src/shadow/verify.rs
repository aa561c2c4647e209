//! Measures a baked map against marched shadow rays (exact optical depth) at random
//! points where the density is not zero: the numbers `--dsm-verify` reports.

use super::map::ShadowMap;
use super::march::{ShadowQuadrature, density_integral};
use super::settings::LightGeometry;
use crate::field::Field;
use crate::field::random::SplitMix64;
use glam::DVec3;
use rayon::prelude::*;

/// Transmittance error of a map at random points inside the density.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct VerifyReport {
    pub points: usize,
    /// Largest `|T_map − T_marched|` over points and channels.
    pub max_error: f64,
    pub mean_error: f64,
    /// The error 99 % of the points stay under.
    pub p99_error: f64,
    /// Points whose error exceeds the map's tolerance.
    pub over_tolerance: usize,
}

/// Up to `n` points uniformly in the density's world bounds where the density is not
/// zero (rejection sampling, at most `100·n` tries).
pub fn points_inside(density: &dyn Field, n: usize, seed: u64) -> Vec<DVec3> {
    let (lo, hi) = density.world_bounds();
    if density.active_bounds().is_empty() {
        return Vec::new();
    }
    let mut rng = SplitMix64(seed);
    let mut out = Vec::with_capacity(n);
    for _ in 0..n.saturating_mul(100) {
        if out.len() == n {
            break;
        }
        let p = lo + (hi - lo) * DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64());
        if density.value_at_world(p) > 0.0 {
            out.push(p);
        }
    }
    out
}

/// Compares `map` with exact marched transmittance at `n` random points.
pub fn verify(
    map: &ShadowMap,
    density: &dyn Field,
    light: LightGeometry,
    sigma_t: DVec3,
    tolerance: f64,
    n: usize,
    seed: u64,
) -> VerifyReport {
    let points = points_inside(density, n, seed);
    let mut errors: Vec<f64> = points
        .par_iter()
        .map(|&p| {
            let (dir, dist) = light.toward(p);
            let exact = density_integral(
                density,
                p,
                dir,
                dist,
                ShadowQuadrature::Exact,
                f64::INFINITY,
            );
            let baked = map.density_integral(p);
            let t = |tau: f64| (-sigma_t * tau).exp();
            (t(baked) - t(exact)).abs().max_element()
        })
        .collect();
    errors.sort_by(f64::total_cmp);
    VerifyReport {
        p99_error: errors
            .get((errors.len() * 99) / 100)
            .copied()
            .unwrap_or(0.0),
        over_tolerance: errors.iter().filter(|e| **e > tolerance).count(),
        points: points.len(),
        max_error: errors.iter().copied().fold(0.0, f64::max),
        mean_error: if errors.is_empty() {
            0.0
        } else {
            errors.iter().sum::<f64>() / errors.len() as f64
        },
    }
}
