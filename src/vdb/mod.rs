//! Loading `.vdb` files. All use of the VDB reader crate stays in this module.
//!
//! [`VdbFile::open`] reads the header, the file metadata and each grid's descriptor,
//! metadata and transform — no trees. [`VdbFile::decode`] then decodes one grid by name
//! and streams its tiles and leaves into a [`TreeSink`] (the render structure's
//! builder), so grids nobody references are never decoded.

mod decode;
mod error;
pub mod guard;
mod scan;
mod snapshot;
mod write;

pub use decode::{DecodedValues, TreeSink};
pub use error::VdbError;
pub use write::{FloatGridOut, MadeGrid, float_grid, write_float_grids, write_grids};

use error::panic_message;
use glam::{DMat4, DVec3, IVec3};
use openvdb::io::{File, GridMetadata};
use openvdb::math::Vec3d;
use std::cell::Cell;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::sync::Once;

/// What a grid's values are, as far as rendering is concerned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ValueKind {
    /// float or double: one channel.
    Scalar,
    /// vec3s or vec3d: three channels.
    Vector,
    /// int, bool, mask, points and anything else: listed but not renderable.
    Unsupported,
}

/// Everything known about a grid without decoding its tree.
#[derive(Clone, Debug)]
pub struct GridInfo {
    /// The grid's name (duplicates get `[n]` when shown, as OpenVDB prints them).
    pub name: String,
    /// The printable unique name (`name` or `name[n]`).
    pub unique_name: String,
    /// OpenVDB's value type name: `float`, `vec3s`, `int32`, `ptdataidx32`, ...
    pub value_type: String,
    pub kind: ValueKind,
    /// `fog volume`, `level set`, `staggered` or `unknown`.
    pub class: String,
    /// True if floating-point values are stored as 16-bit halves.
    pub half: bool,
    /// Compression of the grid's tree: `blosc`, `zip`, `none` (plus `+mask`).
    pub compression: String,
    /// The OpenVDB map type (`UniformScaleMap`, `AffineMap`, ...).
    pub map_type: String,
    /// Index → world (column-vector convention), if the map is linear.
    pub index_to_world: Option<DMat4>,
    /// Instance parent's name, if the grid shares another grid's tree.
    pub instance_of: Option<String>,
    /// Active voxel count and index bounding box as the writer recorded them in the
    /// grid's metadata (`file_voxel_count`, `file_bbox_min/max`), if it did.
    pub file_voxel_count: Option<u64>,
    pub file_bbox: Option<(IVec3, IVec3)>,
    /// The remaining metadata, as `(name, value)` text.
    pub metadata: Vec<(String, String)>,
}

impl GridInfo {
    pub fn voxel_size(&self) -> Option<DVec3> {
        self.index_to_world.map(|m| {
            DVec3::new(
                m.x_axis.truncate().length(),
                m.y_axis.truncate().length(),
                m.z_axis.truncate().length(),
            )
        })
    }
}

/// An opened `.vdb` file: header, metadata and grid descriptors.
pub struct VdbFile {
    path: PathBuf,
    file: File,
    /// The structure scan made before the reader opened the file (same grid order).
    scanned: scan::ScannedFile,
    /// The bytes both read (held open while the reader may read grids).
    snapshot: snapshot::Snapshot,
    /// File format version (e.g. 224).
    pub file_version: u32,
    /// Version of the library that wrote the file, `major.minor`.
    pub library_version: String,
    /// File-level metadata as `(name, value)` text.
    pub metadata: Vec<(String, String)>,
    grids: Vec<GridInfo>,
}

impl std::fmt::Debug for VdbFile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VdbFile")
            .field("path", &self.path)
            .field("grids", &self.grids.len())
            .finish()
    }
}

thread_local! {
    /// Set while this thread runs the reader under [`guarded`]: its panics are errors, not
    /// messages.
    static QUIET_PANICS: Cell<bool> = const { Cell::new(false) };
}

/// Installs (once) a panic hook that stays silent for panics inside [`guarded`] and
/// passes all others to the previous hook.
fn install_quiet_panic_hook() {
    static HOOK: Once = Once::new();
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !QUIET_PANICS.with(Cell::get) {
                previous(info);
            }
        }));
    });
}

