//! Turns [`RenderOptions`] into a validated [`RenderPlan`]: every number checked, every
//! default filled in, before anything is loaded. Each part of the plan checks its own
//! options ([`camera`], [`look`], [`lighting`], [`quality`], [`outputs`], and the
//! scattering in [`super::transport`]); errors name options as `{key}` (see
//! [`PlanError`]).

mod camera;
pub mod defaults;
pub mod device;
mod lighting;
mod look;
mod motion;
mod outputs;
mod quality;
mod shot;
mod values;
mod volume_keys;
mod volumes;

pub use camera::{CameraPlan, CameraRequest};
pub use defaults::{MAX_FRAME_BYTES, MAX_LIGHTS, MAX_THREADS, MIN_STEP_VOXELS};
pub use device::{Device, LatticeDevice};
pub use lighting::{ShadowMode, ShadowPlan, safe_layer_name};
pub use look::{EmissionPlan, GridChoice, GridRoles};
pub use motion::{MAX_SHUTTER_FRAMES, MotionPlan};
pub use outputs::{DeepPlan, OutputPlan, ProductionPlan};
pub use quality::{MarchPlan, SamplingPlan};
pub use shot::{ShotCameraAt, ShotPlan};
pub use volume_keys::{PlacementKey, PlacementKeys};
pub use volumes::{VolumePlan, VolumesPlan};

use super::PlanError;
use super::light::Light;
use super::options::RenderOptions;
use super::transport::TransportPlan;
use crate::integrate::ground::Ground;
use crate::integrate::phase::PhaseKind;
use crate::integrate::{MarchSettings, Medium};
use crate::shadow::ShadowQuadrature;
use std::path::PathBuf;

/// A validated render: every number checked, every default filled in.
#[derive(Clone, Debug)]
pub struct RenderPlan {
    /// The input (a `.vdb`).
    pub input: PathBuf,
    pub camera: CameraPlan,
    pub grids: GridRoles,
    pub medium: Medium,
    /// The phase function (`--phase`; Henyey–Greenstein takes `medium.g`) and the drop
    /// radius in µm for water drops (`--drop-radius`).
    pub phase: PhaseKind,
    pub drop_radius_um: f64,
    pub emission: EmissionPlan,
    pub lights: Vec<Light>,
    pub shadows: ShadowPlan,
    /// A ground plane lit through the volume.
    pub ground: Option<Ground>,
    pub march: MarchPlan,
    pub sampling: SamplingPlan,
    pub outputs: OutputPlan,
    pub production: ProductionPlan,
    /// The scattering mode, its bounces and the environment light.
    pub transport: TransportPlan,
    /// A scene file's `[[volume]]` tables (then `input` is the first one's file, and
    /// `medium` their sum's), `None` for one input.
    pub volumes: Option<VolumesPlan>,
    /// The shutter and how the velocity grid moves the volume.
    pub motion: MotionPlan,
}

impl RenderPlan {
    /// Validates options; `input` is the VDB file (from the command line or the scene).
    pub fn new(o: &RenderOptions, input: PathBuf) -> Result<RenderPlan, PlanError> {
        Self::validated(o, input).map_err(PlanError::Invalid)
    }

    fn validated(o: &RenderOptions, input: PathBuf) -> Result<RenderPlan, String> {
        let outputs = outputs::OutputPlan::from_options(o, &input)?;
        let camera = CameraPlan::from_options(o)?;
        let (lights, environment) = lighting::lights(o)?;
        outputs::check_frame_size(camera.width, camera.height, lights.len())?;
        let transport = TransportPlan::new(o, environment)?;
        if outputs.deep.is_some() && transport.mode == crate::integrate::ScatteringMode::Path {
            return Err("{deep} needs --scattering single or fast: the path tracer keeps no record of its rays in depth".into());
        }
        let shadow_mode = ShadowMode::from_options(o)?;
        let march = MarchPlan::from_options(o, shadow_mode, transport.mode)?;
        let (volumes, medium) = match volumes::volumes(o, look::medium(o)?)? {
            Some((v, m)) => (Some(v), m),
            None => (None, look::medium(o)?),
        };
        Ok(RenderPlan {
            input,
            camera,
            grids: GridRoles::from_options(o),
            medium,
            phase: o.phase.unwrap_or_default(),
            drop_radius_um: look::drop_radius_um(o)?,
            emission: EmissionPlan::from_options(o)?,
            lights,
            shadows: ShadowPlan::from_options(o, shadow_mode, march.dsm_tolerance_share())?,
            ground: lighting::ground(o)?,
            march,
            sampling: SamplingPlan::from_options(o)?,
            outputs,
            production: ProductionPlan::from_options(o)?,
            transport,
            volumes,
            motion: MotionPlan::from_options(o)?,
        })
    }

    /// The camera ray's march: `--step` and `--termination` (the reference's when
    /// `--reference`).
    pub fn march_settings(&self) -> MarchSettings {
        MarchSettings {
            step_voxels: self.march.step,
            termination: self.march.termination,
        }
    }

    /// How marched shadow rays integrate density: exactly (per voxel, two-point
    /// Gauss–Legendre) for `--reference`, else the midpoint rule at `--shadow-step`.
    pub fn shadow_quadrature(&self) -> ShadowQuadrature {
        if self.march.reference {
            ShadowQuadrature::Exact
        } else {
            ShadowQuadrature::Step(self.shadows.step)
        }
    }
}

#[cfg(test)]
mod tests;
