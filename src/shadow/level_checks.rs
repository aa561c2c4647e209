//! How the bake judges a brick's level: its reconstruction against the next level's
//! samples, in transmittance per channel ([`coarse_error`]), and the bound on what samples
//! coarser than a voxel could step over, from the density's range over the brick and the
//! bricks above it toward the light ([`unresolved_bounds`]).

use super::brick::{DepthBlend, blend_across};
use super::chart::{Chart, ChartKind};
use super::map::{
    BRICK, BrickForm, BrickSamples, VOXEL_LEVEL, linear_rounding_error, side, spacing, trilinear,
};
use crate::field::{Field, IndexBox, ValueRange};
use glam::{DVec3, IVec3};

/// What the bricks above a brick (toward the light) say about `∫ρ ds` down to it.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Upstream {
    /// `Σ min ρ · L` over them: a lower bound on `∫ρ ds` to any point of the brick.
    pub(super) depth: f64,
    /// `Σ (max ρ − min ρ) · L` over them: a bound on how much `∫ρ ds` to the brick's top
    /// face differs between any two of its columns.
    pub(super) variation: f64,
}

/// The distinct extinction coefficients of the channels.
pub(super) fn channels(sigma_t: DVec3) -> Vec<f64> {
    let mut v: Vec<f64> = sigma_t
        .to_array()
        .into_iter()
        .filter(|s| *s > 0.0)
        .collect();
    v.sort_by(f64::total_cmp);
    v.dedup();
    v
}

/// Largest transmittance error of reconstructing `fine` (level ℓ+1 samples) from
/// `coarse` (its even-index samples, level ℓ) as the map would in `form` (Hermite:
/// [`super::map::reconstruct`]; Linear: trilinear τ, plus its 16-bit rounding).
pub(super) fn coarse_error(
    fine: &BrickSamples,
    coarse: &BrickSamples,
    level_fine: u8,
    chart: &Chart,
    sigmas: &[f64],
    form: BrickForm,
) -> f64 {
    let m = side(level_fine);
    let mc = side(level_fine - 1);
    let h = spacing(level_fine - 1);
    let planes = &coarse.planes();
    // The coarse cell holding fine index i, and the place in it (0, ½ or 1).
    let cell = |i: usize| (i / 2).min(mc - 2);
    let frac = |i: usize| (i as f64 - 2.0 * cell(i) as f64) / 2.0;
    // Hermite: each coarse column's blend along depth at each fine depth, made once for
    // the fine samples that share it (each cell's four are read by up to 27), exactly as
    // `reconstruct` makes them. Indexed by (coarse y, coarse x, fine k).
    let columns: Vec<[f64; 4]> = if form == BrickForm::Linear {
        Vec::new()
    } else {
        let depths: Vec<DepthBlend> = (0..m)
            .map(|k| DepthBlend::new(frac(k), h, chart.unit))
            .collect();
        (0..mc * mc)
            .flat_map(|xy| {
                depths
                    .iter()
                    .enumerate()
                    .map(move |(k, depth)| depth.column(planes, xy + mc * mc * cell(k), mc * mc))
            })
            .collect()
    };
    let column = |x: usize, y: usize, k: usize| columns[(x + mc * y) * m + k];
    let mut worst: f64 = if form == BrickForm::Linear {
        linear_rounding_error(&coarse.tau, sigmas)
    } else {
        0.0
    };
    let rounding = worst;
    let steepest = sigmas.iter().copied().fold(0.0, f64::max);
    for ([i, j, k], at) in checked_samples(fine, level_fine) {
        let (c, f) = (
            [cell(i), cell(j), cell(k)],
            DVec3::new(frac(i), frac(j), frac(k)),
        );
        let got = match form {
            BrickForm::Linear => {
                let base = c[0] + mc * (c[1] + mc * c[2]);
                trilinear(|d| coarse.tau[base + d] as f64, mc, f)
            }
            _ => blend_across(
                [
                    column(c[0], c[1], k),
                    column(c[0] + 1, c[1], k),
                    column(c[0], c[1] + 1, k),
                    column(c[0] + 1, c[1] + 1, k),
                ],
                f.x,
                f.y,
                chart.lateral,
            ),
        };
        let exact = fine.tau[at] as f64;
        // |e^{−σa} − e^{−σb}| ≤ σ·|a − b| where a, b ≥ 0: a sample that bound
        // puts under the worst so far cannot raise it, and needs no exp.
        if got.min(exact) >= 0.0 && steepest * (got - exact).abs() + rounding <= worst {
            continue;
        }
        for &s in sigmas {
            worst = worst.max(((-s * got).exp() - (-s * exact).exp()).abs() + rounding);
        }
    }
    worst
}

