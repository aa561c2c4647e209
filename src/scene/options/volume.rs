//! A scene file's `[[volume]]` tables: several inputs placed in one world, each with its
//! own medium. What is not given is the scene's (its keys or flags, then the defaults).

use serde::Deserialize;
use std::path::PathBuf;

/// One `[[volume]]` table as written.
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct VolumeTable {
    /// Names the volume in messages and its `volume_<name>` layer; `volume<N>` (from 1)
    /// when not given.
    #[serde(default)]
    pub name: Option<String>,
    /// The input, relative to the scene file; the same file listed twice is read once.
    pub file: PathBuf,
    /// Moves the volume by x,y,z (world units), after `rotate` and `scale`.
    #[serde(default)]
    pub translate: Option<[f64; 3]>,
    /// Turns the volume by x, y, z degrees about the world axes, in that order, after
    /// `scale`.
    #[serde(default)]
    pub rotate: Option<[f64; 3]>,
    /// Scales the volume: one factor or x,y,z.
    #[serde(default)]
    pub scale: Option<Scale>,
    /// The placement as a 4×4 matrix, four rows, the translation in the last column (the
    /// last row 0,0,0,1); instead of translate/rotate/scale.
    #[serde(default)]
    pub matrix: Option<[[f64; 4]; 4]>,
    /// `[[volume.keys]]`: the placement keyed at frames (`frame = N` and any of
    /// translate, rotate, scale, the others the table's; or a `matrix`), interpolated
    /// between keys and held before the first and after the last.
    #[serde(default)]
    pub keys: Vec<VolumeKey>,
    /// As the scene's `density_grid`, for this volume.
    #[serde(default)]
    pub density_grid: Option<String>,
    /// As the scene's `sigma_a`, for this volume.
    #[serde(default)]
    pub sigma_a: Option<String>,
    /// As the scene's `sigma_s`, for this volume.
    #[serde(default)]
    pub sigma_s: Option<String>,
    /// As the scene's `density_scale`, for this volume.
    #[serde(default)]
    pub density_scale: Option<f64>,
    /// As the scene's `emission_grid`, for this volume.
    #[serde(default)]
    pub emission_grid: Option<String>,
    /// As the scene's `temperature_grid`, for this volume.
    #[serde(default)]
    pub temperature_grid: Option<String>,
    /// As the scene's `color_grid`, for this volume.
    #[serde(default)]
    pub color_grid: Option<String>,
    /// As the scene's `emission_color`, for this volume.
    #[serde(default)]
    pub emission_color: Option<String>,
    /// As the scene's `emission_intensity`, for this volume.
    #[serde(default)]
    pub emission_intensity: Option<f64>,
    /// As the scene's `temperature_scale`, for this volume.
    #[serde(default)]
    pub temperature_scale: Option<f64>,
    /// As the scene's `temperature_offset`, for this volume.
    #[serde(default)]
    pub temperature_offset: Option<f64>,
    /// As the scene's `blackbody_intensity`, for this volume.
    #[serde(default)]
    pub blackbody_intensity: Option<f64>,
}

/// One `[[volume.keys]]`: the volume's placement at a frame.
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct VolumeKey {
    pub frame: f64,
    #[serde(default)]
    pub translate: Option<[f64; 3]>,
    #[serde(default)]
    pub rotate: Option<[f64; 3]>,
    #[serde(default)]
    pub scale: Option<Scale>,
    /// The placement at this frame as a matrix (rows, as the table's `matrix`), instead
    /// of translate/rotate/scale: keys of a volume placed by `matrix`.
    #[serde(default)]
    pub matrix: Option<[[f64; 4]; 4]>,
}

/// A uniform or per-axis scale.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum Scale {
    Uniform(f64),
    Axes([f64; 3]),
}

/// The `[[volume]]` row of docs/scene-file.md.
pub const VOLUME_ROW: &str = "| `[[volume]]` | `file`, `name`, `translate`, `rotate`, `scale`, `matrix`, `[[volume.keys]]` with `frame`, `density_grid`, `sigma_a`, `sigma_s`, `density_scale`, `emission_grid`, `temperature_grid`, `color_grid`, `emission_color`, `emission_intensity`, `temperature_scale`, `temperature_offset`, `blackbody_intensity` | a volume placed in the world (scene files only, instead of `input`): `name` (letters, digits, `_`, `-`; default `volume1`, `volume2`, … in order) names its alpha layer `volume_<name>.A` (written with two or more volumes); `file` relative to the scene file, read once however often it is listed with the same grids and emission; `translate = [x, y, z]`, `rotate = [x, y, z]` (degrees about the world axes, in that order), `scale = s` or `[x, y, z]` (applied scale, rotate, translate) or `matrix` (four rows, translation in the last column); `[[volume.keys]]` with `frame = N` and any of `translate`, `rotate`, `scale` (the others the table's), or a `matrix` (a volume placed by `matrix` is keyed by matrices, without shear), key the placement per frame (frames increasing; between keys translation and scale linear, rotation along the shortest arc; held outside the keys), so that with `shutter` the volume blurs along its motion; the grid, medium and emission keys as the scene's, for this volume (unset: the scene's). Where volumes overlap their coefficients and emission add. |\n";
