//! Inputs by kind: one place opens a file and offers its fields for the scene's roles.
//! A VDB file's grids today; another kind of input (a mesh, a procedural scene) is
//! another [`FieldSource`] and an arm in [`open`].

use super::report::Sanitised;
use crate::field::{ColorField, Field, VoxelGrid};
use crate::vdb::{ValueKind, VdbFile};
use anyhow::{Result, anyhow};
use std::path::Path;

/// What values a source's field holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FieldKind {
    /// One number per point: density, emission, temperature.
    Scalar,
    /// Three numbers per point: colour, velocity.
    Vector,
    /// Something murk cannot render (integers, masks, points).
    Other,
}

/// A field a source holds, before it is loaded.
#[derive(Clone, Debug, PartialEq)]
pub struct SourceField {
    /// The name as the file has it.
    pub name: String,
    /// Unique among the source's fields (`name[1]` for a second grid of one name).
    pub unique_name: String,
    pub kind: FieldKind,
    /// The value type as the file calls it (`float`, `vec3s`, …).
    pub type_name: String,
}

/// A loaded field with what loading it found.
pub struct Loaded<T> {
    pub field: T,
    /// The unique name it was loaded as.
    pub name: String,
    /// Bad values replaced by 0 at load.
    pub sanitised: Sanitised,
    /// Bytes of its render structure.
    pub memory_bytes: usize,
}

impl<T> Loaded<T> {
    /// The same load report for a converted field.
    pub fn map<U>(self, f: impl FnOnce(T) -> U) -> Loaded<U> {
        Loaded {
            field: f(self.field),
            name: self.name,
            sanitised: self.sanitised,
            memory_bytes: self.memory_bytes,
        }
    }
}

/// An opened input whose fields can fill the scene's roles.
pub trait FieldSource: Send + Sync {
    fn path(&self) -> &Path;
    /// The fields, in file order.
    fn fields(&self) -> &[SourceField];
    /// The field called `name` (its name or unique name); the error names what there is.
    fn field(&self, name: &str) -> Result<&SourceField>;
    /// Decodes a scalar field.
    fn load_scalar(&self, name: &str) -> Result<Loaded<Box<dyn Field>>>;
    /// Decodes a colour field.
    fn load_color(&self, name: &str) -> Result<Loaded<Box<dyn ColorField>>>;

    /// The file's metadata as `(name, value)` text (a VDB's `creator`, …); none by default.
    fn metadata(&self) -> Vec<(String, String)> {
        Vec::new()
    }

    /// The unique names of all fields, comma separated (for messages).
    fn field_list(&self) -> String {
        self.fields()
            .iter()
            .map(|f| f.unique_name.clone())
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// Opens `path` by its kind: a mesh by its extension (`.vtu`, `.vtk`), else a VDB.
pub fn open(path: &Path) -> Result<Box<dyn FieldSource>> {
    if crate::vtk::is_mesh_path(path) {
        return Ok(Box::new(super::mesh_source::MeshFieldSource::open(path)?));
    }
    Ok(Box::new(VdbSource::open(path)?))
}

/// A `.vdb` file: its float and double grids are scalar fields, its vec3 grids colours.
pub struct VdbSource {
    file: VdbFile,
    fields: Vec<SourceField>,
}

impl VdbSource {
    pub fn open(path: &Path) -> Result<VdbSource> {
        let file = VdbFile::open(path)?;
        let fields = file
            .grids()
            .iter()
            .map(|g| SourceField {
                name: g.name.clone(),
                unique_name: g.unique_name.clone(),
                kind: match g.kind {
                    ValueKind::Scalar => FieldKind::Scalar,
                    ValueKind::Vector => FieldKind::Vector,
                    _ => FieldKind::Other,
                },
                type_name: g.value_type.clone(),
            })
            .collect();
        Ok(VdbSource { file, fields })
    }

    pub fn file(&self) -> &VdbFile {
        &self.file
    }

    fn load(&self, name: &str) -> Result<Loaded<VoxelGrid>> {
        let g = VoxelGrid::load(&self.file, name)?;
        let s = g.stats();
        Ok(Loaded {
            name: g.name().to_string(),
            sanitised: Sanitised {
                nan: s.nan,
                inf: s.inf,
                negative: s.negative,
            },
            memory_bytes: g.memory_bytes(),
            field: g,
        })
    }
}

impl FieldSource for VdbSource {
    fn path(&self) -> &Path {
        self.file.path()
    }
    fn fields(&self) -> &[SourceField] {
        &self.fields
    }
    fn field(&self, name: &str) -> Result<&SourceField> {
        let g = self.file.grid(name)?;
        self.fields
            .iter()
            .find(|f| f.unique_name == g.unique_name)
            .ok_or_else(|| anyhow!("{}: no grid {name}", self.path().display()))
    }
    fn load_scalar(&self, name: &str) -> Result<Loaded<Box<dyn Field>>> {
        Ok(self.load(name)?.map(|g| Box::new(g) as Box<dyn Field>))
    }
    fn metadata(&self) -> Vec<(String, String)> {
        self.file.metadata.clone()
    }
    fn load_color(&self, name: &str) -> Result<Loaded<Box<dyn ColorField>>> {
        Ok(self.load(name)?.map(|g| Box::new(g) as Box<dyn ColorField>))
    }
}
