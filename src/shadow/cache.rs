//! Deep shadow maps on disk, for reuse across frames and cameras (`murk bake-shadows`,
//! `murk render --shadow-cache`).
//!
//! A cache is an ordinary `.vdb` file. For every light, chart and level in use it holds a
//! float grid `dsm_<light>_c<chart>_L<level>` of `∫ρ ds` toward the light (density ×
//! world length; optical depth is σt × this) whose index space is that level's lattice,
//! and a float grid `dsm_<light>_c<chart>_bricks` holding `level + 1 + 16 × form` at
//! each brick (form 0: Hermite, 1: Linear, 2: Constant; see [`BrickForm`](super::map::BrickForm)).
//! Beside each level's grid, `…_L<level>_dx`, `_dy` and `_dxy` hold the map's slopes of
//! that integral across the light (per lattice step) and its twist; the density slope
//! along the light is read from the density itself. Those grids hold the Hermite bricks;
//! `…_L<level>_linear` holds the Linear bricks' τ (each brick apart, at index
//! `key·(2^level + 1)`, so neighbours do not overwrite each other's 16-bit rounding) and
//! `…_dark` the one τ of each Constant brick, at the brick. For a
//! sun the transforms are the true light-space → world maps, so Houdini or Blender show
//! the grids where they belong; a point light's charts are perspective, which an affine
//! transform cannot express, so their grids sit in lattice space and the chart is in the
//! metadata. Every grid's metadata names its light (`murk:light`, `murk:placement`) and
//! the density grid it was baked from (`murk:density_hash`).

use super::BakeReport;
use super::cache_bricks::read_chart_bricks;
use super::cache_check::{GridMeta, check_bake_charts, check_consistent, shown};
pub use super::cache_error::CacheError;
use super::cache_layout::{StoredGrid, grid_name};
use super::chart::{Chart, ChartKind, LateralBlend};
use super::map::{ChartMap, ChartSelect, LEVELS, ShadowMap};
use super::{CachedLight, ShadowMapStats};
use crate::field::Field;
use crate::vdb::{VdbFile, float_grid, write_grids};
use glam::{DMat4, DVec3};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::Path;

type Result<T> = std::result::Result<T, CacheError>;

fn vec_text(v: DVec3) -> String {
    format!("{:?},{:?},{:?}", v.x, v.y, v.z)
}

fn parse_vec(s: &str) -> Option<DVec3> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse().ok())
        .collect::<Option<_>>()?;
    (v.len() == 3 && v.iter().all(|x| x.is_finite())).then(|| DVec3::new(v[0], v[1], v[2]))
}

/// Index → world of a chart's lattice scaled by `step` lattice units per index.
fn lattice_transform(chart: &Chart, step: f64) -> DMat4 {
    let origin = match chart.kind {
        ChartKind::Parallel { origin } => origin,
        ChartKind::Perspective { light, .. } => light,
    };
    let s = chart.unit * step;
    DMat4::from_cols(
        (chart.e1 * s).extend(0.0),
        (chart.e2 * s).extend(0.0),
        (chart.e3 * s).extend(0.0),
        origin.extend(1.0),
    )
}

/// A grid's string metadata.
type Metadata = Vec<(String, String)>;

