//! Every fixture, loaded by murk, against the numbers OpenVDB computed for it
//! (`fixtures/reference.json`, written by `scripts/make_fixtures.py`).

use glam::DVec3;
use murk::field::{Field, VoxelGrid};
use murk::vdb::{ValueKind, VdbFile};
use serde_json::Value;
use std::path::PathBuf;
use std::process::Command;

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures")
}

fn reference() -> Value {
    let text = std::fs::read_to_string(fixtures().join("reference.json"))
        .expect("fixtures/reference.json");
    serde_json::from_str(&text).expect("reference.json parses")
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * b.abs().max(1.0)
}

fn vec3(v: &Value) -> DVec3 {
    DVec3::new(
        v[0].as_f64().unwrap(),
        v[1].as_f64().unwrap(),
        v[2].as_f64().unwrap(),
    )
}

fn floats(v: &Value) -> Vec<f64> {
    match v {
        Value::Array(a) => a.iter().map(|x| x.as_f64().unwrap()).collect(),
        Value::Null => Vec::new(),
        x => vec![x.as_f64().unwrap()],
    }
}

#[test]
fn every_grid_matches_openvdb() {
    let reference = reference();
    let mut checked_grids = 0;
    let mut checked_samples = 0;
    for (file_name, file_ref) in reference["files"].as_object().unwrap() {
        let path = fixtures().join(file_name);
        let file = VdbFile::open(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            file.file_version as u64,
            file_ref["file_version"].as_u64().unwrap(),
            "{file_name}"
        );
        for (grid_name, r) in file_ref["grids"].as_object().unwrap() {
            let info = file.grid(grid_name).unwrap();
            let ctx = format!("{file_name}:{grid_name}");
            assert_eq!(info.value_type, r["value_type"].as_str().unwrap(), "{ctx}");
            assert_eq!(info.half, r["half"].as_bool().unwrap(), "{ctx}");
            assert!(
                info.compression
                    .starts_with(r["compression"].as_str().unwrap()),
                "{ctx}: {}",
                info.compression
            );
            if info.kind == ValueKind::Unsupported {
                continue;
            }
            assert_eq!(info.class, r["class"].as_str().unwrap(), "{ctx}");
            let m = info.index_to_world.unwrap();
            let rm = &r["index_to_world_matrix"];
            for row in 0..4 {
                for col in 0..4 {
                    let want = rm[row][col].as_f64().unwrap();
                    assert!(
                        (m.col(col)[row] - want).abs() <= 1e-12,
                        "{ctx}: matrix[{row}][{col}]"
                    );
                }
            }
            let grid = VoxelGrid::load(&file, grid_name).unwrap();
            let s = grid.stats();
            assert_eq!(
                s.active_voxels,
                r["active_voxel_count"].as_u64().unwrap(),
                "{ctx}: active voxels"
            );
            assert_eq!(s.leaves, r["leaf_count"].as_u64().unwrap(), "{ctx}: leaves");
            for (lvl, n) in s.active_tiles_by_level.iter().enumerate() {
                let want = r["active_tiles_by_level"][(lvl + 1).to_string()]
                    .as_u64()
                    .unwrap();
                assert_eq!(*n, want, "{ctx}: tiles at level {}", lvl + 1);
            }
            match &r["index_bbox"] {
                Value::Null => assert!(s.active_index_bbox.is_none(), "{ctx}"),
                b => {
                    let (lo, hi) = s.active_index_bbox.unwrap();
                    for a in 0..3 {
                        assert_eq!(lo[a] as i64, b[0][a].as_i64().unwrap(), "{ctx}: bbox min");
                        assert_eq!(hi[a] as i64, b[1][a].as_i64().unwrap(), "{ctx}: bbox max");
                    }
                }
            }
            if !r["min"].is_null() {
                for (got, want) in s.min.iter().zip(floats(&r["min"])) {
                    assert!(close(*got, want, 1e-6), "{ctx}: min {got} vs {want}");
                }
                for (got, want) in s.max.iter().zip(floats(&r["max"])) {
                    assert!(close(*got, want, 1e-6), "{ctx}: max {got} vs {want}");
                }
            }
            for (c, want) in floats(&r["sum"]).into_iter().enumerate() {
                let got = s.sum.get(c).copied().unwrap_or(0.0);
                assert!(close(got, want, 1e-6), "{ctx}: sum {got} vs {want}");
            }
            // Index → world of chosen voxels, through the render structure's own map.
            let t = grid.transform();
            for p in r["index_to_world"].as_array().unwrap() {
                let ijk = vec3(&p["ijk"]);
                let want = vec3(&p["xyz"]);
                let got = t.index_to_world(ijk - t.origin.as_dvec3());
                assert!(
                    (got - want).abs().max_element() <= 1e-9 * want.abs().max_element().max(1.0),
                    "{ctx}: {ijk} → {got} vs {want}"
                );
            }
            // Trilinear samples at world points. The blend is done in f32 (as OpenVDB's
            // BoxSampler does), so the error scales with the corner values: use the grid's
            // largest magnitude.
            let scale = floats(&r["max"])
                .iter()
                .chain(floats(&r["min"]).iter())
                .fold(1.0f64, |m, v| m.max(v.abs()));
            for p in r["samples"].as_array().unwrap() {
                let w = vec3(&p["xyz"]);
                let idx = t.world_to_index(w);
                let want = floats(&p["value"]);
                for (c, want) in want.iter().enumerate() {
                    let got = grid.sample_channel(idx, c) as f64;
                    assert!(
                        (got - want).abs() <= 1e-6 * scale,
                        "{ctx}: sample at {w} channel {c}: {got} vs {want}"
                    );
                }
                if want.len() == 1 {
                    assert!(
                        (grid.value_at_world(w) as f64 - want[0]).abs() <= 1e-6 * scale,
                        "{ctx}: value_at_world {w}"
                    );
                }
                checked_samples += 1;
            }
            checked_grids += 1;
        }
    }
    assert!(checked_grids >= 14, "only {checked_grids} grids checked");
    assert!(
        checked_samples >= 14 * 50,
        "only {checked_samples} samples checked"
    );
}

