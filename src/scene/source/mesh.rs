//! A mesh file (`.vtu`, `.vtk`) as a field source: its point and cell data arrays are
//! the fields the scene's roles pick (`--density-grid NAME` names an array), one-
//! component arrays scalar, three-component ones colours. All share the mesh's walkable
//! geometry, built once when the file is opened.

use super::field_source::{FieldKind, FieldSource, Loaded, SourceError, SourceField};
use crate::field::mesh::{MeshField, MeshSource};
use crate::field::{ColorField, Field, IndexToWorld};
use crate::scene::report::Sanitised;
use glam::{DVec3, Vec3};
use std::path::{Path, PathBuf};

type Result<T> = std::result::Result<T, SourceError>;

pub struct MeshFieldSource {
    path: PathBuf,
    source: MeshSource,
    fields: Vec<SourceField>,
}

impl MeshFieldSource {
    pub fn open(path: &Path) -> Result<MeshFieldSource> {
        let source = MeshSource::open(path)?;
        let m = &source.mesh;
        let fields = m
            .point_data
            .iter()
            .map(|a| (a, "point"))
            .chain(m.cell_data.iter().map(|a| (a, "cell")))
            .map(|(a, at)| SourceField {
                name: a.name.clone(),
                unique_name: a.name.clone(),
                kind: match a.components {
                    1 => FieldKind::Scalar,
                    3 => FieldKind::Vector,
                    _ => FieldKind::Other,
                },
                type_name: format!(
                    "{at} data, {} component{}",
                    a.components,
                    if a.components == 1 { "" } else { "s" }
                ),
                class: "unknown".into(),
            })
            .collect();
        Ok(MeshFieldSource {
            path: path.to_path_buf(),
            source,
            fields,
        })
    }

    fn too_few_components(&self, name: &str, components: usize) -> SourceError {
        SourceError::Components {
            path: self.path.clone(),
            name: name.to_owned(),
            components,
            have: self.field_list(),
        }
    }

    /// Component `c` of `name` with NaN, infinite and negative values replaced by 0.
    fn component(&self, name: &str, c: usize) -> Result<(MeshField, Sanitised)> {
        let (field, s) = self
            .source
            .sanitised_component(name, c)
            .ok_or_else(|| self.too_few_components(name, c + 1))?;
        Ok((
            field,
            Sanitised {
                nan: s[0],
                inf: s[1],
                negative: s[2],
            },
        ))
    }
}

/// A three-component mesh array as a colour: each channel its own field over the one
/// geometry (so one lattice, one transform).
struct MeshColor {
    channels: [MeshField; 3],
}

impl ColorField for MeshColor {
    fn transform(&self) -> &IndexToWorld {
        self.channels[0].transform()
    }
    fn color_at_index(&self, p: DVec3) -> Vec3 {
        Vec3::new(
            self.channels[0].value_at_index(p),
            self.channels[1].value_at_index(p),
            self.channels[2].value_at_index(p),
        )
    }
}

impl FieldSource for MeshFieldSource {
    fn path(&self) -> &Path {
        &self.path
    }
    fn fields(&self) -> &[SourceField] {
        &self.fields
    }
    fn field(&self, name: &str) -> Result<&SourceField> {
        self.fields
            .iter()
            .find(|f| f.name == name)
            .ok_or_else(|| SourceError::NoField {
                path: self.path.clone(),
                what: "array",
                name: name.to_owned(),
                have: self.field_list(),
            })
    }
    fn load_scalar(&self, name: &str) -> Result<Loaded<Box<dyn Field>>> {
        let (field, sanitised) = self.component(name, 0)?;
        Ok(Loaded {
            name: name.to_string(),
            sanitised,
            memory_bytes: field.memory_bytes(),
            field: Box::new(field),
        })
    }
    fn load_color(&self, name: &str) -> Result<Loaded<Box<dyn ColorField>>> {
        let mut total = Sanitised::default();
        let mut ch = Vec::new();
        for c in 0..3 {
            let (f, s) = self.component(name, c)?;
            total.nan += s.nan;
            total.inf += s.inf;
            total.negative += s.negative;
            ch.push(f);
        }
        let memory_bytes = ch[0].memory_bytes();
        let channels: [MeshField; 3] = ch
            .try_into()
            .map_err(|_| self.too_few_components(name, 3))?;
        Ok(Loaded {
            name: name.to_string(),
            sanitised: total,
            memory_bytes,
            field: Box::new(MeshColor { channels }),
        })
    }
}
