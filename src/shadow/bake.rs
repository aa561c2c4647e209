//! Baking a deep shadow map: which bricks exist, and at which level each one holds its
//! values.
//!
//! 1. Every 8³-voxel block where the density is not zero (stencil included) is mapped
//!    into each light-space chart; the bricks its lattice box touches exist.
//! 2. Values are `∫ρ ds` from the light and its slopes across it, computed by marching
//!    light *columns* through each brick stack ([`super::columns`]).
//! 3. Adaptivity: each brick is tried at level 0 (one sample per corner). Its samples at
//!    the next level are computed, and the coarse level is kept if the map's
//!    reconstruction from it ([`reconstruct`](super::brick::reconstruct): Hermite along the column and across)
//!    reproduces them within half the tolerance, in transmittance `e^{−σt·∫ρ ds}` for
//!    every channel. Otherwise the brick moves one level finer, down to the finest level
//!    the tolerance allows. Deep inside a thick cloud transmittance is small, so errors in
//!    optical depth cost little there and the bricks stay coarse.
//! 4. Samples coarser than a voxel can step over density (a sheet one voxel thick between
//!    them, or the shadow of one), and then the next level's samples miss it too. So a
//!    brick stays coarser than a voxel only if, besides passing the check, the density's
//!    range over it and over every brick above it toward the light bounds what it could
//!    miss below the tolerance ([`unresolved_bounds`](super::level_checks::unresolved_bounds)).
//! 5. Forms (see [`BrickForm`]): a brick kept at a level is held as τ alone, trilinear in
//!    16 bits, when that blend (plus its rounding) passes the same check, else with τ's
//!    slopes for the Hermite blend; a brick below which at least `−ln(tol/2)/σ` of optical
//!    depth lies for certain (the density's least value over the bricks above) is held as
//!    one τ and its columns are not marched.

use super::chart::Chart;
use super::columns::sample_level;
use super::lattice::{
    MAX_COARSENINGS, block_corners, block_edge, cells_per_column, cells_per_unit, charts_for,
    column_cells,
};
use super::level_checks::{channels, coarse_error, coarsen, unresolved_bounds};
use super::map::{
    BRICK, BakedBrick, BrickForm, BrickSamples, ChartMap, ChartSelect, LEVELS, MAX_LEVEL,
    ShadowMap, VOXEL_LEVEL, side,
};
use crate::field::Field;
use glam::{DVec3, IVec3};
use std::collections::{BTreeMap, HashSet};

/// Below a voxel, how much halving the spacing at least divides a brick's error by: the
/// Hermite blend's error falls 7–12-fold per halving on the fixtures (it goes as the
/// spacing³ or faster).
const SUB_VOXEL_GAIN: f64 = 7.0;

/// The share of the tolerance a brick's check may use: the check sees the error at the
/// next level's samples only, and the error between them is larger.
const CHECK_FRACTION: f64 = 0.5;

/// Where a light is, as far as shadows care.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightGeometry {
    /// A sun: the unit direction its light travels.
    Sun { travel: DVec3 },
    /// A point light at a world position.
    Point { position: DVec3 },
}

impl LightGeometry {
    /// The light's placement in words, which is all a shadow map depends on:
    /// `sun:DX,DY,DZ` (the direction toward the sun) or `point:X,Y,Z`, full precision.
    pub fn placement(&self) -> String {
        let (kind, v) = match *self {
            LightGeometry::Sun { travel } => ("sun", -travel),
            LightGeometry::Point { position } => ("point", position),
        };
        format!("{kind}:{:?},{:?},{:?}", v.x, v.y, v.z)
    }

    /// Unit direction from `x` toward the light and the distance to it.
    pub fn toward(&self, x: DVec3) -> (DVec3, f64) {
        match *self {
            LightGeometry::Sun { travel } => (-travel, f64::INFINITY),
            LightGeometry::Point { position } => {
                let d = position - x;
                let r = d.length();
                (if r > 0.0 { d / r } else { DVec3::Y }, r)
            }
        }
    }
}

