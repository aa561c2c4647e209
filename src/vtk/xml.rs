//! VTK XML unstructured grids (`.vtu`): `format="ascii"`, `"binary"` (inline base64)
//! and `"appended"` (raw or base64 `AppendedData`), with or without
//! `vtkZLibDataCompressor`, UInt32 or UInt64 headers, little- or big-endian.
//!
//! The XML part is parsed with `quick-xml`; raw appended data is binary and not XML,
//! so the file is cut at `<AppendedData` and only what comes before is parsed.

use super::data::{
    BinaryLayout, Numbers, Scalar, decode_base64_block, decode_binary, decode_raw_block,
    parse_ascii,
};
use super::{DataArray, RawMesh};
use quick_xml::events::{BytesStart, Event};
use std::collections::HashMap;

#[derive(Clone, Copy, PartialEq, Debug)]
enum Section {
    None,
    PointData,
    CellData,
    Points,
    Cells,
}

struct ArrayDecl {
    section: Section,
    attrs: HashMap<String, String>,
    text: Vec<u8>,
}

fn attrs_of(e: &BytesStart) -> Result<HashMap<String, String>, String> {
    let mut out = HashMap::new();
    for a in e.attributes() {
        let a = a.map_err(|e| format!("bad XML attribute: {e}"))?;
        let k = String::from_utf8_lossy(a.key.as_ref()).into_owned();
        let v = String::from_utf8_lossy(&a.value).into_owned();
        out.insert(k, v);
    }
    Ok(out)
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

fn rfind(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).rposition(|w| w == needle)
}

/// The appended-data region (after `_`) and whether it is base64.
fn appended(bytes: &[u8], at: usize) -> Result<(&[u8], bool), String> {
    let rest = &bytes[at..];
    let close = find(rest, b">").ok_or("truncated <AppendedData> tag")?;
    let tag = String::from_utf8_lossy(&rest[..close]);
    let base64 = if tag.contains("encoding=\"base64\"") {
        true
    } else if tag.contains("encoding=\"raw\"") {
        false
    } else {
        return Err("<AppendedData> without encoding=\"raw\" or \"base64\"".into());
    };
    let after = &rest[close + 1..];
    let us = find(after, b"_").ok_or("<AppendedData> has no '_' before its data")?;
    let data = &after[us + 1..];
    let end = rfind(data, b"</AppendedData>")
        .ok_or("truncated: the file ends inside <AppendedData> (no </AppendedData>)")?;
    Ok((&data[..end], base64))
}

