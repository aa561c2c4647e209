//! Choosing each brick's level and form (steps 3–5 of [`super::bake`]), packing every
//! brick into the map as soon as it is decided.
//!
//! A level's samples are made a batch of whole brick stacks at a time
//! ([`BAKE_BATCH_SAMPLES`]), and each brick of the batch is decided and packed while
//! the next batch is sampled (a GPU marches that batch's columns meanwhile): at most two
//! batches' samples are ever held in f32 (20 bytes a sample, where the map holds 12 or
//! 2; see [`ColumnMarcher::batch_samples`]). A brick that needs the next level is packed
//! too, at the level checked, in case the budget stops refinement there (then it is kept
//! so, as it always was); if refinement goes on, the finer brick replaces it and
//! [`ChartMap::drop_replaced`] reclaims its room. A stack's columns are marched through
//! all its bricks on trial at once, as before, and the packing depends on the brick
//! alone: the map's lookups are the same as when every brick was sampled together.

use super::chart::Chart;
use super::column_marcher::{BAKE_BATCH_SAMPLES, ColumnMarcher};
use super::columns::sample_level;
use super::lattice::{cells_per_column, cells_per_unit, column_cells};
use super::level_checks::{Upstream, channels, coarse_error, coarsen, unresolved_bounds};
use super::map::{BrickForm, BrickSamples, ChartMap, EncodedBrick, VOXEL_LEVEL, side};
use super::settings::BakePhases;
use super::{BakeReport, BakeSettings};
use crate::field::Field;
use glam::IVec3;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::time::Instant;

/// Below a voxel, how much halving the spacing typically divides a brick's error by:
/// the Hermite blend's error goes as the spacing³ where τ is smooth. Measured from one
/// voxel to half a voxel (the bake's check at each, on the bricks that took both, at
/// `--dsm-tolerance 1e-4`): median 6.3–6.7 on the pyro, Houdini and Blender fixtures
/// (5 % of bricks below 3.3–3.7).
const SUB_VOXEL_GAIN: f64 = 7.0;

/// The same from two voxels to one, where the brick holds τ's kinks across voxel faces
/// at its samples: median 4.4–5.5 on the demo cloud and those fixtures (5 % below
/// 2.5–3.2, the least 0.6). What a brick kept at one voxel unchecked is expected to
/// miss by: its two-voxel error over this.
const VOXEL_GAIN: f64 = 4.0;

/// The share of the tolerance a brick's check may use: the check sees the error at the
/// next level's samples only, and the error between them is larger.
const CHECK_FRACTION: f64 = 0.5;

/// A brick on trial: its key, what coarse samples could miss there (see
/// `unresolved_bounds`), and at the first level what lies above it.
type Pending = (IVec3, f64, Upstream);

