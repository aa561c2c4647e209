//! How closely the camera ray is integrated and how it is sampled: `step`,
//! `termination`, `reference`, `max_error`, `spp`, `antialias`, `seed`, `threads`.

use super::defaults;
use super::lighting::ShadowMode;
use super::values::step_voxels;
use crate::integrate::ScatteringMode;
use crate::integrate::march::REFERENCE_STEP;
use crate::scene::options::RenderOptions;

/// The camera ray's march.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MarchPlan {
    /// Reference quality: exact shadow optical depth, a tiny source step, no termination
    /// (see [`RenderPlan::march_settings`](super::RenderPlan::march_settings),
    /// [`RenderPlan::shadow_quadrature`](super::RenderPlan::shadow_quadrature)).
    pub reference: bool,
    pub step: f64,
    pub termination: f64,
    /// `--max-error`: the relative radiance RMSE to meet; the step and termination are
    /// then chosen by a pilot render (`render::error_budget`), the map's tolerance here.
    pub max_error: Option<f64>,
}

impl MarchPlan {
    /// The part of `--max-error` each of the three independent error sources (step,
    /// termination, shadow-map tolerance) may take: their squares add up to it.
    pub fn error_share(max_error: f64) -> f64 {
        max_error / 3f64.sqrt()
    }

    /// The shadow map's tolerance under `max_error`: its share of the error, but no
    /// coarser than 5 % (the map's bound is on transmittance, not on each pixel's
    /// radiance).
    pub fn dsm_tolerance_share(&self) -> Option<f64> {
        self.max_error.map(Self::tolerance_of)
    }

    /// The shadow map's tolerance for an error `e` shared by the step, the termination
    /// and the map.
    pub fn tolerance_of(e: f64) -> f64 {
        Self::error_share(e).min(0.05)
    }

    /// The share of `max_error` the shutter's sampling noise takes when something moves
    /// while the shutter is open: a fourth independent source, as large as each of the
    /// other three (`render::error_budget`).
    pub fn noise_share(max_error: f64) -> f64 {
        max_error / 2.0
    }

    /// What is left of `max_error` for the step, the termination and the map once the
    /// density's level has taken `level_error` and, when something moves while the
    /// shutter is open, the shutter's noise its share (their squares add up).
    pub fn march_error(max_error: f64, level_error: f64, moving: bool) -> f64 {
        let e = Self::remaining_error(max_error, level_error);
        if moving {
            Self::remaining_error(e, Self::noise_share(e))
        } else {
            e
        }
    }

    /// What is left of `max_error` for the step, the termination and the map once the
    /// density's level has taken `level_error` (their squares add up).
    pub fn remaining_error(max_error: f64, level_error: f64) -> f64 {
        (max_error * max_error - level_error * level_error)
            .max(0.0)
            .sqrt()
    }

    pub(super) fn from_options(
        o: &RenderOptions,
        shadows: ShadowMode,
        scattering: ScatteringMode,
    ) -> Result<MarchPlan, String> {
        let termination = o.termination.unwrap_or(if o.reference {
            0.0
        } else {
            defaults::TERMINATION
        });
        if !(0.0..1.0).contains(&termination) {
            return Err(format!("{{termination}} {termination} must lie in [0, 1)"));
        }
        if o.reference && shadows != ShadowMode::March {
            return Err(format!(
                "{{reference}} marches exact shadow rays: it cannot be combined with {{shadows}} {}",
                o.shadows.as_deref().unwrap_or("")
            ));
        }
        if o.reference && termination != 0.0 {
            return Err(format!(
                "{{reference}} never stops a ray early: it cannot be combined with {{termination}} {termination}"
            ));
        }
        let max_error = match o.max_error {
            None => None,
            Some(e) if !(e > 0.0 && e < 1.0) => {
                return Err(format!("{{max_error}} {e} must lie in (0, 1)"));
            }
            Some(e) => {
                for (set, flag) in [
                    (o.step.is_some(), "{step}"),
                    (o.termination.is_some(), "{termination}"),
                    (o.dsm_tolerance.is_some(), "{dsm_tolerance}"),
                    (o.reference, "{reference}"),
                ] {
                    if set {
                        return Err(format!(
                            "{{max_error}} chooses the step, the termination and the shadow map's tolerance itself: it cannot be combined with {flag}"
                        ));
                    }
                }
                if scattering == ScatteringMode::Path {
                    return Err("{max_error} sets the march's error; {scattering} path's error is its noise (set {spp} instead)".into());
                }
                Some(e)
            }
        };
        let default_step = if o.reference {
            REFERENCE_STEP
        } else {
            defaults::STEP
        };
        Ok(MarchPlan {
            reference: o.reference,
            step: step_voxels(o.step, default_step, "{step}")?,
            termination,
            max_error,
        })
    }
}

/// Samples, their random numbers and the threads that take them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SamplingPlan {
    pub spp: u32,
    /// `--antialias N`: at one sample a pixel, silhouette pixels get N×N stratified
    /// samples (1: pixel centres only).
    pub antialias: u32,
    pub seed: u64,
    /// `spp` was given (`--spp`, the scene file): `--max-error` keeps it rather than
    /// choosing the samples for the shutter's noise.
    pub spp_given: bool,
    pub threads: Option<usize>,
    /// `--device`: where the pixels are computed.
    pub device: super::device::Device,
    /// Where the fast mode's lattice is swept under a GPU render (`MURK_GPU_LATTICE`).
    pub lattice: super::device::LatticeDevice,
}

impl SamplingPlan {
    pub(super) fn from_options(o: &RenderOptions) -> Result<SamplingPlan, String> {
        let spp = o.spp.unwrap_or(defaults::SPP);
        let antialias = o.antialias.unwrap_or(defaults::ANTIALIAS);
        if antialias == 0 || antialias > 16 {
            return Err(format!("{{antialias}} {antialias} must be from 1 to 16"));
        }
        if spp == 0 || spp > 4096 {
            return Err(format!("{{spp}} {spp} must be from 1 to 4096"));
        }
        match o.threads {
            Some(0) => return Err("{threads} must be at least 1".into()),
            Some(n) if n > defaults::MAX_THREADS => {
                return Err(format!(
                    "{{threads}} {n} is more than murk starts (at most {})",
                    defaults::MAX_THREADS
                ));
            }
            _ => {}
        }
        Ok(SamplingPlan {
            spp,
            antialias,
            seed: o.seed.unwrap_or(defaults::SEED),
            spp_given: o.spp.is_some(),
            threads: o.threads,
            device: o.device.unwrap_or_default(),
            lattice: super::device::LatticeDevice::from_env()?,
        })
    }
}
