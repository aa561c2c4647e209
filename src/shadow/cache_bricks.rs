//! One chart's bricks read back from a shadow cache: the bricks grid says each brick's
//! level and form, the grids those need are loaded once each (on all threads), then every
//! brick's samples are gathered from them and packed on all threads, in the bricks grid's
//! order.

use super::cache_error::CacheError;
use super::cache_layout::{StoredGrid, brick_from_code, grid_name};
use super::chart::Chart;
use super::map::{BrickForm, BrickSamples, EncodedBrick, LEVELS, side, spacing};
use crate::field::grid_reader::GridReader;
use crate::field::{Field, VoxelGrid};
use crate::vdb::VdbFile;
use glam::IVec3;
use rayon::prelude::*;
use std::path::Path;

/// The grids a chart's bricks read, each loaded at most once.
struct BrickGrids {
    /// Per level: τ and its slopes `dx`, `dy`, `dxy` (the Hermite bricks').
    hermite: Vec<Option<[VoxelGrid; 4]>>,
    /// Per level: τ of the Linear bricks.
    linear: Vec<Option<VoxelGrid>>,
    /// The one τ of each Constant brick.
    dark: Option<VoxelGrid>,
}

/// The bricks of chart `ci` of `light`'s map in `file`, packed as the map holds them
/// (in the bricks grid's order), with each Hermite sample's density read from `density`
/// where the map's lattice puts it.
pub(super) fn read_chart_bricks(
    file: &VdbFile,
    path: &Path,
    light: &str,
    ci: usize,
    chart: &Chart,
    density: &dyn Field,
) -> Result<Vec<(IVec3, EncodedBrick)>, CacheError> {
    let bad = |problem: String| CacheError::Unusable {
        path: path.to_owned(),
        problem,
    };
    let name = grid_name(light, ci, "bricks");
    let bricks_grid = VoxelGrid::load(file, &name)?;
    let keys = active_voxels(&bricks_grid)
        .ok_or_else(|| bad(format!("grid {name}: its bricks span too large a region")))?;
    let mut coded = Vec::with_capacity(keys.len());
    let mut wanted: Vec<StoredGrid> = Vec::new();
    for key in keys {
        let v = bricks_grid.voxel_value(key, 0);
        let Some((level, form)) = brick_from_code(v) else {
            return Err(bad(format!(
                "grid {name}: brick code {v} is not a level 1..{LEVELS} plus 16 x a form 0..2"
            )));
        };
        for w in StoredGrid::holding(level, form) {
            if !wanted.contains(&w) {
                wanted.push(w);
            }
        }
        coded.push((key, level, form));
    }
    let loaded: Vec<VoxelGrid> = wanted
        .par_iter()
        .map(|w| {
            let name = grid_name(light, ci, &w.suffix());
            if file.grids().iter().all(|g| g.name != name) {
                return Err(bad(format!(
                    "lacks grid {name} (made by an older murk?); bake again with murk bake-shadows"
                )));
            }
            Ok(if w.signed() {
                VoxelGrid::load_signed(file, &name)?
            } else {
                VoxelGrid::load(file, &name)?
            })
        })
        .collect::<Result<_, CacheError>>()?;
    let grids = BrickGrids::placed(wanted, loaded);
    coded
        .par_iter()
        .map(|&(key, level, form)| {
            let samples = grids.samples(key, level, form, chart, density)?;
            Some((key, EncodedBrick::new(level, form, &samples)?))
        })
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| bad(format!("grid {name}: a brick's grids are missing or short")))
}