/// Writes the maps of `lights` (one per light, in order) to `path`, atomically. Each
/// grid's voxels go straight into its tree, the grids made on all threads.
pub fn write(
    path: &Path,
    density_hash: u64,
    lights: &[impl CachedLight],
    maps: &[ShadowMap],
    stats: &[ShadowMapStats],
    tolerance: f64,
    sigma_t: DVec3,
) -> Result<()> {
    // Every grid of the file, in order: its chart's map, what it holds, name, metadata.
    let mut grids: Vec<(&ChartMap, StoredGrid, String, Metadata)> = Vec::new();
    for ((light, map), st) in lights.iter().zip(maps).zip(stats) {
        for (ci, cm) in map.charts.iter().enumerate() {
            let chart = &cm.chart;
            let (kind, origin, scale) = match chart.kind {
                ChartKind::Parallel { origin } => ("parallel", origin, 0.0),
                ChartKind::Perspective { light, scale } => ("perspective", light, scale),
            };
            for what in StoredGrid::of(cm) {
                let (quantity, level) = what.described();
                let mut m = vec![
                    ("murk:light".to_string(), light.name().to_string()),
                    ("murk:placement".into(), light.geometry().placement()),
                    ("murk:density_hash".into(), format!("{density_hash:016x}")),
                    ("murk:quantity".into(), quantity.into()),
                    ("murk:chart".into(), format!("{ci}/{}", map.charts.len())),
                    ("murk:chart_kind".into(), kind.into()),
                    (
                        "murk:lateral_blend".into(),
                        chart.lateral.map(LateralBlend::name).join(","),
                    ),
                    ("murk:chart_e1".into(), vec_text(chart.e1)),
                    ("murk:chart_e2".into(), vec_text(chart.e2)),
                    ("murk:chart_e3".into(), vec_text(chart.e3)),
                    ("murk:chart_origin".into(), vec_text(origin)),
                    ("murk:chart_scale".into(), format!("{scale:?}")),
                    ("murk:lattice_step".into(), format!("{:?}", chart.unit)),
                    ("murk:tolerance".into(), format!("{tolerance:?}")),
                    ("murk:sigma_t".into(), vec_text(sigma_t)),
                    (
                        "murk:bricks_over_tolerance".into(),
                        st.bake.bricks_over_tolerance.to_string(),
                    ),
                    (
                        "murk:bricks_stopped_by_budget".into(),
                        st.bake.bricks_stopped_by_budget.to_string(),
                    ),
                    (
                        "murk:over_tolerance_error".into(),
                        format!("{:?}", st.bake.over_tolerance_error),
                    ),
                    (
                        "murk:lattice_coarsenings".into(),
                        st.bake.lattice_coarsenings.to_string(),
                    ),
                ];
                if let Some(l) = level {
                    m.push(("murk:level".into(), l.to_string()));
                }
                grids.push((cm, what, grid_name(light.name(), ci, &what.suffix()), m));
            }
        }
    }
    let file_meta = [(
        "creator".to_string(),
        format!("murk {}", env!("CARGO_PKG_VERSION")),
    )];
    crate::files::write_atomically(path, |tmp| {
        let made = grids
            .par_iter()
            .map(|(cm, what, name, meta)| {
                let to_world = lattice_transform(&cm.chart, what.step());
                float_grid(tmp, name, to_world, meta, what.voxels(cm))
            })
            .collect::<std::result::Result<Vec<_>, _>>()
            .map_err(|e| CacheError::Read(e.at(path)))?;
        write_grids(tmp, made, &file_meta).map_err(|e| CacheError::Read(e.at(path)))
    })
}

