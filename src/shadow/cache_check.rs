//! Checks of a shadow cache's metadata before its maps are used: every grid of a light's
//! map must say what the others say (one bake made them all), and its charts must be
//! those a bake of this density for this light lays. A cache altered by hand, or mixed
//! from two files, is refused rather than rendered wrong.

use super::bake::{BakeSettings, LightGeometry, bake_charts};
use super::chart::{Chart, ChartKind};
use super::lattice::MAX_COARSENINGS;
use crate::field::Field;
use crate::vdb::guard::short_text;
use glam::DVec3;
use std::collections::BTreeMap;

/// A grid's metadata, name → text.
pub(super) type GridMeta = BTreeMap<String, String>;

/// What every grid of one light's map says the same of.
const MAP_KEYS: [&str; 9] = [
    "murk:placement",
    "murk:density_hash",
    "murk:tolerance",
    "murk:sigma_t",
    "murk:lattice_step",
    "murk:lattice_coarsenings",
    "murk:bricks_over_tolerance",
    "murk:bricks_stopped_by_budget",
    "murk:over_tolerance_error",
];

/// What every grid of one chart says the same of.
const CHART_KEYS: [&str; 8] = [
    "murk:chart",
    "murk:chart_kind",
    "murk:lateral_blend",
    "murk:chart_e1",
    "murk:chart_e2",
    "murk:chart_e3",
    "murk:chart_origin",
    "murk:chart_scale",
];

const BAKE_AGAIN: &str = "bake again with murk bake-shadows";

/// Text from the file as an error shows it: control characters escaped, at most 40
/// characters (a name of hundreds of bytes of binary would fill the terminal).
pub(super) fn shown(s: &str) -> String {
    short_text(s)
}

fn value(v: Option<&String>) -> String {
    v.map_or("(none)".to_string(), |v| format!("\"{}\"", shown(v)))
}

/// Every grid of `light`'s map (name, metadata) says the same of the whole map, names
/// the chart its name says (one of the map's), and says the same of its chart as the
/// chart's other grids.
pub(super) fn check_consistent(light: &str, grids: &[(String, GridMeta)]) -> Result<(), String> {
    let Some(first) = grids.first() else {
        return Ok(());
    };
    let differs = |k: &str, a: &(String, GridMeta), b: &(String, GridMeta)| {
        format!(
            "grid {} has {k} {} but grid {} has {}: its grids are not of one bake (altered, or mixed from two caches); {BAKE_AGAIN}",
            shown(&a.0),
            value(a.1.get(k)),
            shown(&b.0),
            value(b.1.get(k))
        )
    };
    let split = |m: &GridMeta| {
        m.get("murk:chart")
            .and_then(|c| c.split_once('/'))
            .map(|(i, n)| (i.to_string(), n.to_string()))
            .unwrap_or_default()
    };
    let prefix = format!("dsm_{light}_c");
    let mut charts: BTreeMap<String, &(String, GridMeta)> = BTreeMap::new();
    for g in grids {
        if let Some(k) = MAP_KEYS.iter().find(|k| g.1.get(**k) != first.1.get(**k)) {
            return Err(differs(k, g, first));
        }
        let (i, n) = split(&g.1);
        if n != split(&first.1).1 {
            return Err(differs("murk:chart", g, first));
        }
        let named =
            g.0.strip_prefix(&prefix)
                .and_then(|r| r.split_once('_'))
                .map(|(c, _)| c);
        let in_map = matches!((i.parse::<usize>(), n.parse::<usize>()), (Ok(i), Ok(n)) if i < n);
        if named != Some(i.as_str()) || !in_map {
            return Err(format!(
                "grid {}: its murk:chart {} is not the chart its name says, of the map's {}; {BAKE_AGAIN}",
                shown(&g.0),
                value(g.1.get("murk:chart")),
                shown(&n)
            ));
        }
        let c0 = *charts.entry(i).or_insert(g);
        if let Some(k) = CHART_KEYS.iter().find(|k| g.1.get(**k) != c0.1.get(**k)) {
            return Err(differs(k, g, c0));
        }
    }
    Ok(())
}

