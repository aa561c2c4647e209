//! `murk info` on meshes (against what VTK reports, fixtures/reference.json), and bad
//! mesh files: truncated, wrong byte order, connectivity out of range, unknown cell
//! types, arrays of the wrong length, absurd declared sizes — each one line
//! `murk: error: FILE: problem` and exit code 2.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
}

fn murk(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_murk"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn info_json_reports_what_vtk_reads() {
    let r: Value =
        serde_json::from_str(&std::fs::read_to_string(fixture("reference.json")).unwrap()).unwrap();
    for name in [
        "tets_ascii.vtu",
        "tets_binary.vtk",
        "mixed_appended.vtu",
        "mixed_ascii.vtk",
        "graded.vtu",
    ] {
        let want = &r["meshes"]["files"][name];
        let (code, out, err) = murk(&["info", fixture(name).to_str().unwrap(), "--json"]);
        assert_eq!(code, 0, "{name}: {err}");
        let doc: Value = serde_json::from_str(&out).unwrap();
        assert_eq!(doc["points"], want["points"], "{name}");
        assert_eq!(doc["cells_by_type"], want["cells"], "{name}");
        for a in 0..3 {
            assert_eq!(
                doc["bounds"][0][a].as_f64(),
                want["bounds"][2 * a].as_f64(),
                "{name}"
            );
            assert_eq!(
                doc["bounds"][1][a].as_f64(),
                want["bounds"][2 * a + 1].as_f64(),
                "{name}"
            );
        }
        for key in ["point_data", "cell_data"] {
            let arrays = doc[key].as_array().unwrap();
            assert_eq!(
                arrays.len(),
                want[key].as_object().unwrap().len(),
                "{name} {key}"
            );
            for a in arrays {
                let w = &want[key][a["name"].as_str().unwrap()];
                assert_eq!(a["components"], w["components"]);
                for m in ["min", "max"] {
                    let (g, e) = (a[m].as_f64().unwrap(), w[m].as_f64().unwrap());
                    assert!(
                        (g - e).abs() <= 1e-12 * (1.0 + e.abs()),
                        "{name} {key} {m}: {g} vs {e}"
                    );
                }
            }
        }
        assert_eq!(doc["load"]["degenerate_cells"], 0);
        assert_eq!(doc["load"]["inverted_cells"], 0);
    }
    let (code, out, _) = murk(&["info", fixture("mixed_zlib.vtu").to_str().unwrap()]);
    assert_eq!(code, 0);
    assert!(out.contains("10 hexahedron, 6 pyramid, 2 wedge"), "{out}");
}

/// Writes `bytes` as `name` in a fresh directory and runs `murk info` on it: exit 2
/// and one line naming the file and containing `problem`.
fn refuses(dir: &Path, name: &str, bytes: &[u8], problem: &str) {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    let p = path.to_str().unwrap();
    let (code, out, err) = murk(&["info", p, "--json"]);
    assert_eq!(code, 2, "{name}: exit {code}, stdout {out}, stderr {err}");
    assert!(out.is_empty(), "{name}: {out}");
    let line = err.strip_suffix('\n').unwrap_or(&err);
    assert!(!line.contains('\n'), "{name}: more than one line: {err}");
    assert!(
        line.starts_with(&format!("murk: error: {p}: ")),
        "{name}: {line}"
    );
    assert!(
        line.contains(problem),
        "{name}: expected '{problem}' in: {line}"
    );
}

fn replace(b: &[u8], from: &str, to: &str) -> Vec<u8> {
    let s = String::from_utf8_lossy(b);
    assert!(s.contains(from), "{from}");
    s.replacen(from, to, 1).into_bytes()
}

