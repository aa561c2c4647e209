//! Inputs by kind: one place opens a file and offers its fields for the scene's roles.
//! A VDB file's grids ([`vdb`]) and a mesh file's arrays ([`mesh`]); another kind of
//! input (a procedural scene) is another [`FieldSource`] and an arm in [`open`].

mod field_source;
pub mod mesh;
pub mod vdb;

pub use field_source::{FieldKind, FieldSource, Loaded, SourceError, SourceField, VelocityNames};
pub use mesh::MeshFieldSource;
use std::path::Path;
pub use vdb::VdbSource;

/// Opens `path` by its kind: a mesh by its extension (`.vtu`, `.vtk`), else a VDB.
pub fn open(path: &Path) -> Result<Box<dyn FieldSource>, SourceError> {
    if crate::vtk::is_mesh_path(path) {
        return Ok(Box::new(MeshFieldSource::open(path)?));
    }
    Ok(Box::new(VdbSource::open(path)?))
}
