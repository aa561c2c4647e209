//! A `.vdb` file as a field source.

use super::field_source::{
    FieldKind, FieldSource, Loaded, SourceError, SourceField, VelocityNames,
};
use crate::field::advect::GridVelocity;
use crate::field::{ColorField, Field, VoxelGrid};
use crate::scene::report::Sanitised;
use crate::vdb::{ValueKind, VdbFile};
use std::path::Path;

type Result<T> = std::result::Result<T, SourceError>;

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
                class: g.class.clone(),
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
            .ok_or_else(|| SourceError::NoField {
                path: self.path().to_owned(),
                what: "grid",
                name: name.to_owned(),
                have: String::new(),
            })
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
    fn load_velocity(&self, names: &VelocityNames) -> Result<Option<Loaded<GridVelocity>>> {
        let staggered = |n: &str| self.field(n).is_ok_and(|f| f.class == "staggered");
        match names {
            VelocityNames::Vector(n) => {
                let l = self.load(n)?;
                let s = staggered(n);
                Ok(GridVelocity::vector(l.field, s).map(|v| Loaded {
                    field: v,
                    name: l.name,
                    sanitised: l.sanitised,
                    memory_bytes: l.memory_bytes,
                }))
            }
            VelocityNames::Channels(xyz) => {
                let mut grids = Vec::with_capacity(3);
                let mut sanitised = Sanitised::default();
                let mut memory_bytes = 0;
                for n in xyz {
                    let g = VoxelGrid::load_signed(&self.file, n)?;
                    sanitised.nan += g.stats().nan;
                    sanitised.inf += g.stats().inf;
                    memory_bytes += g.memory_bytes();
                    grids.push(g);
                }
                let s = staggered(&xyz[0]);
                let Ok(xyz_grids) = <[VoxelGrid; 3]>::try_from(grids) else {
                    return Ok(None);
                };
                Ok(Some(Loaded {
                    field: GridVelocity::channels(xyz_grids, s),
                    name: xyz.join(","),
                    sanitised,
                    memory_bytes,
                }))
            }
        }
    }
}
