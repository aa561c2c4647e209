//! What the integrators march: a density in a medium, with its emission, colour tint,
//! the volumes' parts and how it moves within the shutter, and the volumes that move by
//! their keyed placements ([`TimedVolume`]).

use super::mattes::Mattes;
use super::medium::{ColorTint, Emission, Medium};
use super::motion::{Motion, MovedFields};
use super::phase::{HenyeyGreenstein, PhaseFunction};
use crate::field::Field;

/// Volumes placed by keys that move within the shutter: each camera sample sees them at
/// its time.
pub trait TimedVolume: Sync {
    /// Calls `f` with `base` (the volume at the frame's time) as it is `time` frames
    /// from the frame: its fields placed as then, everything else `base`'s.
    fn at_time(&self, base: &Volume, time: f64, f: &mut dyn FnMut(&Volume));
    /// The density bounded at every time of the shutter at once: its value ranges over
    /// any box hold the moving density's at any time (the path tracer's majorants).
    fn swept(&self) -> &dyn Field;
}

/// The parts of a scene the integral needs.
pub struct Volume<'a> {
    pub density: &'a dyn Field,
    pub medium: Medium,
    /// The angular distribution of scattering ([`Volume::of`]: Henyey–Greenstein with
    /// the medium's `g`).
    pub phase: std::sync::Arc<dyn PhaseFunction>,
    pub emission: Option<Emission<'a>>,
    /// Tints scattering per voxel.
    pub color: Option<ColorTint<'a>>,
    /// Fields whose non-zero cells must be visited even where density is zero (emission
    /// and temperature grids on the density's lattice).
    pub traversal: &'a dyn Field,
    /// Each segment's mean density from two-point Gauss–Legendre over the segment (two
    /// samples), not from the exact integral voxel by voxel: a second-order error that
    /// the step's error takes in, for a march whose steps are several voxels long
    /// (`--max-error` on a coarse density level). Off: opacity does not depend on the step.
    pub sampled_means: bool,
    /// Several volumes summed in `density`: each one's alpha is a layer of its own.
    pub mattes: Option<Mattes<'a>>,
    /// How the volume moves during the shutter: a ray with a time marches the fields as
    /// they are then (`None`: still).
    pub motion: Option<Motion<'a>>,
    /// Volumes whose keyed placements move within the shutter (`None`: none does).
    pub keyed: Option<&'a dyn TimedVolume>,
}

impl<'a> Volume<'a> {
    /// A density field in `medium`, scattering by Henyey–Greenstein with the medium's
    /// `g`, with no emission and no colour, traversed where the density is not zero.
    pub fn of(density: &'a dyn Field, medium: Medium) -> Self {
        Volume {
            density,
            medium,
            phase: std::sync::Arc::new(HenyeyGreenstein::new(medium.g)),
            emission: None,
            color: None,
            traversal: density,
            sampled_means: false,
            mattes: None,
            motion: None,
            keyed: None,
        }
    }
}

impl Volume<'_> {
    /// This volume with its fields as `fields` moved them (and no motion left).
    pub fn moved<'b>(&'b self, fields: &'b MovedFields<'b>) -> Volume<'b> {
        Volume {
            density: &fields.density,
            medium: self.medium,
            phase: self.phase.clone(),
            emission: self.emission.as_ref().map(|e| fields.emission(e)),
            color: fields.color(),
            traversal: fields.traversal(),
            sampled_means: self.sampled_means,
            mattes: self.mattes,
            motion: None,
            keyed: None,
        }
    }
}