/// Reads the maps for `lights` from a cache, refusing it when it was baked for another
/// density grid or another placement of a light.
/// The density slopes stored beside τ are sampled from `density` again.
pub fn read(
    path: &Path,
    density: &dyn Field,
    density_hash: u64,
    lights: &[impl CachedLight],
) -> Result<Vec<(ShadowMap, BakeReport)>> {
    let file = VdbFile::open(path)?;
    let bad = |problem: String| CacheError::Unusable {
        path: path.to_owned(),
        problem,
    };
    // light name → grid name → metadata
    let mut by_light: BTreeMap<String, Vec<(String, GridMeta)>> = BTreeMap::new();
    for g in file.grids() {
        let meta: GridMeta = g.metadata.iter().cloned().collect();
        if let Some(l) = meta.get("murk:light") {
            by_light
                .entry(l.clone())
                .or_default()
                .push((g.name.clone(), meta));
        }
    }
    if by_light.is_empty() {
        return Err(bad(
            "not a murk shadow cache (no grid has murk:light metadata)".into(),
        ));
    }
    let mut out = Vec::with_capacity(lights.len());
    for light in lights {
        let grids = by_light.get(light.name()).ok_or_else(|| {
            bad(format!(
                "has no shadow map for light {} (it has maps for: {}); bake again with murk bake-shadows",
                light.name(),
                by_light.keys().map(|k| shown(k)).collect::<Vec<_>>().join(", ")
            ))
        })?;
        check_consistent(light.name(), grids).map_err(bad)?;
        let meta = &grids[0].1;
        let get = |k: &str| {
            meta.get(k)
                .ok_or_else(|| bad(format!("grid {} lacks {k}", grids[0].0)))
        };
        if get("murk:placement")? != &light.geometry().placement() {
            return Err(bad(format!(
                "was baked for light {} at {}, not {}; bake again with murk bake-shadows",
                light.name(),
                get("murk:placement")?,
                light.geometry().placement()
            )));
        }
        let hash = format!("{density_hash:016x}");
        if get("murk:density_hash")? != &hash {
            return Err(bad(format!(
                "was baked from a different density grid (hash {}, this one is {hash}); bake again with murk bake-shadows",
                get("murk:density_hash")?
            )));
        }
        let charts: usize = get("murk:chart")?
            .split_once('/')
            .and_then(|(_, n)| n.parse().ok())
            .filter(|n| (1..=6).contains(n))
            .ok_or_else(|| bad("bad murk:chart".into()))?;
        let mut expected = Vec::with_capacity(charts);
        for ci in 0..charts {
            let name = grid_name(light.name(), ci, "bricks");
            let (_, m) = grids
                .iter()
                .find(|(n, _)| *n == name)
                .ok_or_else(|| bad(format!("lacks grid {name}")))?;
            expected.push(
                chart_from(m).ok_or_else(|| bad(format!("grid {name}: bad chart metadata")))?,
            );
        }
        check_bake_charts(density, light.geometry(), light.name(), meta, &expected).map_err(bad)?;
        let mut report = BakeReport {
            charts,
            points_per_level: vec![0; LEVELS],
            ..Default::default()
        };
        let mut chart_maps = Vec::with_capacity(charts);
        for (ci, &chart) in expected.iter().enumerate() {
            let name = grid_name(light.name(), ci, "bricks");
            let meta = &grids
                .iter()
                .find(|(n, _)| *n == name)
                .ok_or_else(|| bad(format!("lacks grid {name}")))?
                .1;
            report.lattice_step = chart.unit;
            // Every chart's grids carry the whole map's counts: read them once.
            if ci == 0 {
                let count = |key: &str| meta.get(key).and_then(|v| v.parse::<usize>().ok());
                report.bricks_over_tolerance = count("murk:bricks_over_tolerance").unwrap_or(0);
                report.bricks_stopped_by_budget =
                    count("murk:bricks_stopped_by_budget").unwrap_or(0);
                report.lattice_coarsenings = count("murk:lattice_coarsenings").unwrap_or(0);
                report.over_tolerance_error = meta
                    .get("murk:over_tolerance_error")
                    .and_then(|v| v.parse::<f64>().ok())
                    .filter(|e| e.is_finite() && *e >= 0.0)
                    .unwrap_or(0.0);
            }
            let bricks = read_chart_bricks(&file, path, light.name(), ci, &chart, density)?;
            let too_large = || bad(format!("grid {name}: its bricks span too large a region"));
            let mut cm = ChartMap::empty(chart, bricks.iter().map(|b| b.0), 64 << 20)
                .ok_or_else(too_large)?;
            let packed: Vec<_> = bricks.iter().map(|(key, b)| (*key, b)).collect();
            cm.push_encoded_all(&packed).ok_or_else(too_large)?;
            chart_maps.push(cm);
        }
        let select = if charts == 6 {
            match chart_maps[0].chart.kind {
                ChartKind::Perspective { light, .. } => ChartSelect::CubeFaces { light },
                ChartKind::Parallel { .. } => return Err(bad("six parallel charts".into())),
            }
        } else {
            ChartSelect::Single
        };
        let map = ShadowMap {
            charts: chart_maps,
            select,
        };
        report.count(&map);
        if report.bricks_over_tolerance > report.bricks
            || report.bricks_stopped_by_budget > report.bricks_over_tolerance
        {
            return Err(bad(format!(
                "the map of light {} says {} of its {} bricks are over the tolerance ({} stopped by the budget): not what a bake writes; bake again with murk bake-shadows",
                light.name(),
                report.bricks_over_tolerance,
                report.bricks,
                report.bricks_stopped_by_budget
            )));
        }
        out.push((map, report));
    }
    Ok(out)
}

fn chart_from(meta: &BTreeMap<String, String>) -> Option<Chart> {
    let v = |k: &str| meta.get(k).and_then(|s| parse_vec(s));
    let f = |k: &str| {
        meta.get(k)
            .and_then(|s| s.parse::<f64>().ok())
            .filter(|x| x.is_finite())
    };
    let (e1, e2, e3, origin) = (
        v("murk:chart_e1")?,
        v("murk:chart_e2")?,
        v("murk:chart_e3")?,
        v("murk:chart_origin")?,
    );
    let unit = f("murk:lattice_step").filter(|u| *u > 0.0)?;
    let kind = match meta.get("murk:chart_kind")?.as_str() {
        "parallel" => ChartKind::Parallel { origin },
        "perspective" => ChartKind::Perspective {
            light: origin,
            scale: f("murk:chart_scale").filter(|s| *s > 0.0)?,
        },
        _ => return None,
    };
    let lateral = match meta.get("murk:lateral_blend").map(|s| s.split_once(',')) {
        Some(Some((x, y))) => [LateralBlend::from_name(x)?, LateralBlend::from_name(y)?],
        Some(None) => return None,
        None => [LateralBlend::Hermite; 2],
    };
    let orthonormal = [e1, e2, e3].iter().all(|e| (e.length() - 1.0).abs() < 1e-9)
        && e1.dot(e2).abs() < 1e-9
        && e1.dot(e3).abs() < 1e-9;
    orthonormal.then_some(Chart {
        kind,
        lateral,
        e1,
        e2,
        e3,
        unit,
    })
}
