//! Legacy VTK files (`.vtk`): `DATASET UNSTRUCTURED_GRID`, ASCII or BINARY
//! (big-endian), the old `CELLS n size` list (versions 2–4) and the `OFFSETS` /
//! `CONNECTIVITY` pair (5.x), with `SCALARS`, `VECTORS`, `NORMALS`, `TENSORS` and
//! `FIELD` attributes.

use super::data::{Numbers, Scalar, decode_binary, parse_ascii, short};
use super::{DataArray, RawMesh};

struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
    binary: bool,
}

impl<'a> Cursor<'a> {
    /// The next non-blank line, trimmed, or `None` at the end.
    fn line(&mut self) -> Option<String> {
        while self.pos < self.bytes.len() {
            let rest = &self.bytes[self.pos..];
            let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
            self.pos += (end + 1).min(rest.len());
            let l = String::from_utf8_lossy(&rest[..end]).trim().to_string();
            if !l.is_empty() {
                return Some(l);
            }
        }
        None
    }

    fn need_line(&mut self, what: &str) -> Result<String, String> {
        self.line()
            .ok_or_else(|| format!("truncated: the file ends where {what} should be"))
    }

    /// `count` values of `ty` at the cursor.
    fn values(&mut self, ty: Scalar, count: usize, what: &str) -> Result<Numbers, String> {
        let rest = &self.bytes[self.pos..];
        if self.binary {
            let need = count.saturating_mul(ty.size());
            if need > rest.len() {
                return Err(format!(
                    "{what}: truncated ({} bytes left where {count} values need {need})",
                    rest.len()
                ));
            }
            let v = decode_binary(rest, ty, count, true, what)?;
            self.pos += need;
            Ok(v)
        } else {
            // An ASCII number takes at least two bytes with its separator.
            if count > rest.len() / 2 + 1 {
                return Err(format!(
                    "{what}: truncated ({} bytes left cannot hold {count} values)",
                    rest.len()
                ));
            }
            let mut at = 0usize;
            let mut tokens = std::iter::from_fn(|| {
                while at < rest.len() && rest[at].is_ascii_whitespace() {
                    at += 1;
                }
                if at >= rest.len() {
                    return None;
                }
                let s = at;
                while at < rest.len() && !rest[at].is_ascii_whitespace() {
                    at += 1;
                }
                Some(std::str::from_utf8(&rest[s..at]).unwrap_or("?"))
            });
            let v = parse_ascii(&mut tokens, ty, count, what);
            self.pos += at;
            let v = v?;
            Ok(v)
        }
    }
}

fn word<'a>(w: &[&'a str], i: usize, line: &str) -> Result<&'a str, String> {
    w.get(i)
        .copied()
        .ok_or_else(|| format!("'{}' is missing a field", short(line)))
}

fn count(w: &[&str], i: usize, line: &str) -> Result<usize, String> {
    word(w, i, line)?
        .parse()
        .map_err(|_| format!("'{}': not a count", short(line)))
}

fn scalar(w: &[&str], i: usize, line: &str) -> Result<Scalar, String> {
    let t = word(w, i, line)?;
    Scalar::parse(t).ok_or_else(|| format!("unknown data type '{t}'"))
}

