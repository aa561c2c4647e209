//! What another renderer of the same paths reads of a [`PathTracer`] (the GPU's path
//! tracer: the passes it fills, its lights, bounces and majorants), and on which of a
//! pixel's samples the camera ray's opacity is computed.

use super::PathTracer;
use crate::accel::MajorantGrid;
use crate::integrate::scatter_passes::ScatterPasses;

/// The parts of a [`PathTracer`] another renderer of its paths needs.
pub struct PathParts<'a> {
    /// The passes, and the writes of each sample's values into them.
    pub passes: &'a ScatterPasses,
    /// Sun and point lights sampled at every event (0: nothing scatters).
    pub lights: usize,
    /// A uniform dome lights the medium.
    pub environment: bool,
    /// The volume emits (gathered along every flight).
    pub emits: bool,
    /// The most scattering events of a path.
    pub bounces: u32,
    /// Free flights step through these blocks (`None`: through the tree's cells).
    pub majorants: Option<&'a MajorantGrid>,
    /// Shadow rays by ratio tracking (else the lights' lookups).
    pub ratio_tracking: bool,
    /// The density the camera rays are expressed in the index space of.
    pub density: &'a dyn crate::field::Field,
    /// Extinction per unit density (R, G, B).
    pub sigma_t: glam::DVec3,
}

impl<'a> PathTracer<'a> {
    /// The parts another renderer of these paths needs.
    pub fn parts(&self) -> PathParts<'_> {
        PathParts {
            passes: &self.passes,
            lights: self.n_lights,
            environment: self.environment.is_some(),
            emits: self.volume.emission.as_ref().is_some_and(|e| e.is_active()),
            bounces: self.settings.bounces,
            majorants: self.majorants.as_deref(),
            ratio_tracking: self.settings.transmittance == super::LightTransmittance::RatioTracking,
            density: self.volume.density,
            sigma_t: self.sigma_t,
        }
    }

    /// The weight of the camera ray's opacity (`A`, `Z`) on a pixel's sample `index`:
    /// 1 on every sample, or `spp / n` on the first `n` and none after
    /// ([`PathTracer::with_opacity_samples`]).
    pub fn alpha_weight(&self, index: u32) -> Option<f64> {
        match self.opacity_samples {
            None => Some(1.0),
            Some(o) => (index < o.n).then_some(o.weight),
        }
    }
}
