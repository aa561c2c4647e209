//! Marching light columns: the samples of a shadow map's bricks.
//!
//! One light ray per lateral lattice position and brick stack, integrated exactly
//! (two-point Gauss–Legendre per voxel crossing) and read off at every sample depth on the
//! way, so each sample reuses the sum of the one before it. τ's slopes across the light
//! and its twist come in closed form where the field has one (a VDB grid:
//! `Field::slopes_along`), else from forward differences of up to three more columns at
//! `(x + ε, y)`, `(x, y + ε)` and `(x + ε, y + ε)` (ε = 1/1024 step: τ is C¹ and its
//! second derivatives are bounded, so these are off by O(ε)), only along the lateral axes
//! the chart blends with Hermite.

use super::chart::{Chart, ChartKind, Column, LateralBlend};
use super::column_marcher::{ColumnJob, ColumnMarcher};
use super::map::{BRICK, BrickSamples, side, spacing};
use super::march::exact_integral;
use crate::accel::{IndexRay, Spans};
use crate::field::{Affine, Field, Sideways};
use glam::{DVec3, IVec3};
use rayon::prelude::*;
use std::collections::BTreeMap;

/// Lateral offset (lattice steps) of the columns whose differences give τ's slopes and
/// twist across the light, for fields without closed-form slopes.
const SLOPE_OFFSET: f64 = 1.0 / 1024.0;

/// A brick stack: its lateral position and its bricks, `(z, index into the keys)`,
/// front (near the light) first.
type Stack = ((i32, i32), Vec<(i32, usize)>);

/// The brick stacks of `keys`, in lateral order.
fn stacks_of(keys: &[IVec3]) -> Vec<Stack> {
    let mut stacks: BTreeMap<(i32, i32), Vec<(i32, usize)>> = BTreeMap::new();
    for (idx, k) in keys.iter().enumerate() {
        stacks.entry((k.x, k.y)).or_default().push((k.z, idx));
    }
    stacks
        .into_iter()
        .map(|(xy, mut v)| {
            v.sort_unstable();
            (xy, v)
        })
        .collect()
}

/// Where a stack's columns start (`t0`, world units along the column) and the depths
/// they are read at: `m` a brick, through every brick of the stack.
fn stack_depths(
    chart: &Chart,
    stack: &Stack,
    level: u8,
    stack_start: &BTreeMap<(i32, i32), i32>,
) -> (f64, Vec<f64>) {
    let ((bx, by), bricks) = stack;
    let (m, s, b) = (side(level), spacing(level), BRICK as f64);
    let start = stack_start.get(&(*bx, *by)).copied().unwrap_or(bricks[0].0) as f64 * b;
    let mut depths = Vec::with_capacity(bricks.len() * m);
    for &(bz, _) in bricks {
        for k in 0..m {
            depths.push((bz as f64 * b + k as f64 * s) * chart.unit);
        }
    }
    let t0 = match chart.kind {
        ChartKind::Parallel { .. } => start * chart.unit,
        ChartKind::Perspective { .. } => (start * chart.unit).max(0.0),
    };
    (t0, depths)
}

/// Lattice position of column `c` (`i + m·j`) of a stack.
fn column_xy(stack: &Stack, level: u8, c: usize) -> (f64, f64) {
    let ((bx, by), _) = stack;
    let (m, s, b) = (side(level), spacing(level), BRICK as f64);
    let (i, j) = (c % m, c / m);
    (*bx as f64 * b + i as f64 * s, *by as f64 * b + j as f64 * s)
}

/// Puts column `c`'s samples (per depth, `[τ, ρ, ∂τ/∂x, ∂τ/∂y, ∂²τ/∂x∂y]`) into its
/// stack's bricks `values`.
fn put_column<T: Copy + Into<f64>>(
    values: &mut [BrickSamples],
    m: usize,
    c: usize,
    samples: &[[T; 5]],
) {
    let (i, j) = (c % m, c / m);
    for (n, v) in values.iter_mut().enumerate() {
        for k in 0..m {
            let [tau, rho, tau_x, tau_y, tau_xy] = samples[n * m + k].map(|x| x.into() as f32);
            let at = i + m * (j + m * k);
            v.tau[at] = tau;
            v.rho[at] = rho;
            v.tau_x[at] = tau_x;
            v.tau_y[at] = tau_y;
            v.tau_xy[at] = tau_xy;
        }
    }
}