/// Resets [`QUIET_PANICS`] when dropped, also while unwinding.
struct QuietPanics(bool);

impl QuietPanics {
    fn on() -> Self {
        QuietPanics(QUIET_PANICS.with(|q| q.replace(true)))
    }
}

impl Drop for QuietPanics {
    fn drop(&mut self) {
        QUIET_PANICS.with(|q| q.set(self.0));
    }
}

/// Runs the reader under `catch_unwind`, so a panic on malformed data becomes an error
/// (and prints nothing: the caller reports the error on one line).
fn guarded<T>(path: &Path, f: impl FnOnce() -> Result<T, VdbError>) -> Result<T, VdbError> {
    install_quiet_panic_hook();
    let quiet = QuietPanics::on();
    let result = catch_unwind(AssertUnwindSafe(f));
    drop(quiet);
    match result {
        Ok(r) => r,
        Err(payload) => Err(VdbError::file(path, panic_message(payload))),
    }
}

/// Runs `f`, a reader of another format (a USD camera), under the guard of the VDB
/// reader: a panic on malformed data becomes an error message, and prints nothing.
pub fn without_panics<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    install_quiet_panic_hook();
    let quiet = QuietPanics::on();
    let result = catch_unwind(AssertUnwindSafe(f));
    drop(quiet);
    result.map_err(error::panic_message)
}

impl VdbFile {
    /// Opens a file and reads everything but the trees.
    pub fn open(path: impl AsRef<Path>) -> Result<VdbFile, VdbError> {
        let path = path.as_ref();
        let opened = std::fs::File::open(path).map_err(|e| VdbError::file(path, io_problem(&e)));
        let meta = match &opened {
            Ok(f) => f.metadata(),
            Err(_) => std::fs::metadata(path),
        }
        .map_err(|e| VdbError::file(path, io_problem(&e)))?;
        if meta.is_dir() {
            return Err(VdbError::file(path, "is a directory, not a .vdb file"));
        }
        if !meta.is_file() {
            return Err(VdbError::file(
                path,
                "is not a regular file (a device, FIFO or socket)",
            ));
        }
        if meta.len() == 0 {
            return Err(VdbError::file(path, "file is empty"));
        }
        // One copy of the bytes, read once: the scan and the reader both read it.
        let snapshot = snapshot::Snapshot::take(path, opened?, meta.len())?;
        // Structure checks first: what would abort the reader must not reach it.
        let scanned = guarded(path, || {
            scan::scan_file(snapshot.path()).map_err(|p| VdbError::file(path, p))
        })?;
        guarded(path, || Self::open_unguarded(path, snapshot, scanned))
    }

