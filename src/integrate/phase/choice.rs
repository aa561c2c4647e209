//! Which phase function a medium scatters with: the `--phase` flag and the scene
//! file's `phase` key, with the parameters each one takes.

use super::water_drop::{RadiusError, WaterDrop};
use super::{HenyeyGreenstein, PhaseFunction};
use std::sync::Arc;

/// `--phase hg|water-drop`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum PhaseKind {
    /// Henyey–Greenstein with asymmetry `--g` (grey).
    #[default]
    Hg,
    /// Water drops of radius `--drop-radius` µm (Lorenz–Mie, in colour: rainbows).
    WaterDrop,
}

/// The phase function of `kind`: Henyey–Greenstein with `g`, or the water-drop tables
/// for `drop_radius_um` (cached in the process and on disk: [`WaterDrop::for_render`]).
pub fn build(
    kind: PhaseKind,
    g: f64,
    drop_radius_um: f64,
) -> Result<Arc<dyn PhaseFunction>, RadiusError> {
    Ok(match kind {
        PhaseKind::Hg => Arc::new(HenyeyGreenstein::new(g)),
        PhaseKind::WaterDrop => WaterDrop::for_render(drop_radius_um)?,
    })
}