/// Samples of the bricks `keys` at `level`, by marching columns: on `elsewhere` (the
/// GPU) where it takes the density, else (and for the columns it could not march) here;
/// and how many light rays were marched.
pub(super) fn sample_level(
    density: &dyn Field,
    chart: &Chart,
    keys: &[IVec3],
    level: u8,
    stack_start: &BTreeMap<(i32, i32), i32>,
    elsewhere: Option<&dyn ColumnMarcher>,
) -> (Vec<BrickSamples>, u64) {
    let stacks = stacks_of(keys);
    if let Some(marcher) = elsewhere.filter(|c| c.takes(density)) {
        let done = sample_stacks(
            marcher,
            density,
            chart,
            &stacks,
            level,
            stack_start,
            keys.len(),
        );
        if let Some(done) = done {
            return done;
        }
    }
    let m = side(level);
    type Marched = (Vec<(usize, BrickSamples)>, u64);
    let results: Vec<Marched> = stacks
        .par_iter()
        .map(|stack| {
            let bricks = &stack.1;
            let mut columns = 0u64;
            let mut values = vec![BrickSamples::zeros(m * m * m); bricks.len()];
            let (t0, depths) = stack_depths(chart, stack, level, stack_start);
            // The stack's columns in parallel too: at the fine levels a batch holds only a
            // few stacks of m² columns each.
            let marched: Vec<(Vec<[f64; 5]>, u64)> = (0..m * m)
                .into_par_iter()
                .map_init(ColumnScratch::default, |column, c| {
                    let (x, y) = column_xy(stack, level, c);
                    let n = column.march(density, chart, x, y, t0, &depths);
                    (std::mem::take(&mut column.samples), n)
                })
                .collect();
            for (c, (samples, n)) in marched.into_iter().enumerate() {
                columns += n;
                put_column(&mut values, m, c, &samples);
            }
            let out: Vec<(usize, BrickSamples)> =
                bricks.iter().map(|&(_, idx)| idx).zip(values).collect();
            (out, columns)
        })
        .collect();
    let mut out = vec![BrickSamples::default(); keys.len()];
    let mut rays = 0;
    for (bricks, columns) in results {
        rays += columns;
        for (idx, v) in bricks {
            out[idx] = v;
        }
    }
    (out, rays)
}

/// `side` with its t measured from `t0` on.
fn from(side: Sideways, t0: f64) -> Sideways {
    let shift = |a: Affine| Affine::new(a.at(t0), a.rate);
    Sideways {
        a: shift(side.a),
        b: shift(side.b),
        c: shift(side.c),
    }
}