pub fn read(bytes: &[u8]) -> Result<RawMesh, String> {
    let app_at = find(bytes, b"<AppendedData");
    let head = &bytes[..app_at.unwrap_or(bytes.len())];
    let mut reader = quick_xml::Reader::from_reader(head);
    let mut file_attrs: Option<HashMap<String, String>> = None;
    let mut piece: Option<HashMap<String, String>> = None;
    let mut section = Section::None;
    let mut arrays: Vec<ArrayDecl> = Vec::new();
    let mut open_array: Option<ArrayDecl> = None;
    let mut closed = false;
    loop {
        let ev = reader.read_event().map_err(|e| {
            format!(
                "not valid VTK XML at byte {}: {e}",
                reader.buffer_position()
            )
        })?;
        match ev {
            Event::Start(ref e) | Event::Empty(ref e) => {
                let empty = matches!(ev, Event::Empty(_));
                match e.name().as_ref() {
                    b"VTKFile" => file_attrs = Some(attrs_of(e)?),
                    b"Piece" => {
                        if piece.is_some() {
                            return Err(
                                "more than one <Piece>: murk reads single-piece .vtu files".into(),
                            );
                        }
                        piece = Some(attrs_of(e)?)
                    }
                    b"PointData" if !empty => section = Section::PointData,
                    b"CellData" if !empty => section = Section::CellData,
                    b"Points" if !empty => section = Section::Points,
                    b"Cells" if !empty => section = Section::Cells,
                    b"DataArray" => {
                        let decl = ArrayDecl {
                            section,
                            attrs: attrs_of(e)?,
                            text: Vec::new(),
                        };
                        if empty {
                            arrays.push(decl);
                        } else {
                            open_array = Some(decl);
                        }
                    }
                    _ => {}
                }
            }
            Event::Text(t) => {
                if let Some(a) = open_array.as_mut() {
                    a.text.extend_from_slice(&t);
                }
            }
            Event::CData(t) => {
                if let Some(a) = open_array.as_mut() {
                    a.text.extend_from_slice(&t);
                }
            }
            Event::End(e) => match e.name().as_ref() {
                b"DataArray" => {
                    if let Some(a) = open_array.take() {
                        arrays.push(a);
                    }
                }
                b"PointData" | b"CellData" | b"Points" | b"Cells" => section = Section::None,
                b"VTKFile" => closed = true,
                _ => {}
            },
            Event::Eof => break,
            _ => {}
        }
    }
    let file = file_attrs.ok_or("no <VTKFile> element: not a VTK XML file")?;
    if open_array.is_some() || (app_at.is_none() && !closed) {
        return Err("truncated: the XML ends before </VTKFile>".into());
    }
    match file.get("type").map(String::as_str) {
        Some("UnstructuredGrid") => {}
        other => {
            return Err(format!(
                "VTKFile type {:?}, expected UnstructuredGrid",
                other.unwrap_or("(none)")
            ));
        }
    }
    let big = match file.get("byte_order").map(String::as_str) {
        None | Some("LittleEndian") => false,
        Some("BigEndian") => true,
        Some(o) => return Err(format!("unknown byte_order '{o}'")),
    };
    let header64 = match file.get("header_type").map(String::as_str) {
        None | Some("UInt32") => false,
        Some("UInt64") => true,
        Some(h) => return Err(format!("unknown header_type '{h}'")),
    };
    let zlib = match file.get("compressor").map(String::as_str) {
        None | Some("") => false,
        Some("vtkZLibDataCompressor") => true,
        Some(c) => return Err(format!("compressor {c} is not supported (only zlib)")),
    };
    let layout = BinaryLayout {
        header64,
        big,
        zlib,
    };
    let piece = piece.ok_or("no <Piece> element")?;
    let count = |k: &str| -> Result<usize, String> {
        piece
            .get(k)
            .ok_or_else(|| format!("<Piece> has no {k}"))?
            .trim()
            .parse::<usize>()
            .map_err(|_| format!("<Piece> {k} is not a count"))
    };
    let (n_points, n_cells) = (count("NumberOfPoints")?, count("NumberOfCells")?);
    // Every point needs at least 3 bytes and every cell 2 in any encoding (zlib at
    // most ~1032:1): a count beyond that is a lie, refused before allocating.
    let budget = (bytes.len() as u64).saturating_mul(1100) + 4096;
    if n_points as u64 > budget || n_cells as u64 > budget {
        return Err(format!(
            "declares {n_points} points and {n_cells} cells, more than a {}-byte file can hold",
            bytes.len()
        ));
    }
    let region = match app_at {
        Some(at) => Some(appended(bytes, at)?),
        None => None,
    };
    let mut offsets_sorted: Vec<usize> = arrays
        .iter()
        .filter_map(|a| a.attrs.get("offset").and_then(|o| o.trim().parse().ok()))
        .collect();
    offsets_sorted.sort_unstable();
    let decode = |a: &ArrayDecl, count: usize| -> Result<Numbers, String> {
        decode_array(a, count, &layout, region, &offsets_sorted)
    };
    let named = |sec: Section, name: &str| {
        arrays
            .iter()
            .find(|a| a.section == sec && a.attrs.get("Name").map(String::as_str) == Some(name))
            .ok_or_else(|| format!("no <DataArray Name=\"{name}\"> in <Cells>"))
    };
    let mut mesh = RawMesh::default();
    let pts = arrays
        .iter()
        .find(|a| a.section == Section::Points)
        .ok_or("no <Points> array")?;
    if components(pts)? != 3 {
        return Err("<Points> array does not have 3 components".into());
    }
    mesh.points = decode(pts, n_points * 3)?.into_f64();
    mesh.ends = decode(named(Section::Cells, "offsets")?, n_cells)?.into_ints("offsets")?;
    mesh.types = decode(named(Section::Cells, "types")?, n_cells)?.into_ints("types")?;
    let n_conn = mesh.ends.last().copied().unwrap_or(0);
    if n_conn < 0 || n_conn as u64 > budget {
        return Err(format!(
            "cell offsets end at {n_conn}, not a connectivity size"
        ));
    }
    mesh.connectivity = decode(named(Section::Cells, "connectivity")?, n_conn as usize)?
        .into_ints("connectivity")?;
    for (sec, n) in [(Section::PointData, n_points), (Section::CellData, n_cells)] {
        for a in arrays.iter().filter(|a| a.section == sec) {
            let name = a
                .attrs
                .get("Name")
                .cloned()
                .unwrap_or_else(|| "unnamed".into());
            let c = components(a)?;
            let values = decode(a, n * c)?.into_f64();
            let list = if sec == Section::PointData {
                &mut mesh.point_data
            } else {
                &mut mesh.cell_data
            };
            list.push(DataArray {
                name,
                components: c,
                values,
            });
        }
    }
    Ok(mesh)
}