/// Chooses every brick's level and form, and packs each into `map`, adding the time
/// each part took to `phases`. `None` if the map refuses a brick (outside its table).
#[allow(clippy::too_many_arguments)]
pub(super) fn refine(
    density: &dyn Field,
    keys: &[IVec3],
    settings: &BakeSettings,
    report: &mut BakeReport,
    phases: &mut BakePhases,
    cells: &mut f64,
    map: &mut ChartMap,
    elsewhere: Option<&dyn ColumnMarcher>,
) -> Option<()> {
    let chart: Chart = map.chart;
    let sigmas = channels(settings.sigma_t);
    let allowed = CHECK_FRACTION * settings.tolerance;
    // The batches' size: the marcher's where it marches this density. The map is the
    // same for any size: each level's budget is decided after all its batches.
    let batch_samples = elsewhere
        .filter(|c| c.takes(density))
        .map_or(BAKE_BATCH_SAMPLES, |c| c.batch_samples());
    // Where each brick stack starts: density lies only inside marked bricks.
    let mut stack_start: BTreeMap<(i32, i32), i32> = BTreeMap::new();
    for k in keys {
        let e = stack_start.entry((k.x, k.y)).or_insert(k.z);
        *e = (*e).min(k.z);
    }
    let clock = Instant::now();
    let bounds = unresolved_bounds(density, &chart, keys, &sigmas);
    phases.bounds_seconds += clock.elapsed().as_secs_f64();
    // Dark bricks: at least `upstream` of ∫ρ ds lies above every point of the brick, so
    // the light there is at most e^{−σ·upstream} ≤ `allowed` in every channel, and so is
    // the error of reading τ = upstream anywhere in it (or below it). They are the tails
    // of their stacks (upstream only grows downward): their columns need no marching.
    let dark = |depth: f64| {
        sigmas
            .first()
            .is_some_and(|&s| (-s * depth).exp() <= allowed)
    };
    let constant = |depth: f64| BrickSamples {
        tau: vec![depth as f32],
        ..Default::default()
    };
    let mut pending: Vec<Pending> = Vec::with_capacity(keys.len());
    for (&key, &(unresolved, upstream)) in keys.iter().zip(&bounds) {
        if dark(upstream.depth) {
            map.push(key, 0, BrickForm::Constant, &constant(upstream.depth))?;
        } else {
            pending.push((key, unresolved, upstream));
        }
    }
    drop(bounds);
    let max_level = settings.max_level.max(1);
    // The first level on trial at which an unresolved brick can be kept (its samples one
    // voxel apart, or the finest level's): before it, `decide` refines it whatever it
    // sees, so only its first level (for the dark check) is sampled before this one.
    let decisive = max_level.min(VOXEL_LEVEL) - 1;
    let mut deferred: Vec<(Pending, f64)> = Vec::new();
    let mut trial: u8 = 0;
    // Samples kept, and reserved for the deferred bricks' samples.
    let (mut held, mut reserved) = (0usize, 0usize);
    while !pending.is_empty() {
        let fine_level = trial + 1;
        let m = side(fine_level);
        // Bricks that need the next level, and their error at this one.
        let mut next: Vec<(Pending, f64)> = Vec::new();
        // Each brick on trial is packed once at this level, with at most m³ samples.
        map.reserve(pending.len(), pending.len() * m * m * m);
        // The level's batches: each one's columns are marched while the batch before
        // is decided (on a GPU, the columns of one batch and the decisions on the one
        // before run at once; on the CPU both are parallel work for the same threads).
        let batches: Vec<_> = stack_batches(&pending, m * m * m, batch_samples).collect();
        // A batch's samples, its columns and the seconds they took.
        let sample = |range: &std::ops::Range<usize>| {
            let clock = Instant::now();
            let keys: Vec<IVec3> = pending[range.clone()].iter().map(|p| p.0).collect();
            let (vals, columns) =
                sample_level(density, &chart, &keys, fine_level, &stack_start, elsewhere);
            (vals, columns, clock.elapsed().as_secs_f64())
        };
        // Each brick is decided and packed on its own (in parallel), then appended in
        // key order: the map is the same for any number of threads.
        let decide_batch = |batch: &[Pending], vals: Vec<BrickSamples>| -> Vec<Outcome> {
            batch
                .par_iter()
                .zip(vals)
                .map(|(&(key, unresolved, upstream), fine)| {
                    if trial == 0 {
                        // Dark from the samples: every point of the brick lies below a
                        // point of its top face on its column, where ∫ρ ds is at least
                        // the least sampled there less how much it can differ between
                        // columns.
                        let top = fine.tau[..m * m]
                            .iter()
                            .fold(f64::INFINITY, |a, &t| a.min(t as f64));
                        let depth = upstream.depth.max(top - upstream.variation);
                        if dark(depth) {
                            return Outcome::packed(key, 0, BrickForm::Constant, &constant(depth));
                        }
                    }
                    let mut over = Over::default();
                    let kept = decide(
                        &fine, fine_level, unresolved, &chart, &sigmas, allowed, max_level,
                        &mut over,
                    );
                    let mut outcome = match kept {
                        Decision::Keep {
                            level,
                            form,
                            coarse,
                        } => {
                            let samples = if coarse {
                                &coarsen(&fine, fine_level)
                            } else {
                                &fine
                            };
                            Outcome::packed(key, level, form, samples)
                        }
                        // Held at the level checked until the budget says otherwise.
                        Decision::Refine { error } => Outcome {
                            refine: Some((unresolved, upstream, error)),
                            ..Outcome::packed(key, fine_level, BrickForm::Hermite, &fine)
                        },
                    };
                    outcome.over = over;
                    outcome
                })
                .collect()
        };
        let mut ahead = batches.first().map(sample);
        // The first batch's columns have nothing to be decided beside them.
        phases.waiting_seconds += ahead.as_ref().map_or(0.0, |a| a.2);
        for (k, range) in batches.iter().enumerate() {
            let Some((vals, columns, seconds)) = ahead.take() else {
                break;
            };
            report.columns += columns;
            phases.columns_seconds += seconds;
            let batch = &pending[range.clone()];
            // The outcomes, and the seconds deciding and packing took.
            let decide_and_pack = || {
                let clock = Instant::now();
                let outcomes = decide_batch(batch, vals);
                let decided = clock.elapsed().as_secs_f64();
                let packed: Option<Vec<(IVec3, &EncodedBrick)>> = outcomes
                    .iter()
                    .map(|o| o.brick.as_ref().map(|b| (o.key, b)))
                    .collect();
                let clock = Instant::now();
                map.push_encoded_all(&packed?)?;
                Some((outcomes, decided, clock.elapsed().as_secs_f64()))
            };
            let clock = Instant::now();
            let (after, done) = rayon::join(|| batches.get(k + 1).map(sample), decide_and_pack);
            let (outcomes, decided, packed) = done?;
            phases.decisions_seconds += decided;
            phases.packing_seconds += packed;
            phases.waiting_seconds += (clock.elapsed().as_secs_f64() - decided - packed).max(0.0);
            ahead = after;
            for o in outcomes {
                report.bricks_over_tolerance += o.over.bricks;
                report.over_tolerance_error = report.over_tolerance_error.max(o.over.error);
                match o.refine {
                    Some((unresolved, upstream, error)) => {
                        next.push(((o.key, unresolved, upstream), error));
                    }
                    None => held += o.held,
                }
            }
        }
        trial += 1;
        // Bricks that go on at the next level, and those deferred to `decisive`.
        let mut skip: Vec<(Pending, f64)> = Vec::new();
        if trial < decisive {
            // Unresolved bricks refine at every level before `decisive` whatever their
            // samples say: those levels are not sampled for them.
            let (s, n): (Vec<_>, Vec<_>) = next.into_iter().partition(|(p, _)| p.1 > allowed);
            (skip, next) = (s, n);
        }
        let cost = |bricks: &[(Pending, f64)], level: u8| {
            let keys: Vec<IVec3> = bricks.iter().map(|(p, _)| p.0).collect();
            let cells = column_cells(
                &keys,
                &stack_start,
                level,
                chart.unit * cells_per_unit(density),
                cells_per_column(density),
            );
            (bricks.len() * side(level).pow(3), cells)
        };
        let (mut needed, mut marched) = cost(&next, trial + 1);
        if !skip.is_empty() {
            let (skip_values, skip_cells) = cost(&skip, decisive + 1);
            if held + reserved + needed + skip_values <= settings.max_values
                && *cells + marched + skip_cells <= settings.max_cells
            {
                // Their level `decisive + 1` samples are paid for now; their copies packed
                // at the level checked are not needed.
                reserved += skip_values;
                *cells += skip_cells;
                for (p, _) in &skip {
                    map.forget(p.0);
                }
                deferred.append(&mut skip);
            } else {
                // Not affordable at once: level by level, as the others.
                next.append(&mut skip);
                (needed, marched) = cost(&next, trial + 1);
            }
        }
        if held + reserved + needed > settings.max_values || *cells + marched > settings.max_cells {
            // Out of budget (samples or work): keep what there is (packed already, at the
            // level checked), and say what it costs.
            report.bricks_over_tolerance += next.len();
            report.bricks_stopped_by_budget += next.len();
            let worst = next.iter().map(|(_, e)| *e).fold(0.0, f64::max);
            // A transmittance error is at most 1, whatever the estimate (a brick's bound
            // on a vast active tile can be far past it).
            report.over_tolerance_error = report.over_tolerance_error.max(worst.min(1.0));
            next.clear();
        } else {
            *cells += marched;
        }
        // The copies packed in case of that stop are not needed: give their room back
        // before the next level's samples are made.
        for (p, _) in &next {
            map.forget(p.0);
        }
        if next.is_empty() && deferred.is_empty() {
            break;
        }
        if trial == decisive || next.is_empty() {
            // The deferred bricks join at `decisive` (their budget counted already), at
            // once if no brick is left before it.
            trial = decisive;
            reserved = 0;
            next.append(&mut deferred);
        }
        let clock = Instant::now();
        map.drop_replaced();
        pending = next.into_iter().map(|(p, _)| p).collect();
        crate::mem::release_freed_memory();
        phases.compacting_seconds += clock.elapsed().as_secs_f64();
    }
    // Bricks refined past a level they were packed at leave that copy behind.
    let clock = Instant::now();
    map.drop_replaced();
    phases.compacting_seconds += clock.elapsed().as_secs_f64();
    Some(())
}

