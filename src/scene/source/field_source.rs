//! What every input offers the scene: its fields, by name, and loading one.

use crate::field::advect::GridVelocity;
use crate::field::{ColorField, Field};
use crate::scene::report::Sanitised;
use crate::vdb::VdbError;
use crate::vtk::MeshError;
use std::path::{Path, PathBuf};

/// Why an input or one of its fields could not be opened; every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    /// A VDB file could not be read (the error names the file and the grid).
    #[error(transparent)]
    Vdb(#[from] VdbError),
    /// A mesh file could not be read (the error names the file).
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// The file has no field of that name.
    #[error("{}: no {what} {name}{}", path.display(), have_list(have))]
    NoField {
        /// The input file.
        path: PathBuf,
        /// What the input calls its fields (`grid`, `array`).
        what: &'static str,
        /// The name asked for.
        name: String,
        /// The fields it has, comma separated (empty: not listed).
        have: String,
    },
    /// A mesh array has fewer components than the role needs.
    #[error(
        "{}: no array {name} with {components} components (the file has: {have})",
        path.display()
    )]
    Components {
        /// The input file.
        path: PathBuf,
        /// The array asked for.
        name: String,
        /// How many components the role needs.
        components: usize,
        /// The arrays it has, comma separated.
        have: String,
    },
}

fn have_list(have: &str) -> String {
    if have.is_empty() {
        String::new()
    } else {
        format!(" (the file has: {have})")
    }
}

type Result<T> = std::result::Result<T, SourceError>;

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
    /// The grid class as the file records it (`fog volume`, `level set`, `staggered`,
    /// `unknown`); `unknown` where the source has none.
    pub class: String,
}

/// The fields a velocity is read from.
#[derive(Clone, Debug, PartialEq)]
pub enum VelocityNames {
    Vector(String),
    Channels([String; 3]),
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

    /// Decodes a velocity: a vector field, or three scalar fields x, y, z (signed
    /// values kept). `None` where the source holds no velocities murk reads.
    fn load_velocity(&self, names: &VelocityNames) -> Result<Option<Loaded<GridVelocity>>> {
        let _ = names;
        Ok(None)
    }

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
