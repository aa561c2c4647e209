//! `murk info MESH.vtu|MESH.vtk`: points, cells by type, bounds, point and cell data
//! arrays (name, components, range) and what loading the mesh for rendering found.

use anyhow::Result;
use murk::field::mesh::MeshGeometry;
use murk::vtk::{MeshError, read_mesh};
use serde_json::{Value, json};
use std::path::Path;

pub fn run(path: &Path, as_json: bool) -> Result<()> {
    let mesh = read_mesh(path)?;
    let geometry = MeshGeometry::new(&mesh).map_err(|e| MeshError::new(path, e))?;
    let (lo, hi) = mesh.bounds();
    let arrays = |list: &[murk::vtk::DataArray]| -> Vec<Value> {
        list.iter()
            .map(|a| {
                let (mn, mx) = a
                    .range()
                    .map_or((Value::Null, Value::Null), |(a, b)| (json!(a), json!(b)));
                json!({"name": a.name, "components": a.components, "min": mn, "max": mx})
            })
            .collect()
    };
    let cells: serde_json::Map<String, Value> = mesh
        .cells_by_type()
        .into_iter()
        .map(|(t, n)| (t.name().to_string(), json!(n)))
        .collect();
    let doc = json!({
        "file": path.display().to_string(),
        "format": path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase(),
        "points": mesh.points.len(),
        "cells": mesh.cells(),
        "cells_by_type": cells,
        "bounds": [lo, hi],
        "point_data": arrays(&mesh.point_data),
        "cell_data": arrays(&mesh.cell_data),
        "load": geometry.report(),
        "memory_bytes": geometry.memory_bytes(),
    });
    let text = if as_json {
        serde_json::to_string_pretty(&doc)? + "\n"
    } else {
        table(&doc)
    };
    super::print_stdout(&text)
}

fn table(doc: &Value) -> String {
    let mut s = String::new();
    let num = |v: &Value| match v.as_f64() {
        Some(x) => format!("{x:.6}"),
        None => "-".to_string(),
    };
    s += &format!("file    {}\n", doc["file"].as_str().unwrap_or(""));
    s += &format!("points  {}\n", doc["points"]);
    s += &format!("cells   {}", doc["cells"]);
    if let Some(m) = doc["cells_by_type"].as_object() {
        let parts: Vec<String> = m.iter().map(|(k, v)| format!("{v} {k}")).collect();
        s += &format!(" ({})", parts.join(", "));
    }
    s += "\n";
    let b = &doc["bounds"];
    s += &format!(
        "bounds  [{}, {}, {}] .. [{}, {}, {}]\n",
        num(&b[0][0]),
        num(&b[0][1]),
        num(&b[0][2]),
        num(&b[1][0]),
        num(&b[1][1]),
        num(&b[1][2])
    );
    for (kind, key) in [("point data", "point_data"), ("cell data", "cell_data")] {
        let list = doc[key].as_array().cloned().unwrap_or_default();
        s += &format!("{kind} ({})\n", list.len());
        for a in list {
            s += &format!(
                "  {:<20} {} comp  range [{}, {}]\n",
                a["name"].as_str().unwrap_or(""),
                a["components"],
                num(&a["min"]),
                num(&a["max"])
            );
        }
    }
    let l = &doc["load"];
    s += &format!(
        "load    {} tetrahedra, {} boundary faces; {} degenerate, {} inverted cells; {} flat tetrahedra; {} non-manifold faces\n",
        l["tetrahedra"],
        l["boundary_faces"],
        l["degenerate_cells"],
        l["inverted_cells"],
        l["flat_tetrahedra"],
        l["non_manifold_faces"]
    );
    s
}
