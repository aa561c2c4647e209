//! How finely the march samples a ray: the step (in voxels of the density grid), the
//! early-termination transmittance, and how far steps grow in optically thin cells.

/// Largest optical depth (majorant × step) a step of the default length (0.5 voxel) may
/// cover before it is no longer lengthened in thin cells; it scales with the step.
pub const THIN_STEP_DEPTH: f64 = 0.01;

/// The source term's step of the reference render, in voxels.
pub const REFERENCE_STEP: f64 = 1.0 / 64.0;

/// Step, jitter and termination of the march.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MarchSettings {
    /// Largest segment, in voxels of the density grid.
    pub step_voxels: f64,
    /// Transmittance below which the march stops (T set to 0).
    pub termination: f64,
}

/// The default march step, in voxels.
pub const DEFAULT_STEP: f64 = 0.5;
/// The default early-termination transmittance.
pub const DEFAULT_TERMINATION: f64 = 1e-4;

impl Default for MarchSettings {
    fn default() -> Self {
        MarchSettings {
            step_voxels: DEFAULT_STEP,
            termination: DEFAULT_TERMINATION,
        }
    }
}

impl MarchSettings {
    /// The reference render's march: [`REFERENCE_STEP`], never terminated early.
    pub fn reference() -> Self {
        MarchSettings {
            step_voxels: REFERENCE_STEP,
            termination: 0.0,
        }
    }

    /// Optical depth a lengthened step in a thin cell may reach: [`THIN_STEP_DEPTH`] at
    /// the default step, proportional to the step.
    pub fn thin_step_depth(&self) -> f64 {
        THIN_STEP_DEPTH * (self.step_voxels / 0.5)
    }
}
