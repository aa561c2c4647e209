//! `murk info`: a table or JSON description of a .vdb file.

use anyhow::Result;
use glam::{DMat4, DVec3, IVec3};
use murk::field::VoxelGrid;
use murk::vdb::{GridInfo, ValueKind, VdbFile};
use serde_json::{Value, json};
use std::path::Path;

pub fn run(path: &Path, stats: bool, as_json: bool) -> Result<()> {
    let file = VdbFile::open(path)?;
    let mut grids = Vec::new();
    for g in file.grids() {
        let built = if stats && g.kind != ValueKind::Unsupported {
            Some(VoxelGrid::load(&file, &g.unique_name)?)
        } else {
            None
        };
        grids.push(grid_json(g, built.as_ref()));
    }
    let doc = json!({
        "file": path.display().to_string(),
        "file_version": file.file_version,
        "library_version": file.library_version,
        "metadata": file.metadata.iter().map(|(k, v)| (k.clone(), Value::String(v.clone()))).collect::<serde_json::Map<_, _>>(),
        "grids": grids,
    });
    let text = if as_json {
        serde_json::to_string_pretty(&doc)? + "\n"
    } else {
        table(&doc)
    };
    super::print_stdout(&text)
}

fn world_bbox(m: DMat4, lo: IVec3, hi: IVec3) -> (DVec3, DVec3) {
    let mut a = DVec3::splat(f64::INFINITY);
    let mut b = DVec3::splat(f64::NEG_INFINITY);
    for c in 0..8 {
        let p = DVec3::new(
            if c & 1 == 0 { lo.x } else { hi.x } as f64,
            if c & 2 == 0 { lo.y } else { hi.y } as f64,
            if c & 4 == 0 { lo.z } else { hi.z } as f64,
        );
        let w = m.transform_point3(p);
        a = a.min(w);
        b = b.max(w);
    }
    (a, b)
}

fn scalar_or_vec(v: &[f64]) -> Value {
    if v.len() == 1 { json!(v[0]) } else { json!(v) }
}

fn grid_json(g: &GridInfo, built: Option<&VoxelGrid>) -> Value {
    let matrix = g.index_to_world.map(|m| {
        let r = m.transpose().to_cols_array_2d();
        json!(r)
    });
    let (count, bbox) = match built {
        Some(b) => (
            Some(b.stats().active_voxels),
            b.stats()
                .active_index_bbox
                .map(|(a, c)| (IVec3::from_array(a), IVec3::from_array(c))),
        ),
        None => (g.file_voxel_count, g.file_bbox),
    };
    let world = match (bbox, g.index_to_world) {
        (Some((lo, hi)), Some(m)) => {
            let (a, b) = world_bbox(m, lo, hi);
            json!([a.to_array(), b.to_array()])
        }
        _ => Value::Null,
    };
    let mut o = json!({
        "name": g.name,
        "unique_name": g.unique_name,
        "value_type": g.value_type,
        "renderable": g.kind != ValueKind::Unsupported,
        "class": g.class,
        "half": g.half,
        "compression": g.compression,
        "map_type": g.map_type,
        "voxel_size": g.voxel_size().map(|v| v.to_array()),
        "index_to_world": matrix,
        "instance_of": g.instance_of,
        "active_voxel_count": count,
        "index_bbox": bbox.map(|(a, b)| [a.to_array(), b.to_array()]),
        "world_bbox": world,
        "tile_count": built.map(|b| b.stats().active_tiles()),
        "metadata": g.metadata.iter().map(|(k, v)| (k.clone(), Value::String(v.clone()))).collect::<serde_json::Map<_, _>>(),
    });
    if let Some(b) = built {
        let s = b.stats();
        o["stats"] = json!({
            "active_voxel_count": s.active_voxels,
            "leaf_count": s.leaves,
            "active_tile_count": s.active_tiles(),
            "active_tiles_by_level": {"1": s.active_tiles_by_level[0], "2": s.active_tiles_by_level[1], "3": s.active_tiles_by_level[2]},
            "min": if s.min.is_empty() { Value::Null } else { scalar_or_vec(&s.min) },
            "max": if s.max.is_empty() { Value::Null } else { scalar_or_vec(&s.max) },
            "mean": if s.sum.is_empty() { Value::Null } else { scalar_or_vec(&s.mean()) },
            "sum": if s.sum.is_empty() { Value::Null } else { scalar_or_vec(&s.sum) },
            "nan_count": s.nan,
            "inf_count": s.inf,
            "negative_count": s.negative,
            "render_memory_bytes": b.memory_bytes(),
        });
    }
    o
}