fn components(a: &ArrayDecl) -> Result<usize, String> {
    match a.attrs.get("NumberOfComponents") {
        None => Ok(1),
        Some(s) => match s.trim().parse::<usize>() {
            Ok(c) if (1..=64).contains(&c) => Ok(c),
            _ => Err(format!(
                "NumberOfComponents=\"{s}\" is not a component count"
            )),
        },
    }
}

fn decode_array(
    a: &ArrayDecl,
    count: usize,
    layout: &BinaryLayout,
    region: Option<(&[u8], bool)>,
    offsets: &[usize],
) -> Result<Numbers, String> {
    let name = a.attrs.get("Name").map(String::as_str).unwrap_or("unnamed");
    let what = format!("array '{name}'");
    let ty_s = a.attrs.get("type").map(String::as_str).unwrap_or("");
    let ty = Scalar::parse(ty_s).ok_or_else(|| format!("{what}: unknown type '{ty_s}'"))?;
    let bytes = count
        .checked_mul(ty.size())
        .ok_or_else(|| format!("{what}: size overflows"))?;
    let fmt = a.attrs.get("format").map(String::as_str).unwrap_or("ascii");
    let raw = match fmt {
        "ascii" => {
            let text = std::str::from_utf8(&a.text).map_err(|_| format!("{what}: not text"))?;
            let mut tokens = text.split_ascii_whitespace();
            let v = parse_ascii(&mut tokens, ty, count, &what)?;
            if tokens.next().is_some() {
                return Err(format!("{what}: more than the {count} values expected"));
            }
            return Ok(v);
        }
        "binary" => decode_base64_block(&a.text, layout, bytes, &what)?,
        "appended" => {
            let (data, base64) =
                region.ok_or_else(|| format!("{what}: format=appended but no <AppendedData>"))?;
            let off: usize = a
                .attrs
                .get("offset")
                .and_then(|o| o.trim().parse().ok())
                .ok_or_else(|| format!("{what}: appended without an offset"))?;
            if off > data.len() {
                return Err(format!(
                    "{what}: offset {off} beyond the {} bytes of appended data (truncated?)",
                    data.len()
                ));
            }
            if base64 {
                let end = offsets
                    .iter()
                    .copied()
                    .find(|&o| o > off)
                    .unwrap_or(data.len())
                    .min(data.len());
                decode_base64_block(&data[off..end], layout, bytes, &what)?
            } else {
                decode_raw_block(&data[off..], layout, bytes, &what)?
            }
        }
        f => return Err(format!("{what}: unknown format '{f}'")),
    };
    decode_binary(&raw, ty, count, layout.big, &what)
}
