//! Where a shadow map's bricks can be: the density's non-empty blocks in world space,
//! the light's charts around them, and bounds on the density cells the light columns
//! cross — what keeps a bake's work bounded whatever the grid's size or voxel shape.

use super::chart::Chart;
use super::map::{BRICK, ChartSelect, side};
use super::settings::LightGeometry;
use crate::accel::nonzero_blocks;
use crate::field::Field;
use glam::{DVec3, IVec3};
use std::collections::BTreeMap;

/// How many times [`super::bake::bake`] coarsens its lattice before giving up: each doubling halves
/// the bricks along every axis, so 60 take any grid an `i32` index can hold to one brick.
pub(super) const MAX_COARSENINGS: usize = 60;

/// The edge in voxels of the density blocks mapped into a lattice `coarsening` times
/// the voxel: 8 voxels at the voxel's lattice, and as many more as the lattice is coarser
/// (a power of two, at most 2^30), so their number falls with the bricks'.
pub(super) fn block_edge(coarsening: f64) -> i32 {
    let factor = coarsening.max(1.0).log2().floor().min(27.0) as u32;
    BRICK * (1i32 << factor)
}

/// The 8 world corners of every non-empty block of `edge`³ voxels of the density; `None`
/// past `limit`.
pub(super) fn block_corners(
    density: &dyn Field,
    edge: i32,
    limit: usize,
) -> Option<Vec<[DVec3; 8]>> {
    let tr = density.transform();
    let mut out = Vec::new();
    let ok = nonzero_blocks(density, edge, limit, &mut |b| {
        let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
        out.push(std::array::from_fn(|i| {
            tr.index_to_world(DVec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            ))
        }));
    });
    ok.then_some(out)
}

/// The charts of a light around the blocks, with the lateral limit of each.
pub(super) fn charts_for(
    density: &dyn Field,
    light: LightGeometry,
    blocks: &[[DVec3; 8]],
    unit: f64,
) -> (Vec<Chart>, ChartSelect, f64) {
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for c in blocks.iter().flatten() {
        lo = lo.min(*c);
        hi = hi.max(*c);
    }
    let center = (lo + hi) * 0.5;
    match light {
        LightGeometry::Sun { travel } => (
            vec![
                Chart::voxel_aligned(travel, density.transform(), center, unit)
                    .unwrap_or_else(|| Chart::parallel(travel, center, unit)),
            ],
            ChartSelect::Single,
            f64::INFINITY,
        ),
        LightGeometry::Point { position } => {
            let radius = (hi - lo).length() * 0.5;
            let dist = (center - position).length();
            let r_max = blocks
                .iter()
                .flatten()
                .map(|c| (*c - position).length())
                .fold(unit, f64::max);
            // One chart when the light sees the whole volume within 60° of its axis.
            if dist > radius / 60f64.to_radians().sin() {
                let chart = Chart::perspective(position, center - position, r_max, unit);
                let scale = r_max / unit;
                let half_tan = radius / (dist * dist - radius * radius).sqrt();
                (
                    vec![chart],
                    ChartSelect::Single,
                    scale.max(1.0) * half_tan * 1.05 + 2.0,
                )
            } else {
                let scale = (r_max / unit).max(1.0);
                (
                    Chart::cube_faces(position, r_max, unit),
                    ChartSelect::CubeFaces { light: position },
                    scale + 2.0,
                )
            }
        }
    }
}

/// A bound on the density cells a straight line crosses per world unit, whatever its
/// direction: `Σ |dᵢ| / vᵢ ≤ |1/v|` for a unit direction `d` and voxel edges `v`.
pub(super) fn cells_per_unit(density: &dyn Field) -> f64 {
    let v = density.transform().voxel_size();
    let r = DVec3::new(1.0 / v.x, 1.0 / v.y, 1.0 / v.z).length();
    if r.is_finite() { r } else { f64::MAX }
}

/// A bound on the cells any one column crosses where there is density: a line crosses
/// at most one more than the index extent of the active bounds along each axis.
pub(super) fn cells_per_column(density: &dyn Field) -> f64 {
    let b = density.active_bounds();
    if b.is_empty() {
        return 0.0;
    }
    let e = (b.max - b.min).as_dvec3() + DVec3::splat(3.0);
    e.x + e.y + e.z
}

/// A bound on the density cells the columns sampling `keys` at `level` cross (see
/// [`super::columns::sample_level`]): per brick stack, `side(level)²` columns from the
/// stack's top to the bottom of its deepest brick, `cells_per_lattice_unit` cells a
/// lattice step (plus one per column for the cell it starts in), but no more than
/// `column_cap` a column ([`cells_per_column`]). A stack starts at its entry in `tops` if
/// there is one (refinement marches from the top of the whole stack).
pub(super) fn column_cells(
    keys: &[IVec3],
    tops: &BTreeMap<(i32, i32), i32>,
    level: u8,
    cells_per_lattice_unit: f64,
    column_cap: f64,
) -> f64 {
    let mut stacks: BTreeMap<(i32, i32), (i32, i32)> = BTreeMap::new();
    for k in keys {
        let top = tops.get(&(k.x, k.y)).map_or(k.z, |t| (*t).min(k.z));
        let e = stacks.entry((k.x, k.y)).or_insert((top, k.z));
        *e = (e.0.min(top), e.1.max(k.z));
    }
    let m = side(level) as f64;
    stacks
        .values()
        .map(|(top, bottom)| {
            let depth = (f64::from(*bottom) - f64::from(*top) + 1.0) * BRICK as f64;
            m * m * (depth * cells_per_lattice_unit + 1.0).min(column_cap)
        })
        .sum()
}