fn text(v: &Value) -> String {
    match v {
        Value::Null => "-".to_string(),
        Value::String(s) => s.clone(),
        Value::Array(a) => format!("({})", a.iter().map(text).collect::<Vec<_>>().join(", ")),
        Value::Number(n) => match n.as_f64() {
            Some(f) if n.is_f64() && (f == 0.0 || (1e-4..1e15).contains(&f.abs())) => {
                format!("{f:.6}")
            }
            Some(f) if n.is_f64() => murk::vdb::guard::number_text(f),
            _ => n.to_string(),
        },
        other => other.to_string(),
    }
}

macro_rules! wl {
    ($o:expr, $($t:tt)*) => {{ let _ = writeln!($o, $($t)*); }};
}

fn table(doc: &Value) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    wl!(out, "file:            {}", text(&doc["file"]));
    wl!(
        out,
        "file version:    {}   library {}",
        text(&doc["file_version"]),
        text(&doc["library_version"])
    );
    if let Some(m) = doc["metadata"].as_object() {
        for (k, v) in m {
            wl!(out, "  {k}: {}", text(v));
        }
    }
    let Some(grids) = doc["grids"].as_array() else {
        return out;
    };
    for g in grids {
        wl!(out, "");
        wl!(out, "grid \"{}\"", text(&g["unique_name"]));
        let row = |out: &mut String, k: &str, v: String| wl!(out, "  {k:<18}{v}");
        row(
            &mut out,
            "value type",
            format!(
                "{}{}",
                text(&g["value_type"]),
                if g["renderable"] == json!(false) {
                    " (not renderable)"
                } else {
                    ""
                }
            ),
        );
        row(&mut out, "class", text(&g["class"]));
        row(
            &mut out,
            "storage",
            if g["half"] == json!(true) {
                "half".into()
            } else {
                "float".into()
            },
        );
        row(&mut out, "compression", text(&g["compression"]));
        row(&mut out, "active voxels", text(&g["active_voxel_count"]));
        row(
            &mut out,
            "tiles",
            if g["tile_count"].is_null() {
                "- (needs --stats)".into()
            } else {
                text(&g["tile_count"])
            },
        );
        row(&mut out, "index bbox", text(&g["index_bbox"]));
        row(&mut out, "world bbox", text(&g["world_bbox"]));
        row(&mut out, "voxel size", text(&g["voxel_size"]));
        row(&mut out, "map", text(&g["map_type"]));
        if let Some(rows) = g["index_to_world"].as_array() {
            for (i, r) in rows.iter().enumerate() {
                row(&mut out, if i == 0 { "index→world" } else { "" }, text(r));
            }
        }
        if let Some(s) = g.get("stats") {
            row(&mut out, "leaves", text(&s["leaf_count"]));
            row(
                &mut out,
                "tiles by level",
                text(&json!([
                    s["active_tiles_by_level"]["1"],
                    s["active_tiles_by_level"]["2"],
                    s["active_tiles_by_level"]["3"]
                ])),
            );
            row(
                &mut out,
                "min / max",
                format!("{} / {}", text(&s["min"]), text(&s["max"])),
            );
            row(&mut out, "mean", text(&s["mean"]));
            row(
                &mut out,
                "NaN/Inf/negative",
                format!(
                    "{} / {} / {}",
                    text(&s["nan_count"]),
                    text(&s["inf_count"]),
                    text(&s["negative_count"])
                ),
            );
            row(
                &mut out,
                "render memory",
                format!(
                    "{:.2} MiB",
                    s["render_memory_bytes"].as_f64().unwrap_or(0.0) / 1048576.0
                ),
            );
        }
    }
    out
}