/// `murk info --stats --json` reports the same numbers (what other tools will read).
#[test]
fn info_json_matches_openvdb() {
    let reference = reference();
    for file_name in [
        "cloud.vdb",
        "pyro.vdb",
        "tiles.vdb",
        "far.vdb",
        "rotated.vdb",
        "bad_types.vdb",
        "empty.vdb",
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_murk"))
            .args(["info", "--stats", "--json"])
            .arg(fixtures().join(file_name))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{file_name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let doc: Value = serde_json::from_slice(&out.stdout).unwrap();
        let file_ref = &reference["files"][file_name];
        for g in doc["grids"].as_array().unwrap() {
            let name = g["name"].as_str().unwrap();
            let r = &file_ref["grids"][name];
            assert_eq!(g["value_type"], r["value_type"], "{file_name}:{name}");
            assert_eq!(g["half"], r["half"], "{file_name}:{name}");
            assert_eq!(g["class"], r["class"], "{file_name}:{name}");
            if g["renderable"] == Value::Bool(false) {
                assert!(g.get("stats").is_none());
                continue;
            }
            assert_eq!(
                g["active_voxel_count"], r["active_voxel_count"],
                "{file_name}:{name}"
            );
            assert_eq!(g["index_bbox"], r["index_bbox"], "{file_name}:{name}");
            assert_eq!(
                g["stats"]["leaf_count"], r["leaf_count"],
                "{file_name}:{name}"
            );
            assert_eq!(
                g["stats"]["active_tile_count"], r["active_tile_count"],
                "{file_name}:{name}"
            );
            for (got, want) in floats(&g["voxel_size"])
                .iter()
                .zip(floats(&r["voxel_size"]))
            {
                assert!(close(*got, want, 1e-12), "{file_name}:{name}: voxel size");
            }
            if let Value::Array(wb) = &r["world_bbox"] {
                for k in 0..2 {
                    let got = vec3(&g["world_bbox"][k]);
                    let want = vec3(&wb[k]);
                    assert!(
                        (got - want).abs().max_element()
                            <= 1e-9 * want.abs().max_element().max(1.0),
                        "{file_name}:{name}: world bbox"
                    );
                }
            }
        }
    }
}

/// Without --stats, info decodes no trees but still reports counts and boxes from the
/// metadata OpenVDB wrote.
#[test]
fn info_without_stats_reads_metadata_only() {
    let out = Command::new(env!("CARGO_BIN_EXE_murk"))
        .args(["info", "--json"])
        .arg(fixtures().join("cloud.vdb"))
        .output()
        .unwrap();
    assert!(out.status.success());
    let doc: Value = serde_json::from_slice(&out.stdout).unwrap();
    let g = &doc["grids"][0];
    assert!(g.get("stats").is_none());
    assert!(g["tile_count"].is_null());
    assert_eq!(
        g["active_voxel_count"],
        reference()["files"]["cloud.vdb"]["grids"]["density"]["active_voxel_count"]
    );
}

/// A grid name that does not exist: exit 2, one line naming the file, the grid, and the
/// grids that do exist.
#[test]
fn unsupported_and_missing_grids_are_clean_errors() {
    let file = VdbFile::open(fixtures().join("pyro.vdb")).unwrap();
    let e = VoxelGrid::load(&file, "dencity").unwrap_err().to_string();
    assert!(
        e.contains("pyro.vdb") && e.contains("dencity") && e.contains("density, temperature"),
        "{e}"
    );
    let file = VdbFile::open(fixtures().join("bad_types.vdb")).unwrap();
    for g in ["ival", "mask", "points"] {
        let e = VoxelGrid::load(&file, g).unwrap_err().to_string();
        assert!(
            e.contains("bad_types.vdb") && e.contains(g) && e.contains("cannot be rendered"),
            "{e}"
        );
    }
}