/// The charts read from a cache (`charts`, in order; `meta` is any grid's metadata of
/// the map) are those a bake of `light` over `density` lays at the lattice the cache
/// says.
pub(super) fn check_bake_charts(
    density: &dyn Field,
    light: LightGeometry,
    light_name: &str,
    meta: &GridMeta,
    charts: &[Chart],
) -> Result<(), String> {
    let coarsenings = meta
        .get("murk:lattice_coarsenings")
        .and_then(|v| v.parse::<usize>().ok())
        .filter(|c| *c < MAX_COARSENINGS)
        .ok_or_else(|| {
            format!(
                "the map of light {light_name} has murk:lattice_coarsenings {}, not 0 to {}; {BAKE_AGAIN}",
                value(meta.get("murk:lattice_coarsenings")),
                MAX_COARSENINGS - 1
            )
        })?;
    // The brick budget, all that decides the charts, is the same at every tolerance.
    let settings = BakeSettings::new(1e-3, DVec3::ONE);
    let expected = bake_charts(density, light, &settings, coarsenings).ok_or_else(|| {
        format!(
            "the map of light {light_name} says its lattice was coarsened {coarsenings} times, but this density does not fit a bake's budget there; {BAKE_AGAIN}"
        )
    })?;
    if expected.len() != charts.len() {
        return Err(format!(
            "the map of light {light_name} has {} charts, but a bake of this density and light lays {}; {BAKE_AGAIN}",
            charts.len(),
            expected.len()
        ));
    }
    for (ci, (got, want)) in charts.iter().zip(&expected).enumerate() {
        if !same_chart(got, want) {
            return Err(format!(
                "chart {ci} of light {light_name} (lattice step {}, origin {}) is not the chart a bake of this density and light lays (lattice step {}, origin {}); {BAKE_AGAIN}",
                got.unit,
                origin(got),
                want.unit,
                origin(want)
            ));
        }
    }
    Ok(())
}

fn origin(c: &Chart) -> String {
    let o = match c.kind {
        ChartKind::Parallel { origin } => origin,
        ChartKind::Perspective { light, .. } => light,
    };
    format!("{},{},{}", o.x, o.y, o.z)
}

/// Equal up to the rounding of the metadata's text (which is exact) and of arithmetic
/// done in another order: 1e-9 relative.
fn same_chart(a: &Chart, b: &Chart) -> bool {
    let near = |x: f64, y: f64| (x - y).abs() <= 1e-9 * x.abs().max(y.abs());
    let near_v = |x: DVec3, y: DVec3, scale: f64| (x - y).length() <= 1e-9 * scale;
    let unit_ok = near(a.unit, b.unit);
    let axes = near_v(a.e1, b.e1, 1.0) && near_v(a.e2, b.e2, 1.0) && near_v(a.e3, b.e3, 1.0);
    let kind = match (a.kind, b.kind) {
        (ChartKind::Parallel { origin: p }, ChartKind::Parallel { origin: q }) => {
            near_v(p, q, p.length().max(q.length()) + b.unit)
        }
        (
            ChartKind::Perspective { light: p, scale: s },
            ChartKind::Perspective { light: q, scale: t },
        ) => near_v(p, q, p.length().max(q.length()) + b.unit) && near(s, t),
        _ => false,
    };
    unit_ok && axes && kind && a.lateral == b.lateral
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(name: &str, pairs: &[(&str, &str)]) -> (String, GridMeta) {
        let mut m: GridMeta = [
            ("murk:placement", "sun:0.6,1,0.5"),
            ("murk:density_hash", "00ff"),
            ("murk:chart", "0/1"),
            ("murk:lattice_step", "0.4"),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
        for (k, v) in pairs {
            m.insert(k.to_string(), v.to_string());
        }
        (name.to_string(), m)
    }

    #[test]
    fn grids_that_disagree_are_named() {
        let ok = [grid("dsm_sun0_c0_bricks", &[]), grid("dsm_sun0_c0_L0", &[])];
        check_consistent("sun0", &ok).unwrap();
        let hash = [
            grid("dsm_sun0_c0_bricks", &[]),
            grid("dsm_sun0_c0_L0", &[("murk:density_hash", "0100")]),
        ];
        let e = check_consistent("sun0", &hash).unwrap_err();
        assert!(
            e.contains("grid dsm_sun0_c0_L0 has murk:density_hash \"0100\""),
            "{e}"
        );
        let chart = [grid("dsm_sun0_c0_bricks", &[("murk:chart", "1/1")])];
        let e = check_consistent("sun0", &chart).unwrap_err();
        assert!(e.contains("its murk:chart \"1/1\" is not the chart"), "{e}");
        let step = [
            grid("dsm_sun0_c0_bricks", &[]),
            grid("dsm_sun0_c0_dark", &[("murk:lattice_step", "1e3")]),
        ];
        assert!(
            check_consistent("sun0", &step)
                .unwrap_err()
                .contains("lattice_step")
        );
    }

    #[test]
    fn long_binary_names_are_shortened() {
        let name: String = (0..650).map(|i| char::from((i % 32) as u8)).collect();
        let s = shown(&name);
        assert!(s.chars().count() < 70, "{s}");
        assert!(s.ends_with("(650 bytes)"), "{s}");
        assert!(!s.chars().any(char::is_control), "{s}");
    }
}