/// The samples of every brick of `stacks` (`keys` of them) at `level`, their columns
/// marched by `marcher` (those it could not, here), and how many light rays were marched;
/// `None` when the marcher failed the batch.
fn sample_stacks(
    marcher: &dyn ColumnMarcher,
    density: &dyn Field,
    chart: &Chart,
    stacks: &[Stack],
    level: u8,
    stack_start: &BTreeMap<(i32, i32), i32>,
    keys: usize,
) -> Option<(Vec<BrickSamples>, u64)> {
    let m = side(level);
    let columns = m * m;
    // Each stack's start and depths (its columns share them), and its columns' jobs with
    // `first` counted within the stack.
    type Setup = (f64, Vec<f64>, Vec<ColumnJob>);
    let setups: Vec<Setup> = stacks
        .par_iter()
        .map(|stack| {
            let (t0, depths) = stack_depths(chart, stack, level, stack_start);
            let jobs = (0..columns)
                .map(|c| {
                    let (x, y) = column_xy(stack, level, c);
                    let column = chart.column(x, y);
                    let ray = IndexRay::new(density, column.origin, column.dir);
                    ColumnJob {
                        ray: IndexRay {
                            origin: ray.at(t0),
                            dir: ray.dir,
                        },
                        side: from(sideways(chart, density, x, y), t0),
                        first: 0,
                        count: depths.len(),
                    }
                })
                .collect();
            (t0, depths, jobs)
        })
        .collect();
    let mut depths = Vec::new();
    let mut jobs = Vec::with_capacity(stacks.len() * columns);
    for (t0, d, stack_jobs) in &setups {
        let first = depths.len();
        depths.extend(d.iter().map(|t| t - t0));
        jobs.extend(stack_jobs.iter().map(|j| ColumnJob { first, ..*j }));
    }
    let marched = marcher.march(density, &jobs, &depths).ok()?;
    if marched.done.len() != jobs.len()
        || marched.samples.len() != jobs.iter().map(|j| j.count).sum::<usize>()
    {
        return None;
    }
    // Where each stack's samples begin in the batch's.
    let mut offsets = Vec::with_capacity(stacks.len());
    let mut at = 0;
    for (_, d, _) in &setups {
        offsets.push(at);
        at += d.len() * columns;
    }
    type Filled = (Vec<BrickSamples>, u64);
    let filled: Vec<Filled> = stacks
        .par_iter()
        .zip(&setups)
        .enumerate()
        .map(|(s, (stack, (t0, depths, _)))| {
            let mut values = vec![BrickSamples::zeros(m * m * m); stack.1.len()];
            let mut rays = 0;
            let mut scratch = ColumnScratch::default();
            let n = depths.len();
            for c in 0..columns {
                if marched.done[s * columns + c] {
                    let from = offsets[s] + c * n;
                    put_column(&mut values, m, c, &marched.samples[from..from + n]);
                    rays += 1;
                } else {
                    let (x, y) = column_xy(stack, level, c);
                    rays += scratch.march(density, chart, x, y, *t0, depths);
                    put_column(&mut values, m, c, &scratch.samples);
                }
            }
            (values, rays)
        })
        .collect();
    let mut out = vec![BrickSamples::default(); keys];
    let mut rays = 0;
    for (stack, (values, n)) in stacks.iter().zip(filled) {
        rays += n;
        for (&(_, idx), v) in stack.1.iter().zip(values) {
            out[idx] = v;
        }
    }
    Some((out, rays))
}

/// One column's samples and the buffers that make them, reused from column to column.
#[derive(Default)]
struct ColumnScratch {
    /// Per target depth: τ, ρ, ∂τ/∂x, ∂τ/∂y, ∂²τ/∂x∂y.
    samples: Vec<[f64; 5]>,
    slopes: Vec<[f64; 4]>,
    sums: [Vec<(f64, f64)>; 4],
}

impl ColumnScratch {
    /// Marches column `(x, y)` from `t0` through `depths`, filling `samples`; returns how
    /// many light rays it marched. The slopes come in closed form where the field has
    /// them, else from the column's neighbours at (ε, 0), (0, ε) and (ε, ε) — those the
    /// chart's blend reads: slopes only along Hermite axes, the twist only if both are.
    fn march(
        &mut self,
        density: &dyn Field,
        chart: &Chart,
        x: f64,
        y: f64,
        t0: f64,
        depths: &[f64],
    ) -> u64 {
        self.samples.clear();
        self.slopes.clear();
        let centre = chart.column(x, y);
        let ray = IndexRay::new(density, centre.origin, centre.dir);
        let side = sideways(chart, density, x, y);
        if density.slopes_along(&ray, t0, depths, &side, &mut self.slopes) {
            let rho = |t: f64| density.value_at_index(ray.at(t)) as f64;
            self.samples.extend(
                self.slopes
                    .iter()
                    .zip(depths)
                    .map(|(&[tau, tx, ty, txy], &t)| [tau, rho(t), tx, ty, txy]),
            );
            return 1;
        }
        let e = SLOPE_OFFSET;
        let [hx, hy] = chart.lateral.map(|b| b == LateralBlend::Hermite);
        let offsets = [(0.0, 0.0), (e, 0.0), (0.0, e), (e, e)];
        let wanted = [true, hx, hy, hx && hy];
        let mut marched = 0;
        for (c, (sum, (ox, oy))) in self.sums.iter_mut().zip(offsets).enumerate() {
            sum.clear();
            if wanted[c] {
                marched += 1;
                let column = chart.column(x + ox, y + oy);
                cumulative_integrals(density, column, t0, depths, c == 0, sum);
            }
        }
        let sums = &self.sums;
        self.samples.extend((0..depths.len()).map(|d| {
            let (tau, rho) = sums[0][d];
            let at_offset = |c: usize| if wanted[c] { sums[c][d].0 } else { tau };
            let [px, py, pxy] = [1, 2, 3].map(at_offset);
            [
                tau,
                rho,
                (px - tau) / e,
                (py - tau) / e,
                (pxy - px - py + tau) / (e * e),
            ]
        }));
        marched
    }
}