/// The default [`BakeSettings::max_cells`]: about 20 s of one core (slopes along a
/// column cost ~70 ns a cell). The fixtures' bakes cross 50 times fewer or less.
pub const MAX_COLUMN_CELLS: f64 = 3e8;

/// What a bake is asked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BakeSettings {
    /// Largest transmittance error allowed, absolute.
    pub tolerance: f64,
    /// Extinction per unit density for each channel (σt × density scale).
    pub sigma_t: DVec3,
    /// Finest level a brick may reach.
    pub max_level: u8,
    /// Largest number of bricks (over all charts) before the lattice is made coarser.
    pub max_bricks: usize,
    /// Largest number of samples held before refinement stops.
    pub max_values: usize,
    /// Largest number of density cells the light columns may cross, over the whole bake
    /// (a bound computed before marching: see [`column_cells`]). Past it at the coarsest
    /// level the lattice is made coarser; past it later refinement stops. This bounds the
    /// bake's time whatever the voxels' shape or the grid's size.
    pub max_cells: f64,
}

impl BakeSettings {
    pub fn new(tolerance: f64, sigma_t: DVec3) -> Self {
        BakeSettings {
            tolerance,
            sigma_t,
            max_level: finest_level(tolerance),
            max_bricks: 4 << 20,
            max_values: 16 << 20,
            max_cells: MAX_COLUMN_CELLS,
        }
    }
}

/// The finest level a bake at `tolerance` may refine to. With the map's Hermite blend,
/// one sample per voxel leaves at most ~3.5e-3 of transmittance error on the fixtures
/// (where τ curves sharply across the light), half a voxel ~6e-4 and a quarter ~1e-4:
/// so one voxel from 5e-3 up, half a voxel down to 1e-3 (the default), a quarter below.
pub fn finest_level(tolerance: f64) -> u8 {
    if tolerance >= 5e-3 {
        VOXEL_LEVEL
    } else if tolerance >= 1e-3 {
        VOXEL_LEVEL + 1
    } else {
        MAX_LEVEL
    }
}

/// What a bake did.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct BakeReport {
    /// Lattice step in world units (the density's smallest voxel edge, or a multiple).
    pub lattice_step: f64,
    pub charts: usize,
    pub bricks: usize,
    /// Samples held at each level (0: one per 8³ brick corner; 3: one per voxel).
    pub points_per_level: Vec<u64>,
    /// Bricks likely over the tolerance: kept at the finest level after missing the
    /// check at the level before by more than refining gains (see `SUB_VOXEL_GAIN`), or
    /// stopped early when the sample budget ran out.
    pub bricks_over_tolerance: usize,
    /// Of those, bricks whose refinement the sample or work budget stopped.
    pub bricks_stopped_by_budget: usize,
    /// What to expect on the bricks over the tolerance: the largest transmittance error
    /// measured one level coarser than the level kept (for those kept at the finest level,
    /// divided by the gain refining is known to give). 0 when none.
    pub over_tolerance_error: f64,
    /// Times the lattice was made twice coarser than the density's voxel because the
    /// bricks or columns of the finer one did not fit the budget (0: voxel lattice).
    pub lattice_coarsenings: usize,
    /// Bricks held as τ alone in 16 bits, blended trilinearly (see [`BrickForm::Linear`]).
    pub linear_bricks: usize,
    /// Bricks held as one τ: the light reaching them is below the tolerance already
    /// (see [`BrickForm::Constant`]).
    pub dark_bricks: usize,
    /// Light columns marched.
    pub columns: u64,
    pub memory_bytes: usize,
}

impl BakeReport {
    /// Fills in what `map` holds: bricks, samples per level, memory.
    pub fn count(&mut self, map: &ShadowMap) {
        self.bricks = map.brick_count();
        self.points_per_level = map.points_per_level().to_vec();
        let [_, linear, dark] = map.bricks_per_form();
        (self.linear_bricks, self.dark_bricks) = (linear as usize, dark as usize);
        self.memory_bytes = map.memory_bytes();
    }
}