/// The fine samples (level `level_fine`) the check compares, as their place `[i, j, k]`
/// and index: not the coarse level's own samples and, at voxel spacing and finer, only
/// where there is density or on the bottom face (points downstream of the brick read
/// it): nothing else looks the map up. (Coarser samples could step over density: all
/// count.)
fn checked_samples(
    fine: &BrickSamples,
    level_fine: u8,
) -> impl Iterator<Item = ([usize; 3], usize)> + '_ {
    let m = side(level_fine);
    let places = (0..m).flat_map(move |k| (0..m).flat_map(move |j| (0..m).map(move |i| [i, j, k])));
    places.zip(0..).filter(move |&([i, j, k], at)| {
        let coarse = i % 2 == 0 && j % 2 == 0 && k % 2 == 0;
        let unread = level_fine >= VOXEL_LEVEL && k + 1 < m && fine.rho[at] <= 0.0;
        !(coarse || unread)
    })
}

/// The even-index samples of `fine`: the same brick one level coarser.
pub(super) fn coarsen(fine: &BrickSamples, level_fine: u8) -> BrickSamples {
    let m = side(level_fine);
    let mc = side(level_fine - 1);
    let mut out = BrickSamples::with_capacity(mc * mc * mc);
    for k in 0..mc {
        for j in 0..mc {
            for i in 0..mc {
                out.push_sample(fine, 2 * i + m * (2 * j + m * 2 * k));
            }
        }
    }
    out
}

