//! A mesh file opened for rendering: its geometry, and its data arrays as fields.

use super::{MeshField, MeshGeometry};
use crate::vtk::{MeshError, UnstructuredMesh, read_mesh};
use std::path::Path;
use std::sync::Arc;

/// A mesh file with its geometry, handing out fields by array name.
pub struct MeshSource {
    pub mesh: UnstructuredMesh,
    pub geometry: Arc<MeshGeometry>,
}

impl MeshSource {
    pub fn open(path: &Path) -> Result<MeshSource, MeshError> {
        let mesh = read_mesh(path)?;
        let geometry = MeshGeometry::new(&mesh).map_err(|e| MeshError::new(path, e))?;
        Ok(MeshSource {
            mesh,
            geometry: Arc::new(geometry),
        })
    }

    /// The array `name` (point data first, then cell data) as a field.
    pub fn field(&self, name: &str) -> Option<MeshField> {
        if let Some(a) = self.mesh.point_array(name) {
            let v = (0..a.tuples()).map(|i| a.scalar(i)).collect();
            return Some(MeshField::from_point_values(self.geometry.clone(), name, v));
        }
        let a = self.mesh.cell_array(name)?;
        let v = (0..a.tuples()).map(|i| a.scalar(i)).collect();
        Some(MeshField::from_cell_values(self.geometry.clone(), name, v))
    }

    /// [`MeshSource::component_field`] with NaN, infinite and negative values replaced
    /// by 0, as a density must be, and how many of each there were.
    pub fn sanitised_component(&self, name: &str, c: usize) -> Option<(MeshField, [u64; 3])> {
        let (a, point) = match self.mesh.point_array(name) {
            Some(a) => (a, true),
            None => (self.mesh.cell_array(name)?, false),
        };
        if c >= a.components {
            return None;
        }
        let mut counts = [0u64; 3];
        let v: Vec<f64> = (0..a.tuples())
            .map(|i| {
                let x = a.values[i * a.components + c];
                let bad = if x.is_nan() {
                    0
                } else if x.is_infinite() {
                    1
                } else if x < 0.0 {
                    2
                } else {
                    return x;
                };
                counts[bad] += 1;
                0.0
            })
            .collect();
        let label = if a.components == 1 {
            name.to_string()
        } else {
            format!("{name}[{c}]")
        };
        let f = if point {
            MeshField::from_point_values(self.geometry.clone(), &label, v)
        } else {
            MeshField::from_cell_values(self.geometry.clone(), &label, v)
        };
        Some((f, counts))
    }

    /// Component `c` of the array `name` as a field (a colour's channel).
    pub fn component_field(&self, name: &str, c: usize) -> Option<MeshField> {
        let (a, point) = match self.mesh.point_array(name) {
            Some(a) => (a, true),
            None => (self.mesh.cell_array(name)?, false),
        };
        if c >= a.components {
            return None;
        }
        let v = (0..a.tuples())
            .map(|i| a.values[i * a.components + c])
            .collect();
        let label = format!("{name}[{c}]");
        Some(if point {
            MeshField::from_point_values(self.geometry.clone(), &label, v)
        } else {
            MeshField::from_cell_values(self.geometry.clone(), &label, v)
        })
    }

    /// Names of every array (point data, then cell data).
    pub fn array_names(&self) -> Vec<String> {
        self.mesh
            .point_data
            .iter()
            .chain(&self.mesh.cell_data)
            .map(|a| a.name.clone())
            .collect()
    }
}
