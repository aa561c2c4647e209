//! Writing float grids (the deep shadow map cache) with OpenVDB-rs, so any OpenVDB
//! reader — Houdini, Blender, `vdb_print` — opens them as ordinary grids.

use super::error::VdbError;
use glam::{DMat4, IVec3};
use openvdb::prelude::*;
use std::path::Path;

/// A float grid to write: its active voxels, transform and string metadata.
#[derive(Clone, Debug)]
pub struct FloatGridOut {
    pub name: String,
    /// Index → world (column-vector convention); must be affine and invertible.
    pub index_to_world: DMat4,
    pub voxels: Vec<(IVec3, f32)>,
    pub metadata: Vec<(String, String)>,
}

/// Writes `grids` (and file metadata) to `path` as one `.vdb` file.
pub fn write_float_grids(
    path: &Path,
    grids: &[FloatGridOut],
    file_metadata: &[(String, String)],
) -> Result<(), VdbError> {
    let made = grids
        .iter()
        .map(|g| {
            float_grid(
                path,
                &g.name,
                g.index_to_world,
                &g.metadata,
                g.voxels.iter().copied(),
            )
        })
        .collect::<Result<Vec<_>, _>>()?;
    write_grids(path, made, file_metadata)
}

/// A float grid made for [`write_grids`], its voxels already in OpenVDB's tree.
pub struct MadeGrid(AnyGrid);

/// A float grid of `voxels` (set as they come: no list of them is held), its transform
/// and string metadata; `path` is the file it is for, named in an error.
pub fn float_grid(
    path: &Path,
    name: &str,
    index_to_world: DMat4,
    metadata: &[(String, String)],
    voxels: impl IntoIterator<Item = (IVec3, f32)>,
) -> Result<MadeGrid, VdbError> {
    if !(index_to_world.is_finite() && index_to_world.determinant().abs() > 1e-300) {
        return Err(VdbError::grid(
            path,
            name,
            "its transform is not invertible",
        ));
    }
    let mut grid = FloatGrid::new(0.0);
    grid.set_name(name);
    grid.set_grid_class(GridClass::FogVolume);
    // OpenVDB matrices are row-vector: world = [i j k 1] · M.
    let c = index_to_world.to_cols_array_2d();
    let m = Mat4d::new(
        [c[0][0], c[0][1], c[0][2], 0.0],
        [c[1][0], c[1][1], c[1][2], 0.0],
        [c[2][0], c[2][1], c[2][2], 0.0],
        [c[3][0], c[3][1], c[3][2], 1.0],
    );
    grid.set_transform(Transform::from_matrix(m));
    for (k, v) in metadata {
        grid.insert_meta(k, v.as_str());
    }
    {
        let mut acc = grid.accessor_mut();
        for (ijk, v) in voxels {
            acc.set_value_on(&Coord::new(ijk.x, ijk.y, ijk.z), v);
        }
    }
    Ok(MadeGrid(grid.into()))
}

/// Writes grids made by [`float_grid`] (and file metadata) to `path` as one `.vdb` file.
pub fn write_grids(
    path: &Path,
    grids: Vec<MadeGrid>,
    file_metadata: &[(String, String)],
) -> Result<(), VdbError> {
    let out: Vec<AnyGrid> = grids.into_iter().map(|g| g.0).collect();
    let mut meta = MetaMap::new();
    for (k, v) in file_metadata {
        meta.insert(k.as_str(), v.as_str());
    }
    openvdb::io::write_file(path, &out, &meta)
        .map_err(|e| VdbError::file(path, format!("cannot write: {e}")))
}
