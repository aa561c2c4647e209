//! What building a scene did: which grids fill which role, what was decoded, sanitised
//! and baked, and which stages ran or were skipped and why. The render's stats
//! (`--stats FILE.json`) carry it, under the same keys.

use crate::shadow::ShadowMapStats;
use serde::Serialize;
use std::collections::BTreeMap;

/// A pipeline stage: whether it ran, and how long it took.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Stage {
    /// `ran`, or `skipped: <reason>`.
    pub status: String,
    pub seconds: f64,
}

impl Stage {
    pub fn ran(seconds: f64) -> Stage {
        Stage {
            status: "ran".into(),
            seconds,
        }
    }
    pub fn skipped(reason: &str) -> Stage {
        Stage {
            status: format!("skipped: {reason}"),
            seconds: 0.0,
        }
    }
}

/// Bad voxels replaced by 0 in one grid.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct Sanitised {
    pub nan: u64,
    pub inf: u64,
    pub negative: u64,
}

#[derive(Clone, Debug, Default, Serialize)]
pub struct SceneReport {
    /// Stage name → status and time: load, build, shadows, emission, scatter, render, write.
    pub stages: BTreeMap<String, Stage>,
    /// Role → grid name (`density`, `emission`, `temperature`), for the roles filled.
    pub grid_roles: BTreeMap<String, String>,
    /// Grids decoded from the file.
    pub grids_decoded: Vec<String>,
    /// Grids in the file never decoded (nobody referenced them).
    pub grids_not_decoded: Vec<String>,
    /// Grid → voxels sanitised at load.
    pub sanitised: BTreeMap<String, Sanitised>,
    pub sanitised_total: u64,
    /// Render-structure memory of the decoded grids, bytes.
    pub grid_memory_bytes: usize,
    pub lights: Vec<String>,
    pub shadows: String,
    /// Per light, with `--shadows dsm`: how its deep shadow map was made and what it holds.
    pub shadow_maps: Vec<ShadowMapStats>,
    /// All shadow maps' memory, bytes, and the density structure's, to compare.
    pub shadow_map_memory_bytes: usize,
    pub density_memory_bytes: usize,
    /// With the march on a GPU: the bytes of the scene's buffers there (the grids' nodes,
    /// the shadow maps, the lights, phase table, lattice and blackbody colours, the
    /// parameters), to compare with the two above; 0 on the CPU.
    pub gpu_memory_bytes: usize,
    /// Of those, the bytes this render uploaded: all of them, but in a sequence only
    /// those that differ from the frame before's (0: the frame before's were all kept).
    pub gpu_upload_bytes: u64,
    /// With the march on a GPU: the bytes of the GPU's buffers the camera samples stream
    /// through (the inputs and results of the two chunks in flight), besides
    /// `gpu_memory_bytes`: they grow with the image up to a bound, not with the scene.
    pub gpu_stream_bytes: u64,
    /// With the march on a GPU: the buffers the grids' node tables and their values
    /// went in, `[tables, values]` (1 each while they fit the adapter's largest binding,
    /// else up to 4 parts each); `[0, 0]` on the CPU.
    pub gpu_grid_parts: [usize; 2],
    pub notes: Vec<String>,
    /// What cost accuracy without being asked to (a budget that stopped a shadow map's
    /// refinement): printed on stderr as well, even with `--quiet`.
    pub warnings: Vec<String>,
    /// Production caches: the tool the file is taken to come from and how that was told
    /// (`null` when nothing tells), the up axis assumed and why, the temperature
    /// convention assumed, and grids in a role left out because they add nothing
    /// (grid → reason).
    pub source_tool: Option<String>,
    pub up_axis: String,
    pub temperature_convention: Option<TemperatureConvention>,
    pub skipped_grids: BTreeMap<String, String>,
}

/// How temperature became Kelvin: Kelvin = value × scale + offset.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct TemperatureConvention {
    /// `kelvin`, `blender-normalised`, `houdini-normalised`, `normalised` or `explicit`.
    pub convention: String,
    pub scale: f64,
    pub offset: f64,
    pub reason: String,
    /// The grid's largest value, and that in Kelvin.
    pub max_value: f64,
    pub max_kelvin: f64,
    /// Whether the temperature glows (blackbody emission) and why: `on: …` or `off: …`.
    pub emission: String,
}
