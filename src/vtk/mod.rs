//! Readers for VTK unstructured grids: XML `.vtu` (ASCII, inline base64 binary,
//! appended raw or base64, zlib-compressed, UInt32 or UInt64 headers, either byte
//! order) and legacy `.vtk` (ASCII and big-endian binary, versions 2–5.1).
//!
//! Written here rather than with the `vtkio` crate: vtkio 0.7.0-rc2 (the newest) does
//! not read the ParaView-style appended zlib files (see the commit that added this
//! module), and it allocates whatever sizes a file declares. This reader checks every
//! declared size against the bytes the file has before allocating, and every problem
//! is a [`MeshError`] that prints as one line naming the file.

mod data;
mod error;
mod legacy;
mod xml;

pub use error::MeshError;

use std::path::Path;

/// VTK cell types murk renders as volumes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum CellType {
    Tetra,
    Hexahedron,
    Wedge,
    Pyramid,
}

impl CellType {
    /// From the VTK type id, or `None` for any other (surface, quadratic, polyhedron…).
    pub fn from_vtk(id: i64) -> Option<CellType> {
        match id {
            10 => Some(CellType::Tetra),
            12 => Some(CellType::Hexahedron),
            13 => Some(CellType::Wedge),
            14 => Some(CellType::Pyramid),
            _ => None,
        }
    }
    pub fn vtk_id(self) -> u8 {
        match self {
            CellType::Tetra => 10,
            CellType::Hexahedron => 12,
            CellType::Wedge => 13,
            CellType::Pyramid => 14,
        }
    }
    /// Number of points of the linear cell.
    pub fn points(self) -> usize {
        match self {
            CellType::Tetra => 4,
            CellType::Hexahedron => 8,
            CellType::Wedge => 6,
            CellType::Pyramid => 5,
        }
    }
    /// VTK's name (as `vtkCellTypes` and meshio spell it).
    pub fn name(self) -> &'static str {
        match self {
            CellType::Tetra => "tetra",
            CellType::Hexahedron => "hexahedron",
            CellType::Wedge => "wedge",
            CellType::Pyramid => "pyramid",
        }
    }
}

/// VTK's name for a cell type id murk does not render (for the error message).
pub fn vtk_type_name(id: i64) -> &'static str {
    match id {
        1 => "VTK_VERTEX",
        2 => "VTK_POLY_VERTEX",
        3 => "VTK_LINE",
        4 => "VTK_POLY_LINE",
        5 => "VTK_TRIANGLE",
        6 => "VTK_TRIANGLE_STRIP",
        7 => "VTK_POLYGON",
        8 => "VTK_PIXEL",
        9 => "VTK_QUAD",
        11 => "VTK_VOXEL",
        15 => "VTK_PENTAGONAL_PRISM",
        16 => "VTK_HEXAGONAL_PRISM",
        21..=37 => "a quadratic cell",
        42 => "VTK_POLYHEDRON",
        _ => "not a VTK linear cell type",
    }
}

/// A named array of point or cell data: `values[i * components + c]`.
#[derive(Clone, Debug, PartialEq)]
pub struct DataArray {
    pub name: String,
    pub components: usize,
    pub values: Vec<f64>,
}

impl DataArray {
    /// Tuples in the array.
    pub fn tuples(&self) -> usize {
        self.values.len() / self.components.max(1)
    }
    /// The scalar murk renders from tuple `i`: the value for one component, the
    /// Euclidean norm for several (VTK's "Magnitude").
    pub fn scalar(&self, i: usize) -> f64 {
        let c = self.components.max(1);
        let t = &self.values[i * c..(i + 1) * c];
        if c == 1 {
            t[0]
        } else {
            t.iter().map(|v| v * v).sum::<f64>().sqrt()
        }
    }
    /// `(min, max)` of [`DataArray::scalar`] over the tuples (NaN skipped), or `None`.
    pub fn range(&self) -> Option<(f64, f64)> {
        let mut r: Option<(f64, f64)> = None;
        for i in 0..self.tuples() {
            let v = self.scalar(i);
            if v.is_nan() {
                continue;
            }
            r = Some(match r {
                None => (v, v),
                Some((a, b)) => (a.min(v), b.max(v)),
            });
        }
        r
    }
}

/// An unstructured grid of linear volume cells, validated: every connectivity index is
/// a point, every cell a known type with the right number of points, every array one
/// tuple per point (cell).
#[derive(Clone, Debug, Default)]
pub struct UnstructuredMesh {
    pub points: Vec<[f64; 3]>,
    pub cell_types: Vec<CellType>,
    /// Cell `i`'s points are `connectivity[offsets[i]..offsets[i + 1]]`.
    pub offsets: Vec<usize>,
    pub connectivity: Vec<u32>,
    pub point_data: Vec<DataArray>,
    pub cell_data: Vec<DataArray>,
}