/// How the points of column `(x, y)` move with x and y, in `density`'s index space: a
/// parallel chart's columns shift by `e1`, `e2` (one lattice step each); a perspective
/// chart's turn about the light, `D = normalize(e3 + (x·e1 + y·e2)/S)`, so the point at
/// distance t moves by `t·∂D/∂x`, `t·∂D/∂y` and `t·∂²D/∂x∂y`.
fn sideways(chart: &Chart, density: &dyn Field, x: f64, y: f64) -> Sideways {
    let tr = density.transform();
    let index = |w: DVec3| tr.world_dir_to_index(w);
    match chart.kind {
        ChartKind::Parallel { .. } => {
            Sideways::parallel(index(chart.e1 * chart.unit), index(chart.e2 * chart.unit))
        }
        ChartKind::Perspective { scale, .. } => {
            let (vx, vy) = (chart.e1 / scale, chart.e2 / scale);
            let v = chart.e3 + vx * x + vy * y;
            let (n, d) = (v.length(), v.normalize());
            let dx = (vx - d * d.dot(vx)) / n;
            let dy = (vy - d * d.dot(vy)) / n;
            let dxy = -(dy * d.dot(vx) + d * dy.dot(vx)) / n - dx * d.dot(vy) / n;
            let fan = |w: DVec3| Affine::new(DVec3::ZERO, index(w));
            Sideways {
                a: fan(dx),
                b: fan(dy),
                c: fan(dxy),
            }
        }
    }
}

/// `(∫ρ dt, ρ)` along `column` from `t_start` to each of `targets` (ascending): the
/// integral exact, the density at the target (0 unless `with_density`).
pub fn cumulative_integrals(
    density: &dyn Field,
    column: Column,
    t_start: f64,
    targets: &[f64],
    with_density: bool,
    out: &mut Vec<(f64, f64)>,
) {
    let Some(&t_end) = targets.last() else { return };
    let ray = IndexRay::new(density, column.origin, column.dir);
    let rho_at = |t: f64| {
        if with_density {
            density.value_at_index(ray.at(t)) as f64
        } else {
            0.0
        }
    };
    let mut sum = 0.0;
    let mut k = 0;
    if t_end > t_start {
        for span in Spans::new(density, ray, t_start, t_end) {
            while k < targets.len() && targets[k] <= span.t0 {
                out.push((sum, rho_at(targets[k])));
                k += 1;
            }
            let piece = |a: f64, b: f64| {
                if span.range.is_constant() {
                    span.range.max as f64 * (b - a)
                } else {
                    exact_integral(density, &ray, a, b)
                }
            };
            let mut a = span.t0;
            while k < targets.len() && targets[k] < span.t1 {
                sum += piece(a, targets[k]);
                a = targets[k];
                out.push((sum, rho_at(a)));
                k += 1;
            }
            sum += piece(a, span.t1);
        }
    }
    while k < targets.len() {
        out.push((sum, rho_at(targets[k])));
        k += 1;
    }
}