/// Bakes the map of one light over `density`.
pub fn bake(
    density: &dyn Field,
    light: LightGeometry,
    settings: &BakeSettings,
) -> (ShadowMap, BakeReport) {
    let voxel = density.transform().voxel_size().min_element();
    let mut unit = if voxel > 0.0 && voxel.is_finite() {
        voxel
    } else {
        1.0
    };
    let voxel_unit = unit;
    for coarsenings in 0..MAX_COARSENINGS {
        if let Some((map, mut report)) = bake_at(
            density,
            light,
            settings,
            unit,
            block_edge(unit / voxel_unit),
        ) {
            report.lattice_coarsenings = coarsenings;
            return (map, report);
        }
        // Too many bricks for this lattice: a coarser one, over coarser density blocks
        // (the same blocks again would fail the same way).
        unit *= 2.0;
    }
    // Past any lattice a field's bounds allow (2^60 voxels): a map with no bricks, read as
    // unshadowed, and said so.
    let report = BakeReport {
        lattice_step: unit,
        points_per_level: vec![0; LEVELS],
        bricks_over_tolerance: 1,
        lattice_coarsenings: MAX_COARSENINGS,
        ..Default::default()
    };
    (
        ShadowMap {
            charts: Vec::new(),
            select: ChartSelect::Single,
        },
        report,
    )
}

fn bake_at(
    density: &dyn Field,
    light: LightGeometry,
    settings: &BakeSettings,
    unit: f64,
    edge: i32,
) -> Option<(ShadowMap, BakeReport)> {
    // A block maps to up to 2³ bricks at least: more blocks than an eighth of the brick
    // budget cannot fit, and would only cost their enumeration.
    let blocks = block_corners(density, edge, settings.max_bricks / 8)?;
    let (charts, select, lateral_limit) = charts_for(density, light, &blocks, unit);
    let mut report = BakeReport {
        lattice_step: unit,
        charts: charts.len(),
        points_per_level: vec![0; LEVELS],
        ..Default::default()
    };
    // Which bricks exist, per chart.
    let mut marked: Vec<Vec<IVec3>> = Vec::with_capacity(charts.len());
    let mut total = 0usize;
    for chart in &charts {
        let mut set = HashSet::new();
        for corners in &blocks {
            let Some((lo, hi)) = chart.lattice_bounds(corners, lateral_limit) else {
                continue;
            };
            let (blo, bhi) = (
                (lo / BRICK as f64 - 1e-9).floor(),
                (hi / BRICK as f64 + 1e-9).floor(),
            );
            let count = (bhi - blo + DVec3::ONE).element_product();
            if !(count.is_finite()
                && blo.abs().max_element() < 1e9
                && bhi.abs().max_element() < 1e9)
                || total as f64 + count > settings.max_bricks as f64 * 4.0
            {
                return None;
            }
            for z in blo.z as i32..=bhi.z as i32 {
                for y in blo.y as i32..=bhi.y as i32 {
                    for x in blo.x as i32..=bhi.x as i32 {
                        set.insert(IVec3::new(x, y, z));
                    }
                }
            }
            total = total.saturating_add(count as usize);
        }
        if set.len() > settings.max_bricks {
            return None;
        }
        let mut keys: Vec<IVec3> = set.into_iter().collect();
        keys.sort_by_key(|k| (k.x, k.y, k.z));
        marked.push(keys);
    }
    if marked.iter().map(Vec::len).sum::<usize>() > settings.max_bricks {
        return None;
    }
    // The columns of the first level sampled must fit the work budget: else a coarser
    // lattice (fewer columns) is needed.
    let per_unit = cells_per_unit(density);
    let cap = cells_per_column(density);
    let first: f64 = charts
        .iter()
        .zip(&marked)
        .map(|(chart, keys)| column_cells(keys, &BTreeMap::new(), 1, chart.unit * per_unit, cap))
        .sum();
    if first > settings.max_cells {
        return None;
    }
    let mut maps = Vec::with_capacity(charts.len());
    let mut cells = first;
    for (chart, keys) in charts.iter().zip(&marked) {
        let bricks = refine(density, chart, keys, settings, &mut report, &mut cells);
        maps.push(ChartMap::new(
            *chart,
            bricks,
            settings.max_bricks.saturating_mul(16),
        )?);
    }
    // The bake's samples are packed and freed: return them before the render.
    crate::mem::release_freed_memory();
    let map = ShadowMap {
        charts: maps,
        select,
    };
    report.count(&map);
    Some((map, report))
}