impl UnstructuredMesh {
    pub fn cells(&self) -> usize {
        self.cell_types.len()
    }
    pub fn cell(&self, i: usize) -> &[u32] {
        &self.connectivity[self.offsets[i]..self.offsets[i + 1]]
    }
    /// World bounds `(min, max)` of the points (zeros for an empty mesh).
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        if self.points.is_empty() {
            return ([0.0; 3], [0.0; 3]);
        }
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.points {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        (lo, hi)
    }
    /// Cells of each type, in [`CellType`] order.
    pub fn cells_by_type(&self) -> Vec<(CellType, usize)> {
        let mut counts = std::collections::BTreeMap::new();
        for t in &self.cell_types {
            *counts.entry(*t).or_insert(0usize) += 1;
        }
        counts.into_iter().collect()
    }
    pub fn point_array(&self, name: &str) -> Option<&DataArray> {
        self.point_data.iter().find(|a| a.name == name)
    }
    pub fn cell_array(&self, name: &str) -> Option<&DataArray> {
        self.cell_data.iter().find(|a| a.name == name)
    }
}

/// What the readers produce before validation: raw ids and types.
#[derive(Default)]
struct RawMesh {
    points: Vec<f64>,
    types: Vec<i64>,
    /// End offsets (VTK XML `offsets`), one per cell.
    ends: Vec<i64>,
    connectivity: Vec<i64>,
    point_data: Vec<DataArray>,
    cell_data: Vec<DataArray>,
}

/// True if `path` names a mesh file (by extension: `.vtu`, `.vtk`).
pub fn is_mesh_path(path: &Path) -> bool {
    matches!(
        path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()),
        Some(e) if e == "vtu" || e == "vtk"
    )
}

/// Reads and validates a `.vtu` or `.vtk` file.
pub fn read_mesh(path: impl AsRef<Path>) -> Result<UnstructuredMesh, MeshError> {
    let path = path.as_ref();
    let err = |p: String| MeshError::new(path, p);
    let bytes = std::fs::read(path).map_err(|e| err(format!("cannot read: {e}")))?;
    parse_mesh(path, &bytes)
}

/// [`read_mesh`] on bytes already in memory (`path` names them in errors and chooses
/// the format by extension).
pub fn parse_mesh(path: &Path, bytes: &[u8]) -> Result<UnstructuredMesh, MeshError> {
    let err = |p: String| MeshError::new(path, p);
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let raw = match ext.as_str() {
        "vtu" => xml::read(bytes),
        "vtk" => legacy::read(bytes),
        _ => Err(format!(
            "unknown mesh extension '.{ext}' (expected .vtu or .vtk)"
        )),
    }
    .map_err(err)?;
    validate(raw).map_err(err)
}

fn validate(raw: RawMesh) -> Result<UnstructuredMesh, String> {
    if !raw.points.len().is_multiple_of(3) {
        return Err(format!(
            "{} point coordinates is not a multiple of 3",
            raw.points.len()
        ));
    }
    let n_points = raw.points.len() / 3;
    if n_points > u32::MAX as usize {
        return Err(format!("{n_points} points: more than murk indexes"));
    }
    let points: Vec<[f64; 3]> = raw
        .points
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    if let Some(i) = points.iter().position(|p| !p.iter().all(|v| v.is_finite())) {
        return Err(format!("point {i} has a non-finite coordinate"));
    }
    let n_cells = raw.types.len();
    if raw.ends.len() != n_cells {
        return Err(format!(
            "{} cell types but {} cell offsets",
            n_cells,
            raw.ends.len()
        ));
    }
    let mut cell_types = Vec::with_capacity(n_cells);
    let mut offsets = Vec::with_capacity(n_cells + 1);
    offsets.push(0usize);
    let mut start = 0i64;
    for (i, (&t, &end)) in raw.types.iter().zip(&raw.ends).enumerate() {
        let ct = CellType::from_vtk(t).ok_or_else(|| {
            format!(
                "cell {i} has unknown cell type {t} ({}): murk renders tetra (10), \
                 hexahedron (12), wedge (13) and pyramid (14)",
                vtk_type_name(t)
            )
        })?;
        if end < start || end > raw.connectivity.len() as i64 {
            return Err(format!(
                "cell {i}: offset {end} outside the connectivity (0..={}) or decreasing",
                raw.connectivity.len()
            ));
        }
        let n = (end - start) as usize;
        if n != ct.points() {
            return Err(format!(
                "cell {i} ({}) has {n} points, expected {}",
                ct.name(),
                ct.points()
            ));
        }
        cell_types.push(ct);
        offsets.push(end as usize);
        start = end;
    }
    if (start as usize) != raw.connectivity.len() {
        return Err(format!(
            "connectivity has {} entries but the cells use {start}",
            raw.connectivity.len()
        ));
    }
    let mut connectivity = Vec::with_capacity(raw.connectivity.len());
    for (k, &v) in raw.connectivity.iter().enumerate() {
        if v < 0 || v as usize >= n_points {
            let cell = offsets.partition_point(|&o| o <= k).saturating_sub(1);
            return Err(format!(
                "cell {cell} refers to point {v}, out of range (the mesh has {n_points} points)"
            ));
        }
        connectivity.push(v as u32);
    }
    for (kind, arrays, n) in [
        ("point", &raw.point_data, n_points),
        ("cell", &raw.cell_data, n_cells),
    ] {
        for a in arrays {
            if a.components == 0 || a.values.len() != n * a.components {
                return Err(format!(
                    "{kind} data array '{}' has {} values, expected {} ({n} {kind}s × {} components)",
                    a.name,
                    a.values.len(),
                    n * a.components.max(1),
                    a.components.max(1)
                ));
            }
        }
    }
    Ok(UnstructuredMesh {
        points,
        cell_types,
        offsets,
        connectivity,
        point_data: raw.point_data,
        cell_data: raw.cell_data,
    })
}