impl BrickGrids {
    fn placed(wanted: Vec<StoredGrid>, loaded: Vec<VoxelGrid>) -> Self {
        let mut out = BrickGrids {
            hermite: vec![None; LEVELS],
            linear: vec![None; LEVELS],
            dark: None,
        };
        let mut planes: Vec<[Option<VoxelGrid>; 4]> = vec![Default::default(); LEVELS];
        for (w, g) in wanted.into_iter().zip(loaded) {
            match w {
                StoredGrid::Hermite { level, quantity } => {
                    planes[level as usize][quantity] = Some(g)
                }
                StoredGrid::Linear { level } => out.linear[level as usize] = Some(g),
                StoredGrid::Dark => out.dark = Some(g),
                StoredGrid::Bricks => {}
            }
        }
        for (slot, [a, b, c, d]) in out.hermite.iter_mut().zip(planes) {
            if let (Some(a), Some(b), Some(c), Some(d)) = (a, b, c, d) {
                *slot = Some([a, b, c, d]);
            }
        }
        out
    }

    /// Brick `key`'s samples at `level` in `form`; `None` if its grids are not here.
    fn samples(
        &self,
        key: IVec3,
        level: u8,
        form: BrickForm,
        chart: &Chart,
        density: &dyn Field,
    ) -> Option<BrickSamples> {
        let n = 1i32 << level;
        let m = side(level);
        let places = move |step: i32| {
            (0..m as i32).flat_map(move |k| {
                (0..m as i32)
                    .flat_map(move |j| (0..m as i32).map(move |i| key * step + IVec3::new(i, j, k)))
            })
        };
        match form {
            BrickForm::Constant => Some(BrickSamples {
                tau: vec![self.dark.as_ref()?.voxel_value(key, 0)],
                ..Default::default()
            }),
            // Each brick apart, at key × (n + 1): neighbours keep their own rounding.
            BrickForm::Linear => {
                let mut grid = GridReader::new(self.linear.get(level as usize)?.as_ref()?);
                Some(BrickSamples {
                    tau: places(n + 1).map(|ijk| grid.voxel(ijk)).collect(),
                    ..Default::default()
                })
            }
            BrickForm::Hermite => {
                let [tau, tau_x, tau_y, tau_xy] = self.hermite.get(level as usize)?.as_ref()?;
                let [mut tau, mut tau_x, mut tau_y, mut tau_xy] =
                    [tau, tau_x, tau_y, tau_xy].map(GridReader::new);
                // The density where the map's lattice puts the sample: a voxel grid read
                // as `value_at_world` reads it, its block kept from sample to sample.
                let mut rho = density.as_voxel_grid().map(GridReader::new);
                let to_index = density.transform();
                let mut samples = BrickSamples::with_capacity(m * m * m);
                for ijk in places(n) {
                    samples.tau.push(tau.voxel(ijk));
                    let world = chart.to_world(ijk.as_dvec3() * spacing(level));
                    samples.rho.push(match &mut rho {
                        Some(r) => r.sample(to_index.world_to_index(world)),
                        None => density.value_at_world(world),
                    });
                    samples.tau_x.push(tau_x.voxel(ijk));
                    samples.tau_y.push(tau_y.voxel(ijk));
                    samples.tau_xy.push(tau_xy.voxel(ijk));
                }
                Some(samples)
            }
        }
    }
}

/// The global index of every stored voxel of a (small) grid, from its active bounds;
/// `None` if the bounds are too large to scan.
fn active_voxels(g: &VoxelGrid) -> Option<Vec<IVec3>> {
    let b = g.active_bounds();
    if b.is_empty() {
        return Some(Vec::new());
    }
    let origin = g.transform().origin;
    let (lo, hi) = (b.min.ceil().as_ivec3(), b.max.floor().as_ivec3());
    let mut out = Vec::new();
    let count = (hi - lo + IVec3::ONE).as_i64vec3().element_product();
    if count > (64 << 20) {
        return None;
    }
    for z in lo.z..=hi.z {
        for y in lo.y..=hi.y {
            for x in lo.x..=hi.x {
                let global = IVec3::new(x, y, z) + origin;
                if g.voxel_value(global, 0) > 0.0 {
                    out.push(global);
                }
            }
        }
    }
    Some(out)
}
