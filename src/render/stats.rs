//! What a render did, written with `--stats FILE.json`. Keys are stable (docs/guide.md lists them).

pub use crate::scene::report::{Sanitised, SceneReport, Stage};
use serde::Serialize;

#[derive(Clone, Debug, Default, Serialize)]
pub struct RenderStats {
    pub murk_version: String,
    pub input: String,
    pub output: String,
    pub width: usize,
    pub height: usize,
    pub spp: u32,
    /// Stages, grids in their roles, shadow maps and notes.
    #[serde(flatten)]
    pub scene: SceneReport,
    /// Where the pixels were computed: `cpu`, or `gpu: ` and the adapter's name.
    pub device: String,
    /// EXR channels written.
    pub channels: Vec<String>,
    pub rays: u64,
    pub samples: u64,
    pub samples_per_second: f64,
    pub total_seconds: f64,
    /// With `--max-error`: the settings chosen and what the pilot measured.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error_budget: Option<super::error_budget::ErrorBudgetReport>,
    /// With `--scattering fast`: the lattice of multiple scattering (its size, cell,
    /// orders swept per light and the tail's ratio).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub multiple_scattering: Option<crate::integrate::ms_lattice::LatticeReport>,
}