#[test]
fn bad_mesh_files_are_one_line_and_exit_2() {
    let dir =
        Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("mesh-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let read = |n: &str| std::fs::read(fixture(n)).unwrap();
    // Truncated: binary legacy, inline zlib, appended raw, ASCII legacy.
    let b = read("tets_binary.vtk");
    refuses(&dir, "trunc_binary.vtk", &b[..b.len() / 2], "truncated");
    let b = read("tets_zlib.vtu");
    refuses(&dir, "trunc_zlib.vtu", &b[..b.len() * 2 / 3], "");
    let b = read("tets_appended.vtu");
    refuses(&dir, "trunc_appended.vtu", &b[..b.len() - 400], "truncated");
    let b = read("mixed_ascii.vtk");
    refuses(&dir, "trunc_ascii.vtk", &b[..b.len() / 3], "truncated");
    // Wrong byte order: the binary header's sizes no longer match the arrays.
    let b = read("tets_binary.vtu");
    refuses(
        &dir,
        "big_endian.vtu",
        &replace(&b, "LittleEndian", "BigEndian"),
        "wrong byte order",
    );
    let b = read("mixed_appended.vtu");
    refuses(
        &dir,
        "big_endian_appended.vtu",
        &replace(&b, "LittleEndian", "BigEndian"),
        "wrong byte order",
    );
    // Connectivity out of range.
    let b = read("mixed_ascii.vtk");
    refuses(
        &dir,
        "conn.vtk",
        &replace(
            &b,
            "CONNECTIVITY vtktypeint64\n2\n",
            "CONNECTIVITY vtktypeint64\n9999\n",
        ),
        "out of range",
    );
    let b = read("tets_ascii.vtu");
    let s = String::from_utf8_lossy(&b);
    let at = s.find("Name=\"connectivity\"").unwrap();
    let gt = at + s[at..].find('>').unwrap() + 1;
    let mut t = s.to_string();
    t.insert_str(gt, "\n-3 ");
    // One more value than expected: the first is -3, the last one dropped.
    let t = {
        let end = gt + t[gt..].find("</DataArray>").unwrap();
        let body: Vec<&str> = t[gt..end].split_whitespace().collect();
        let body = body[..body.len() - 1].join(" ");
        format!("{}{}{}", &t[..gt], body, &t[end..])
    };
    refuses(&dir, "negative.vtu", t.as_bytes(), "out of range");
    // Unknown cell types, named.
    let b = read("mixed_ascii.vtk");
    let s = String::from_utf8_lossy(&b);
    let at = s.find("CELL_TYPES 18\n").unwrap() + "CELL_TYPES 18\n".len();
    let mut t = s.to_string();
    t.replace_range(at..at + 2, "42");
    refuses(
        &dir,
        "polyhedron.vtk",
        t.as_bytes(),
        "unknown cell type 42 (VTK_POLYHEDRON)",
    );
    t.replace_range(at..at + 2, " 5");
    refuses(
        &dir,
        "triangle.vtk",
        t.as_bytes(),
        "unknown cell type 5 (VTK_TRIANGLE)",
    );
    // Arrays of the wrong length.
    refuses(
        &dir,
        "short_array.vtk",
        &replace(
            &read("mixed_ascii.vtk"),
            "density 1 37 double",
            "density 1 36 double",
        ),
        "36 tuples, expected 37",
    );
    let b = read("tets_ascii.vtu");
    refuses(
        &dir,
        "points.vtu",
        &replace(&b, "NumberOfPoints=\"125\"", "NumberOfPoints=\"124\""),
        "",
    );
    // Absurd declared sizes: refused before allocating.
    refuses(&dir, "huge.vtk", b"# vtk DataFile Version 2.0\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4000000000000 double\n0 0 0\n", "truncated");
    let b = read("tets_zlib.vtu");
    refuses(
        &dir,
        "huge.vtu",
        &replace(
            &b,
            "NumberOfPoints=\"125\"",
            "NumberOfPoints=\"90000000000000\"",
        ),
        "more than a",
    );
    // Not a mesh at all.
    refuses(&dir, "empty.vtu", b"", "no <VTKFile>");
    refuses(&dir, "empty.vtk", b"", "truncated");
    let _ = std::fs::remove_dir_all(&dir);
}