/// The density's range over the world region of brick `key` of `chart`, from the
/// field's hierarchy (a bound, not a sample).
pub(super) fn brick_range(density: &dyn Field, chart: &Chart, key: IVec3) -> ValueRange {
    // A parallel chart is affine: its corners bound it. A perspective one has spherical
    // ends and diverging columns, so points across its faces too, and a voxel of margin.
    let (per_axis, margin) = match chart.kind {
        ChartKind::Parallel { .. } => (2, 1.0),
        ChartKind::Perspective { .. } => (5, 2.0),
    };
    let tr = density.transform();
    let base = key.as_dvec3() * BRICK as f64;
    let step = BRICK as f64 / (per_axis - 1) as f64;
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for k in 0..per_axis {
        for j in 0..per_axis {
            for i in 0..per_axis {
                let q = base + DVec3::new(i as f64, j as f64, k as f64) * step;
                let p = tr.world_to_index(chart.to_world(q));
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return ValueRange::EMPTY;
    }
    let m = DVec3::splat(margin);
    density.range_over(&IndexBox::new((lo - m).as_vec3(), (hi + m).as_vec3()))
}

/// Per brick of `keys`: a bound
/// on the transmittance error the map could make there from density its samples do not
/// see. Along any column, optical depth down to a point in the brick varies with the
/// point by at most `σt · Σ (max ρ − min ρ) · L` over this brick and those above it (L
/// the length of a column in a brick), and transmittance there is at most `e^{−σt ·
/// Σ min ρ · L}` over the bricks above. Their product, doubled for the blend's
/// overshoot, bounds what samples coarser than the density's features can miss.
///
/// Also per brick, [`Upstream`]: what the bricks above it say about `∫ρ ds` down to it.
pub(super) fn unresolved_bounds(
    density: &dyn Field,
    chart: &Chart,
    keys: &[IVec3],
    sigmas: &[f64],
) -> Vec<(f64, Upstream)> {
    let (Some(&s_min), Some(&s_max)) = (sigmas.first(), sigmas.last()) else {
        return vec![(0.0, Upstream::default()); keys.len()];
    };
    let length = BRICK as f64 * chart.unit;
    // Stack by stack, from the light down.
    let mut order: Vec<usize> = (0..keys.len()).collect();
    order.sort_by_key(|&i| (keys[i].x, keys[i].y, keys[i].z));
    let mut out = vec![(0.0, Upstream::default()); keys.len()];
    let mut stack = None;
    let (mut variation, mut depth_below) = (0.0, 0.0);
    for i in order {
        let key = keys[i];
        if stack != Some((key.x, key.y)) {
            stack = Some((key.x, key.y));
            (variation, depth_below) = (0.0, 0.0);
        }
        let r = brick_range(density, chart, key);
        let (min, max) = if r.min <= r.max {
            (f64::from(r.min).max(0.0), f64::from(r.max).max(0.0))
        } else {
            (0.0, 0.0)
        };
        let above = Upstream {
            depth: depth_below,
            variation,
        };
        variation += (max - min) * length;
        out[i] = (
            2.0 * s_max * variation * (-s_min * depth_below).exp(),
            above,
        );
        depth_below += min * length;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shadow::chart::LateralBlend;
    use crate::shadow::map::reconstruct;

    /// `coarse_error` as its definition reads: every fine sample reconstructed by
    /// `reconstruct` from the coarse samples, the largest transmittance difference kept.
    fn coarse_error_by_reconstruct(
        fine: &BrickSamples,
        coarse: &BrickSamples,
        level_fine: u8,
        chart: &Chart,
        sigmas: &[f64],
    ) -> f64 {
        let mc = side(level_fine - 1);
        let cell = |i: usize| (i / 2).min(mc - 2);
        let frac = |i: usize| (i as f64 - 2.0 * cell(i) as f64) / 2.0;
        let mut worst: f64 = 0.0;
        for ([i, j, k], at) in checked_samples(fine, level_fine) {
            let got = reconstruct(
                &coarse.planes(),
                mc,
                [cell(i), cell(j), cell(k)],
                DVec3::new(frac(i), frac(j), frac(k)),
                spacing(level_fine - 1),
                chart.unit,
                chart.lateral,
            );
            for &s in sigmas {
                let exact = fine.tau[at] as f64;
                worst = worst.max(((-s * got).exp() - (-s * exact).exp()).abs());
            }
        }
        worst
    }

    /// A brick of made-up samples: τ growing with depth, some density zero.
    fn samples(level: u8, seed: u64) -> BrickSamples {
        let m = side(level);
        let mut state = seed;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut s = BrickSamples::zeros(m * m * m);
        for at in 0..m * m * m {
            let k = at / (m * m);
            s.tau[at] = 0.3 * k as f32 + next();
            s.rho[at] = if next() < 0.2 { 0.0 } else { next() };
            s.tau_x[at] = next() - 0.5;
            s.tau_y[at] = next() - 0.5;
            s.tau_xy[at] = 0.1 * (next() - 0.5);
        }
        s
    }

    /// The columns made once per brick give the very numbers `reconstruct` gives per
    /// sample (the bake's decisions, and so its map, are unchanged by them), at levels
    /// coarser than, at and finer than a voxel, for both lateral blends.
    #[test]
    fn hermite_error_equals_reconstruct_sample_by_sample() {
        let sigmas = [0.7, 2.5];
        for (level, lateral) in [
            (2, LateralBlend::Hermite),
            (VOXEL_LEVEL, LateralBlend::Hermite),
            (VOXEL_LEVEL + 1, LateralBlend::Linear),
        ] {
            let mut chart = Chart::parallel(DVec3::new(0.2, -1.0, 0.1), DVec3::ZERO, 0.05);
            chart.lateral = [lateral, LateralBlend::Hermite];
            let fine = samples(level, 7 + level as u64);
            let coarse = coarsen(&fine, level);
            let want = coarse_error_by_reconstruct(&fine, &coarse, level, &chart, &sigmas);
            let got = coarse_error(&fine, &coarse, level, &chart, &sigmas, BrickForm::Hermite);
            assert!(
                want > 1e-3,
                "level {level}: the made-up brick blends exactly"
            );
            assert_eq!(
                got.to_bits(),
                want.to_bits(),
                "level {level}: {got} vs {want}"
            );
        }
    }
}
