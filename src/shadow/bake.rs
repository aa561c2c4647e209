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
//!    A brick that bound does not clear is refined whatever its samples say until they
//!    are a voxel apart, so after its first level (which can find it dark) it goes
//!    straight to that one: the levels between are not marched for it.
//! 5. Forms (see [`BrickForm`](super::map::BrickForm)): a brick kept at a level is held as τ alone, trilinear in
//!    16 bits, when that blend (plus its rounding) passes the same check, else with τ's
//!    slopes for the Hermite blend; a brick below which at least `−ln(tol/2)/σ` of optical
//!    depth lies for certain (the density's least value over the bricks above) is held as
//!    one τ and its columns are not marched.

use super::chart::Chart;
use super::column_marcher::ColumnMarcher;
use super::lattice::{
    MAX_COARSENINGS, block_corners, block_edge, cells_per_column, cells_per_unit, charts_for,
    column_cells,
};
use super::map::{BRICK, ChartMap, ChartSelect, LEVELS, ShadowMap};
use super::refine::refine;
use super::settings::BakePhases;
pub use super::settings::{BakeReport, BakeSettings, LightGeometry};
use crate::field::Field;
use glam::{DVec3, IVec3};
use std::collections::{BTreeMap, HashSet};
use std::time::Instant;

/// The lattice step of a bake made `coarsenings` times twice coarser than the density's
/// smallest voxel edge (1 when that edge is not a positive number).
pub fn lattice_unit(density: &dyn Field, coarsenings: usize) -> f64 {
    let voxel = density.transform().voxel_size().min_element();
    let unit = if voxel > 0.0 && voxel.is_finite() {
        voxel
    } else {
        1.0
    };
    unit * 2f64.powi(coarsenings.min(MAX_COARSENINGS) as i32)
}

/// The charts a bake of `light` over `density` lays on the lattice coarsened
/// `coarsenings` times (what a shadow cache's chart metadata must say); `None` where
/// the density's blocks are past the bake's budget at that lattice (no bake made it).
pub fn bake_charts(
    density: &dyn Field,
    light: LightGeometry,
    settings: &BakeSettings,
    coarsenings: usize,
) -> Option<Vec<Chart>> {
    let unit = lattice_unit(density, coarsenings);
    let edge = block_edge(unit / lattice_unit(density, 0));
    let blocks = block_corners(density, edge, settings.max_bricks / 8)?;
    Some(charts_for(density, light, &blocks, unit).0)
}

/// Bakes the map of one light over `density`.
pub fn bake(
    density: &dyn Field,
    light: LightGeometry,
    settings: &BakeSettings,
) -> (ShadowMap, BakeReport) {
    bake_with(density, light, settings, None)
}

/// [`bake`] with the light columns marched by `columns` (a GPU) where it takes the
/// density; the decisions stay here.
pub fn bake_with(
    density: &dyn Field,
    light: LightGeometry,
    settings: &BakeSettings,
    columns: Option<&dyn ColumnMarcher>,
) -> (ShadowMap, BakeReport) {
    let mut unit = lattice_unit(density, 0);
    let voxel_unit = unit;
    for coarsenings in 0..MAX_COARSENINGS {
        if let Some((map, mut report)) = bake_at(
            density,
            light,
            settings,
            unit,
            block_edge(unit / voxel_unit),
            columns,
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
    columns: Option<&dyn ColumnMarcher>,
) -> Option<(ShadowMap, BakeReport)> {
    let clock = Instant::now();
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
    // The blocks (192 bytes each, tens of MB on a large grid) are not needed past here.
    drop(blocks);
    crate::mem::release_freed_memory();
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
    let mut phases = BakePhases {
        marking_seconds: clock.elapsed().as_secs_f64(),
        ..Default::default()
    };
    for (chart, keys) in charts.iter().zip(&marked) {
        let clock = Instant::now();
        let mut map = ChartMap::empty(
            *chart,
            keys.iter().copied(),
            settings.max_bricks.saturating_mul(16),
        )?;
        phases.marking_seconds += clock.elapsed().as_secs_f64();
        refine(
            density,
            keys,
            settings,
            &mut report,
            &mut phases,
            &mut cells,
            &mut map,
            columns,
        )?;
        maps.push(map);
    }
    // The bake's samples are packed and freed: return them before the render.
    let clock = Instant::now();
    crate::mem::release_freed_memory();
    phases.compacting_seconds += clock.elapsed().as_secs_f64();
    report.phases = Some(phases);
    let map = ShadowMap {
        charts: maps,
        select,
    };
    report.count(&map);
    Some((map, report))
}