pub fn read(bytes: &[u8]) -> Result<RawMesh, String> {
    let mut c = Cursor {
        bytes,
        pos: 0,
        binary: false,
    };
    let first = c.need_line("the '# vtk DataFile Version' line")?;
    let version: f64 = first
        .strip_prefix("# vtk DataFile Version")
        .ok_or("not a legacy VTK file (no '# vtk DataFile Version' line)")?
        .trim()
        .parse()
        .map_err(|_| format!("bad version line '{}'", short(&first)))?;
    // The title line may be empty: take the raw next line.
    let rest = &bytes[c.pos..];
    let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
    c.pos += (end + 1).min(rest.len());
    match c.need_line("ASCII or BINARY")?.as_str() {
        "ASCII" => c.binary = false,
        "BINARY" => c.binary = true,
        other => {
            return Err(format!(
                "expected ASCII or BINARY, found '{}'",
                short(other)
            ));
        }
    }
    let mut mesh = RawMesh::default();
    let mut saw_dataset = false;
    let mut cells_seen = false;
    // Attribute target: (is point data, tuple count).
    let mut target: Option<(bool, usize)> = None;
    while let Some(line) = c.line() {
        let w: Vec<&str> = line.split_whitespace().collect();
        let key = w[0].to_ascii_uppercase();
        match key.as_str() {
            "DATASET" => {
                let kind = word(&w, 1, &line)?;
                if !kind.eq_ignore_ascii_case("UNSTRUCTURED_GRID") {
                    return Err(format!("DATASET {kind}, expected UNSTRUCTURED_GRID"));
                }
                saw_dataset = true;
            }
            "POINTS" => {
                let n = count(&w, 1, &line)?;
                let ty = scalar(&w, 2, &line)?;
                let n3 = n.checked_mul(3).ok_or("POINTS count overflows")?;
                mesh.points = c.values(ty, n3, "POINTS")?.into_f64();
            }
            "CELLS" => {
                let a = count(&w, 1, &line)?;
                let b = count(&w, 2, &line)?;
                cells_seen = true;
                if version >= 5.0 {
                    let l = c.need_line("OFFSETS")?;
                    let ow: Vec<&str> = l.split_whitespace().collect();
                    if ow[0] != "OFFSETS" {
                        return Err(format!(
                            "expected OFFSETS after CELLS, found '{}'",
                            short(&l)
                        ));
                    }
                    let offs = c
                        .values(scalar(&ow, 1, &l)?, a, "OFFSETS")?
                        .into_ints("OFFSETS")?;
                    let l = c.need_line("CONNECTIVITY")?;
                    let cw: Vec<&str> = l.split_whitespace().collect();
                    if cw[0] != "CONNECTIVITY" {
                        return Err(format!(
                            "expected CONNECTIVITY after OFFSETS, found '{}'",
                            short(&l)
                        ));
                    }
                    mesh.connectivity = c
                        .values(scalar(&cw, 1, &l)?, b, "CONNECTIVITY")?
                        .into_ints("CONNECTIVITY")?;
                    if offs.first().copied().unwrap_or(0) != 0 {
                        return Err("OFFSETS does not start at 0".into());
                    }
                    mesh.ends = offs.into_iter().skip(1).collect();
                } else {
                    let list = c.values(Scalar::I32, b, "CELLS")?.into_ints("CELLS")?;
                    let mut at = 0usize;
                    mesh.ends = Vec::with_capacity(a.min(list.len()));
                    for i in 0..a {
                        let n = *list
                            .get(at)
                            .ok_or_else(|| format!("CELLS list ends before cell {i}"))?;
                        if n < 0 || at + 1 + n as usize > list.len() {
                            return Err(format!(
                                "CELLS: cell {i} claims {n} points, past the list"
                            ));
                        }
                        mesh.connectivity
                            .extend_from_slice(&list[at + 1..at + 1 + n as usize]);
                        mesh.ends.push(mesh.connectivity.len() as i64);
                        at += 1 + n as usize;
                    }
                    if at != list.len() {
                        return Err(format!("CELLS size {b} but the cells use {at}"));
                    }
                }
            }
            "CELL_TYPES" => {
                let n = count(&w, 1, &line)?;
                mesh.types = c
                    .values(Scalar::I32, n, "CELL_TYPES")?
                    .into_ints("CELL_TYPES")?;
            }
            "POINT_DATA" => target = Some((true, count(&w, 1, &line)?)),
            "CELL_DATA" => target = Some((false, count(&w, 1, &line)?)),
            "SCALARS"
            | "VECTORS"
            | "NORMALS"
            | "TENSORS"
            | "TEXTURE_COORDINATES"
            | "COLOR_SCALARS" => {
                let (is_point, n) =
                    target.ok_or_else(|| format!("{key} before POINT_DATA or CELL_DATA"))?;
                let name = word(&w, 1, &line)?.to_string();
                let (ty, comps) = match key.as_str() {
                    "SCALARS" => {
                        let comps = match w.get(3) {
                            Some(s) => s
                                .parse()
                                .map_err(|_| format!("'{}': bad component count", short(&line)))?,
                            None => 1,
                        };
                        (scalar(&w, 2, &line)?, comps)
                    }
                    "VECTORS" | "NORMALS" => (scalar(&w, 2, &line)?, 3),
                    "TENSORS" => (scalar(&w, 2, &line)?, 9),
                    "TEXTURE_COORDINATES" => (scalar(&w, 3, &line)?, count(&w, 2, &line)?),
                    _ => {
                        let ty = if c.binary { Scalar::U8 } else { Scalar::F32 };
                        (ty, count(&w, 2, &line)?)
                    }
                };
                if !(1..=64).contains(&comps) {
                    return Err(format!("{key} {name}: {comps} components"));
                }
                if key == "SCALARS" {
                    // "LOOKUP_TABLE name" follows (required by the format).
                    let save = c.pos;
                    match c.line() {
                        Some(l) if l.starts_with("LOOKUP_TABLE") => {}
                        _ => c.pos = save,
                    }
                }
                let values = c.values(ty, n.checked_mul(comps).ok_or("overflow")?, &name)?;
                push(&mut mesh, is_point, name, comps, values.into_f64());
            }
            "FIELD" => {
                let (is_point, n) = target.ok_or("FIELD before POINT_DATA or CELL_DATA")?;
                let arrays = count(&w, 2, &line)?;
                for _ in 0..arrays {
                    let l = c.need_line("a FIELD array")?;
                    let aw: Vec<&str> = l.split_whitespace().collect();
                    if aw[0] == "NULL_ARRAY" {
                        continue;
                    }
                    let name = aw[0].to_string();
                    let comps = count(&aw, 1, &l)?;
                    let tuples = count(&aw, 2, &l)?;
                    let ty = scalar(&aw, 3, &l)?;
                    if !(1..=64).contains(&comps) {
                        return Err(format!("FIELD array {name}: {comps} components"));
                    }
                    if tuples != n {
                        return Err(format!(
                            "{} data array '{name}' has {tuples} tuples, expected {n}",
                            if is_point { "point" } else { "cell" }
                        ));
                    }
                    let values = c.values(ty, comps * tuples, &name)?;
                    push(&mut mesh, is_point, name, comps, values.into_f64());
                    skip_metadata(&mut c);
                }
            }
            "LOOKUP_TABLE" => {
                let n = count(&w, 2, &line)?;
                let ty = if c.binary { Scalar::U8 } else { Scalar::F32 };
                c.values(ty, n.checked_mul(4).ok_or("overflow")?, "LOOKUP_TABLE")?;
            }
            "METADATA" => {
                // Until a blank line.
                while c.pos < bytes.len() {
                    let rest = &bytes[c.pos..];
                    let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
                    c.pos += (end + 1).min(rest.len());
                    if rest[..end].iter().all(|b| b.is_ascii_whitespace()) {
                        break;
                    }
                }
            }
            "FIELD_DATA" | "DATASET_FIELD" => {}
            _ => {
                return Err(format!(
                    "unexpected '{}' in a legacy VTK file",
                    short(&line)
                ));
            }
        }
    }
    if !saw_dataset {
        return Err("no DATASET UNSTRUCTURED_GRID".into());
    }
    if !cells_seen && !mesh.points.is_empty() {
        return Err("no CELLS section".into());
    }
    Ok(mesh)
}

/// Skips a `METADATA` block after a FIELD array, if there is one.
fn skip_metadata(c: &mut Cursor) {
    let save = c.pos;
    match c.line() {
        Some(l) if l == "METADATA" => {
            while c.pos < c.bytes.len() {
                let rest = &c.bytes[c.pos..];
                let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
                c.pos += (end + 1).min(rest.len());
                if rest[..end].iter().all(|b| b.is_ascii_whitespace()) {
                    break;
                }
            }
        }
        _ => c.pos = save,
    }
}

fn push(mesh: &mut RawMesh, is_point: bool, name: String, components: usize, values: Vec<f64>) {
    let a = DataArray {
        name,
        components,
        values,
    };
    if is_point {
        mesh.point_data.push(a);
    } else {
        mesh.cell_data.push(a);
    }
}