/// Chooses every brick's level and form.
fn refine(
    density: &dyn Field,
    chart: &Chart,
    keys: &[IVec3],
    settings: &BakeSettings,
    report: &mut BakeReport,
    cells: &mut f64,
) -> Vec<BakedBrick> {
    let sigmas = channels(settings.sigma_t);
    let allowed = CHECK_FRACTION * settings.tolerance;
    // Where each brick stack starts: density lies only inside marked bricks.
    let mut stack_start: BTreeMap<(i32, i32), i32> = BTreeMap::new();
    for k in keys {
        let e = stack_start.entry((k.x, k.y)).or_insert(k.z);
        *e = (*e).min(k.z);
    }
    let mut done = Vec::with_capacity(keys.len());
    let bounds = unresolved_bounds(density, chart, keys, &sigmas);
    // Dark bricks: at least `upstream` of ∫ρ ds lies above every point of the brick, so
    // the light there is at most e^{−σ·upstream} ≤ `allowed` in every channel, and so is
    // the error of reading τ = upstream anywhere in it (or below it). They are the tails
    // of their stacks (upstream only grows downward): their columns need no marching.
    let dark = |depth: f64| {
        sigmas
            .first()
            .is_some_and(|&s| (-s * depth).exp() <= allowed)
    };
    let constant = |key, depth: f64| BakedBrick {
        key,
        level: 0,
        form: BrickForm::Constant,
        samples: BrickSamples {
            tau: vec![depth as f32],
            ..Default::default()
        },
    };
    let mut lit = Vec::with_capacity(keys.len());
    for (&key, &(unresolved, upstream)) in keys.iter().zip(&bounds) {
        if dark(upstream.depth) {
            done.push(constant(key, upstream.depth));
        } else {
            lit.push((key, unresolved, upstream));
        }
    }
    let max_level = settings.max_level.max(1);
    let mut trial: u8 = 0;
    // Bricks still undecided: key, what coarse samples could miss there (see
    // `unresolved_bounds`), and the samples one level finer than the level on trial.
    let mut pending: Vec<(IVec3, f64, BrickSamples)> = {
        let lit_keys: Vec<IVec3> = lit.iter().map(|(k, _, _)| *k).collect();
        let vals = sample_level(density, chart, &lit_keys, 1, &stack_start, report);
        let m = side(1);
        let mut pending = Vec::with_capacity(lit.len());
        for ((k, b, upstream), v) in lit.into_iter().zip(vals) {
            // Dark from the samples: every point of the brick lies below a point of its
            // top face on its column, where ∫ρ ds is at least the least sampled there
            // less how much it can differ between columns.
            let top = v.tau[..m * m]
                .iter()
                .fold(f64::INFINITY, |a, &t| a.min(t as f64));
            let depth = upstream.depth.max(top - upstream.variation);
            if dark(depth) {
                done.push(constant(k, depth));
            } else {
                pending.push((k, b, v));
            }
        }
        pending
    };
    let hermite = |key, level, samples| BakedBrick {
        key,
        level,
        form: BrickForm::Hermite,
        samples,
    };
    let mut held: usize = 0;
    while !pending.is_empty() {
        let fine_level = trial + 1;
        let mut next = Vec::new();
        for (key, unresolved, fine) in pending {
            let coarse = coarsen(&fine, fine_level);
            let error_in = |form| {
                if sigmas.is_empty() {
                    0.0
                } else {
                    coarse_error(&fine, &coarse, fine_level, chart, &sigmas, form)
                }
            };
            // Coarser than a voxel, the check alone could pass over unseen density.
            let resolved = trial >= VOXEL_LEVEL || unresolved <= allowed;
            // Trilinear τ in 16 bits first: a sixth of the memory and a cheaper lookup.
            // Checked where the level on trial would be kept, and at two voxels, where an
            // unresolved brick that passes is kept one level finer (below).
            let linear =
                (resolved || fine_level == VOXEL_LEVEL) && error_in(BrickForm::Linear) <= allowed;
            if linear && !resolved {
                // Trilinear from two-voxel samples meets the one-voxel ones: one sample
                // per voxel, which cannot step over density, trilinear too (2 bytes a
                // sample, where Hermite at one voxel would take 12).
                held += fine.len();
                done.push(BakedBrick {
                    key,
                    level: fine_level,
                    form: BrickForm::Linear,
                    samples: fine,
                });
                continue;
            }
            if linear {
                held += coarse.len();
                done.push(BakedBrick {
                    key,
                    level: trial,
                    form: BrickForm::Linear,
                    samples: coarse,
                });
                continue;
            }
            let error = error_in(BrickForm::Hermite);
            if error <= allowed && resolved {
                held += coarse.len();
                done.push(hermite(key, trial, coarse));
            } else if error <= allowed && fine_level == VOXEL_LEVEL {
                // Smooth at two voxels as one-voxel samples see it, and only unresolved:
                // one sample per voxel cannot step over density, so that level is kept
                // without checking it against half a voxel (which would sample every such
                // brick eight times over).
                held += fine.len();
                done.push(hermite(key, fine_level, fine));
            } else if fine_level >= max_level {
                // Kept at the finest level unchecked (checking would take the level
                // after). Below a voxel, halving the spacing divides the blend's error by
                // SUB_VOXEL_GAIN or more: a brick likely misses only beyond that.
                let gain = if fine_level > VOXEL_LEVEL {
                    SUB_VOXEL_GAIN
                } else {
                    1.0
                };
                if error > gain * allowed {
                    report.bricks_over_tolerance += 1;
                    report.over_tolerance_error = report.over_tolerance_error.max(error / gain);
                }
                held += fine.len();
                done.push(hermite(key, fine_level, fine));
            } else {
                next.push((key, unresolved, fine, error));
            }
        }
        trial += 1;
        let needed = next.len() * side(trial + 1).pow(3);
        let keys: Vec<IVec3> = next.iter().map(|(k, _, _, _)| *k).collect();
        let marched = column_cells(
            &keys,
            &stack_start,
            trial + 1,
            chart.unit * cells_per_unit(density),
            cells_per_column(density),
        );
        if held + needed > settings.max_values || *cells + marched > settings.max_cells {
            // Out of budget (samples or work): keep what there is, and say what it costs.
            report.bricks_over_tolerance += next.len();
            report.bricks_stopped_by_budget += next.len();
            let worst = next.iter().map(|(_, _, _, e)| *e).fold(0.0, f64::max);
            report.over_tolerance_error = report.over_tolerance_error.max(worst);
            done.extend(next.into_iter().map(|(k, _, v, _)| hermite(k, trial, v)));
            break;
        }
        *cells += marched;
        // The samples of the level just checked are not needed past here: free them
        // before the next level's (a fifth of their size, at the largest) are made.
        let next: Vec<(IVec3, f64)> = next.into_iter().map(|(k, b, _, _)| (k, b)).collect();
        crate::mem::release_freed_memory();
        let vals = sample_level(density, chart, &keys, trial + 1, &stack_start, report);
        pending = next
            .into_iter()
            .zip(vals)
            .map(|((k, b), v)| (k, b, v))
            .collect();
    }
    done
}