/// Bricks kept over the tolerance, and the worst one's estimated error.
#[derive(Default)]
struct Over {
    bricks: usize,
    error: f64,
}

/// One brick decided at a level: packed as kept (or as checked, when it goes on), the
/// samples it holds, and if it goes on what it carries to the next level.
struct Outcome {
    key: IVec3,
    /// `None` where its samples do not fit its form (the map then refuses the bake).
    brick: Option<EncodedBrick>,
    held: usize,
    refine: Option<(f64, Upstream, f64)>,
    over: Over,
}

impl Outcome {
    fn packed(key: IVec3, level: u8, form: BrickForm, samples: &BrickSamples) -> Outcome {
        Outcome {
            key,
            brick: EncodedBrick::new(level, form, samples),
            held: if form == BrickForm::Constant {
                0
            } else {
                samples.len()
            },
            refine: None,
            over: Over::default(),
        }
    }
}

/// What the check at one level says about a brick.
enum Decision {
    /// Kept at `level` in `form`: from the level checked's samples coarsened, or from
    /// them as they are.
    Keep {
        level: u8,
        form: BrickForm,
        coarse: bool,
    },
    /// Needs the next level; `error` is the Hermite error at the level on trial.
    Refine { error: f64 },
}

/// Decides one brick on trial at `fine_level − 1` from its samples at `fine_level`.
#[allow(clippy::too_many_arguments)]
fn decide(
    fine: &BrickSamples,
    fine_level: u8,
    unresolved: f64,
    chart: &Chart,
    sigmas: &[f64],
    allowed: f64,
    max_level: u8,
    over: &mut Over,
) -> Decision {
    let trial = fine_level - 1;
    let coarse = coarsen(fine, fine_level);
    let error_in = |form| {
        if sigmas.is_empty() {
            0.0
        } else {
            coarse_error(fine, &coarse, fine_level, chart, sigmas, form)
        }
    };
    let keep = |level, form| Decision::Keep {
        level,
        form,
        coarse: level == trial,
    };
    // Coarser than a voxel, the check alone could pass over unseen density.
    let resolved = trial >= VOXEL_LEVEL || unresolved <= allowed;
    // Trilinear τ in 16 bits first: a sixth of the memory and a cheaper lookup. Checked
    // where the level on trial would be kept, and at two voxels, where an unresolved
    // brick that passes is kept one level finer (below).
    let linear = (resolved || fine_level == VOXEL_LEVEL) && error_in(BrickForm::Linear) <= allowed;
    if linear && !resolved {
        // Trilinear from two-voxel samples meets the one-voxel ones: one sample per voxel,
        // which cannot step over density, trilinear too (2 bytes a sample, where Hermite
        // at one voxel would take 12).
        return keep(fine_level, BrickForm::Linear);
    }
    if linear {
        return keep(trial, BrickForm::Linear);
    }
    let error = error_in(BrickForm::Hermite);
    if error <= allowed && resolved {
        keep(trial, BrickForm::Hermite)
    } else if error <= allowed && fine_level == VOXEL_LEVEL {
        // Smooth at two voxels as one-voxel samples see it, and only unresolved: one
        // sample per voxel cannot step over density, so that level is kept without
        // checking it against half a voxel (which would sample every such brick eight
        // times over).
        keep(fine_level, BrickForm::Hermite)
    } else if fine_level >= max_level {
        // Kept at the finest level unchecked (checking would take the level after).
        // From two voxels down, halving the spacing typically divides the blend's error
        // by VOXEL_GAIN or SUB_VOXEL_GAIN: a brick likely misses only beyond that.
        // Coarser, samples can step over density: no gain is assumed.
        let gain = match fine_level.cmp(&VOXEL_LEVEL) {
            std::cmp::Ordering::Greater => SUB_VOXEL_GAIN,
            std::cmp::Ordering::Equal => VOXEL_GAIN,
            std::cmp::Ordering::Less => 1.0,
        };
        if error > gain * allowed {
            over.bricks += 1;
            over.error = over.error.max((error / gain).min(1.0));
        }
        keep(fine_level, BrickForm::Hermite)
    } else {
        Decision::Refine { error }
    }
}

/// `pending` (sorted by stack, as the keys are) cut into runs of whole brick stacks of
/// about `batch_samples` samples, `per_brick` each.
fn stack_batches(
    pending: &[Pending],
    per_brick: usize,
    batch_samples: usize,
) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
    let per_batch = (batch_samples / per_brick.max(1)).max(1);
    let mut start = 0;
    std::iter::from_fn(move || {
        if start >= pending.len() {
            return None;
        }
        let mut end = (start + per_batch).min(pending.len());
        // Finish the stack the batch ends in.
        let stack = |i: usize| (pending[i].0.x, pending[i].0.y);
        while end < pending.len() && stack(end) == stack(end - 1) {
            end += 1;
        }
        let batch = start..end;
        start = end;
        Some(batch)
    })
}