    fn open_unguarded(
        path: &Path,
        snapshot: snapshot::Snapshot,
        scanned: scan::ScannedFile,
    ) -> Result<VdbFile, VdbError> {
        let file =
            File::open(snapshot.path()).map_err(|e| VdbError::file(path, reader_problem(&e)))?;
        let descs = file.descriptors();
        if descs.is_empty() {
            return Err(VdbError::file(path, "the file holds no grids"));
        }
        let unique: Vec<String> = descs.iter().map(|d| d.unique_name.clone()).collect();
        let parents: Vec<String> = descs.iter().map(|d| d.instance_parent.clone()).collect();
        guard::check_instance_chains(&unique, &parents).map_err(|p| VdbError::file(path, p))?;
        if scanned.grids.len() != descs.len()
            || scanned
                .grids
                .iter()
                .zip(descs)
                .any(|(s, d)| s.unique_name != d.unique_name)
        {
            return Err(VdbError::file(
                path,
                "the grid descriptors could not be read consistently",
            ));
        }
        let metas = file
            .read_all_grid_metadata()
            .map_err(|e| VdbError::file(path, reader_problem(&e)))?;
        if metas.len() != descs.len() {
            return Err(VdbError::file(
                path,
                format!(
                    "{} grid descriptors but {} grids could be read",
                    descs.len(),
                    metas.len()
                ),
            ));
        }
        let grids = metas
            .iter()
            .map(|m| grid_info(path, m))
            .collect::<Result<Vec<_>, _>>()?;
        let header = file.header();
        Ok(VdbFile {
            path: path.to_path_buf(),
            file_version: header.file_version,
            library_version: format!("{}.{}", header.library_version.0, header.library_version.1),
            metadata: file
                .metadata()
                .iter()
                .map(|(k, v)| (guard::printable(k), meta_text(v)))
                .collect(),
            grids,
            file,
            scanned,
            snapshot,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// All grids in file order, including unsupported ones.
    pub fn grids(&self) -> &[GridInfo] {
        &self.grids
    }

    /// Names of all grids, comma separated (for error messages).
    pub fn grid_list(&self) -> String {
        self.grids
            .iter()
            .map(|g| guard::short_text(&g.unique_name))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Looks up a grid by name or unique name (`name[1]`).
    pub fn grid(&self, name: &str) -> Result<&GridInfo, VdbError> {
        Ok(&self.grids[self.grid_index(name)?])
    }

    fn grid_index(&self, name: &str) -> Result<usize, VdbError> {
        self.grids
            .iter()
            .position(|g| g.unique_name == name)
            .or_else(|| self.grids.iter().position(|g| g.name == name))
            .ok_or_else(|| VdbError::NoSuchGrid {
                path: self.path.clone(),
                grid: guard::short_text(name),
                available: self.grid_list(),
            })
    }

    /// True if the file has a grid of that name.
    pub fn has_grid(&self, name: &str) -> bool {
        self.grid(name).is_ok()
    }

    /// Decodes one grid and streams its tree into `sink`. Returns the grid's transform
    /// and what was decoded.
    pub fn decode(&self, name: &str, sink: &mut dyn TreeSink) -> Result<DecodedValues, VdbError> {
        let index = self.grid_index(name)?;
        let info = &self.grids[index];
        let gerr = |p: String| VdbError::grid(&self.path, &info.unique_name, p);
        if info.kind == ValueKind::Unsupported {
            return Err(gerr(format!(
                "value type \"{}\" cannot be rendered (murk reads float, double and vec3 grids)",
                info.value_type
            )));
        }
        let Some(m) = info.index_to_world else {
            return Err(gerr(format!(
                "the transform ({}) is not a linear map",
                info.map_type
            )));
        };
        if let Some(problem) = guard::voxel_shape_problem(info.voxel_size()) {
            return Err(gerr(problem));
        }
        // The raw unique name, as in the file (the printable one may have been escaped).
        let unique = &self.scanned.grids[index].unique_name;
        guarded(&self.path, || {
            self.scanned
                .check_tree(self.snapshot.path(), unique)
                .map_err(gerr)?;
            let grid = self
                .file
                .read_grid(unique)
                .map_err(|e| gerr(reader_problem(&e)))?;
            decode::walk(grid, info.kind, m, sink).map_err(gerr)
        })
    }
}

fn grid_info(path: &Path, m: &GridMetadata) -> Result<GridInfo, VdbError> {
    let d = &m.descriptor;
    let unique_name = guard::printable(&d.display_name());
    let value_type = d.value_type().unwrap_or(d.grid_type.as_str()).to_string();
    let kind = match value_type.as_str() {
        "float" | "double" => ValueKind::Scalar,
        "vec3s" | "vec3d" => ValueKind::Vector,
        _ => ValueKind::Unsupported,
    };
    let index_to_world = match &m.transform {
        Some(t) if t.is_linear() => {
            let o = t.index_to_world(Vec3d::new(0.0, 0.0, 0.0));
            let col = |i: usize| {
                let mut e = [0.0; 3];
                e[i] = 1.0;
                let w = t.index_to_world(Vec3d::new(e[0], e[1], e[2]));
                DVec3::new(w[0] - o[0], w[1] - o[1], w[2] - o[2]).extend(0.0)
            };
            Some(DMat4::from_cols(
                col(0),
                col(1),
                col(2),
                DVec3::new(o[0], o[1], o[2]).extend(1.0),
            ))
        }
        _ => None,
    };
    if let Some(mat) = index_to_world {
        let lin = glam::DMat3::from_mat4(mat);
        let det = lin.determinant();
        let sizes = [
            lin.x_axis.length(),
            lin.y_axis.length(),
            lin.z_axis.length(),
        ];
        if !mat.is_finite()
            || !det.is_finite()
            || det.abs() < 1e-300
            || sizes.iter().any(|s| *s <= 0.0 || *s > 1e15)
        {
            return Err(VdbError::grid(
                path,
                &unique_name,
                "the transform has a zero, non-finite or absurd voxel size",
            ));
        }
    }
    let file_voxel_count = m
        .metadata
        .get("file_voxel_count")
        .and_then(|v| v.as_i64())
        .map(|v| v.max(0) as u64);
    let file_bbox = match (
        m.metadata.get("file_bbox_min"),
        m.metadata.get("file_bbox_max"),
    ) {
        (Some(a), Some(b)) => match (a.as_vec3i(), b.as_vec3i()) {
            (Some(a), Some(b)) => {
                Some((IVec3::new(a[0], a[1], a[2]), IVec3::new(b[0], b[1], b[2])))
            }
            _ => None,
        },
        _ => None,
    };
    let compression = compression_name(m.compression);
    let class = guard::printable(m.metadata.get_str("class").unwrap_or("unknown"));
    let value_type = guard::printable(&value_type);
    let metadata = m
        .metadata
        .iter()
        .map(|(k, v)| (guard::printable(k), meta_text(v)))
        .collect();
    Ok(GridInfo {
        name: guard::printable(&d.grid_name),
        unique_name,
        value_type,
        kind,
        class,
        half: d.save_float_as_half,
        compression,
        map_type: guard::printable(&m.map_type),
        index_to_world,
        instance_of: (!d.instance_parent.is_empty()).then(|| guard::printable(&d.instance_parent)),
        file_voxel_count,
        file_bbox,
        metadata,
    })
}

fn compression_name(c: openvdb::io::Compression) -> String {
    use openvdb::io::Compression as C;
    let codec = if c.contains(C::BLOSC) {
        "blosc"
    } else if c.contains(C::ZIP) {
        "zip"
    } else {
        "none"
    };
    if c.contains(C::ACTIVE_MASK) {
        format!("{codec}+mask")
    } else {
        codec.to_string()
    }
}

fn meta_text(v: &openvdb::metadata::MetaValue) -> String {
    use openvdb::metadata::MetaValue as M;
    match v {
        M::Bool(b) => b.to_string(),
        M::Int32(i) => i.to_string(),
        M::Int64(i) => i.to_string(),
        M::Float(f) => guard::number_text(f64::from(*f)),
        M::Double(f) => guard::number_text(*f),
        M::String(s) => guard::printable(s),
        M::Vec3i(v) => format!("({}, {}, {})", v[0], v[1], v[2]),
        M::Vec3s(v) => format!(
            "({}, {}, {})",
            guard::number_text(f64::from(v[0])),
            guard::number_text(f64::from(v[1])),
            guard::number_text(f64::from(v[2]))
        ),
        M::Vec3d(v) => format!(
            "({}, {}, {})",
            guard::number_text(v[0]),
            guard::number_text(v[1]),
            guard::number_text(v[2])
        ),
        M::Unknown { type_name, data } => {
            format!("<{} bytes of {}>", data.len(), guard::printable(type_name))
        }
        other => format!("<{}>", other.type_name()),
    }
}

pub(super) fn io_problem(e: &std::io::Error) -> String {
    match e.kind() {
        std::io::ErrorKind::NotFound => "no such file".to_string(),
        std::io::ErrorKind::PermissionDenied => "permission denied".to_string(),
        _ => e.to_string(),
    }
}

fn reader_problem(e: &openvdb::io::Error) -> String {
    match e {
        openvdb::io::Error::NotVdb => "not a VDB file (bad magic number)".to_string(),
        openvdb::io::Error::Io(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            "the file is truncated (unexpected end of data)".to_string()
        }
        openvdb::io::Error::Io(io) => io_problem(io),
        other => guard::printable(&other.to_string()),
    }
}
