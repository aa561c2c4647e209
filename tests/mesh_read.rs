//! The mesh readers against VTK: every fixture variant (written by meshio and by VTK's
//! own XML writer) reads to the point count, cells by type, bounds and array ranges
//! that VTK 9 reports for it (`fixtures/reference.json`, key `meshes`).

use murk::vtk::read_mesh;
use serde_json::Value;

fn reference() -> Value {
    let root = env!("CARGO_MANIFEST_DIR");
    let text = std::fs::read_to_string(format!("{root}/fixtures/reference.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * (1.0 + a.abs().max(b.abs()))
}

#[test]
fn every_variant_reads_as_vtk_reads_it() {
    let r = reference();
    let files = r["meshes"]["files"].as_object().unwrap();
    assert!(files.len() >= 11, "{} mesh fixtures", files.len());
    for (name, want) in files {
        let path = format!("{}/fixtures/{name}", env!("CARGO_MANIFEST_DIR"));
        let m = read_mesh(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            m.points.len() as u64,
            want["points"].as_u64().unwrap(),
            "{name}"
        );
        let by_type: std::collections::BTreeMap<String, u64> = m
            .cells_by_type()
            .into_iter()
            .map(|(t, n)| (t.name().to_string(), n as u64))
            .collect();
        let want_types: std::collections::BTreeMap<String, u64> = want["cells"]
            .as_object()
            .unwrap()
            .iter()
            .map(|(k, v)| (k.clone(), v.as_u64().unwrap()))
            .collect();
        assert_eq!(by_type, want_types, "{name}");
        let (lo, hi) = m.bounds();
        let b: Vec<f64> = want["bounds"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        for a in 0..3 {
            assert!(
                close(lo[a], b[2 * a]) && close(hi[a], b[2 * a + 1]),
                "{name} bounds"
            );
        }
        for (kind, arrays) in [("point_data", &m.point_data), ("cell_data", &m.cell_data)] {
            let w = want[kind].as_object().unwrap();
            assert_eq!(arrays.len(), w.len(), "{name} {kind}");
            for a in arrays {
                let wa = &w[&a.name];
                assert_eq!(a.components as u64, wa["components"].as_u64().unwrap());
                let (mn, mx) = a.range().unwrap();
                assert!(
                    close(mn, wa["min"].as_f64().unwrap())
                        && close(mx, wa["max"].as_f64().unwrap()),
                    "{name} {}: ({mn}, {mx}) vs {wa}",
                    a.name
                );
            }
        }
    }
}
