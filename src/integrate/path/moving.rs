//! The path tracer through a volume that moves within the shutter: each camera sample's
//! path, every flight and shadow ray of it, sees the volume as it is at the sample's
//! time (its fields advected back along the velocity), under majorants padded by the
//! farthest displacement in the shutter, so one grid bounds the density at every time.
//! Volumes moved by their keyed placements likewise, under the majorants of the density
//! swept over the shutter.

use super::{PathScratch, PathTracer};
use crate::accel::MajorantGrid;
use crate::field::advect::Advected;
use crate::integrate::integrator::{CameraSample, SampleRng};
use crate::integrate::march::Volume;
use crate::integrate::motion::MovedFields;

/// The density's majorants over blocks of `block` voxels: where the volume moves, its
/// range over each block grown by the shutter's largest displacement.
pub(super) fn majorants(volume: &Volume, block: i32) -> MajorantGrid {
    if let Some(k) = volume.keyed {
        return MajorantGrid::build(k.swept(), block);
    }
    match &volume.motion {
        Some(m) if m.max_displacement(m.frames) > 0.0 => MajorantGrid::build(
            &Advected::new(volume.density, m.velocity, m.shift(m.frames)),
            block,
        ),
        _ => MajorantGrid::build(volume.density, block),
    }
}

impl PathTracer<'_> {
    /// One camera sample, through the volume as it is at the sample's time.
    pub(super) fn sample_at_its_time(
        &self,
        camera: &CameraSample,
        rng: &mut SampleRng,
        scratch: &mut PathScratch,
        acc: &mut [f64],
    ) -> u64 {
        let v = self.volume;
        if let Some(k) = v.keyed {
            let mut samples = 0;
            k.at_time(v, camera.ray.time, &mut |moved| {
                let view = PathTracer {
                    volume: moved,
                    passes: self.passes.clone(),
                    majorants: self.majorants.clone(),
                    ..*self
                };
                samples = view.sample_still(camera, rng, scratch, acc);
            });
            return samples;
        }
        let Some(m) = v
            .motion
            .as_ref()
            .filter(|m| m.max_displacement(camera.ray.time) > 0.0)
        else {
            return self.sample_still(camera, rng, scratch, acc);
        };
        // A path's flights are many rays: each lookup advects on its own.
        let fields = MovedFields::new(
            v.density,
            v.traversal,
            v.emission.as_ref(),
            v.color.as_ref(),
            m,
            m.shift(camera.ray.time),
            None,
        );
        let moved = v.moved(&fields);
        let view = PathTracer {
            volume: &moved,
            passes: self.passes.clone(),
            majorants: self.majorants.clone(),
            ..*self
        };
        view.sample_still(camera, rng, scratch, acc)
    }
}
