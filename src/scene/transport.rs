//! How light is transported in a render: the scattering mode (`--scattering`), the
//! scattering events a path may have (`--bounces`) and the environment light
//! (`--light env:…`), validated together because each mode accepts only some of them.

use super::light::EnvLight;
use super::options::RenderOptions;
use crate::integrate::ScatteringMode;
use crate::integrate::fast::FastSettings;
use crate::integrate::scattering::{MAX_BOUNCES, PATH_BOUNCES};

/// The scattering mode, its bounces and the environment light.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TransportPlan {
    pub mode: ScatteringMode,
    /// `--bounces` as given (each mode has its own default).
    pub bounces: Option<u32>,
    /// A uniform dome light (`--light env:R,G,B[:I]`).
    pub environment: Option<EnvLight>,
}

impl TransportPlan {
    /// The most scattering events a path may have (`--scattering path`).
    pub fn path_bounces(&self) -> u32 {
        self.bounces.unwrap_or(PATH_BOUNCES)
    }

    /// The scattering orders the fast approximation models (`--scattering fast`).
    pub fn fast_settings(&self) -> FastSettings {
        FastSettings {
            bounces: self
                .bounces
                .unwrap_or(crate::integrate::fast::DEFAULT_BOUNCES),
            ..FastSettings::default()
        }
    }

    /// Validates the mode against the bounces and lights it was given.
    pub(super) fn new(
        o: &RenderOptions,
        environment: Vec<EnvLight>,
    ) -> Result<TransportPlan, String> {
        let mode = o.scattering.unwrap_or_default();
        if environment.len() > 1 {
            return Err(format!(
                "{{light}} env: given {} times: a render has one environment light at most",
                environment.len()
            ));
        }
        let environment = environment.into_iter().next();
        if let Some(b) = o.bounces {
            if b == 0 || b > MAX_BOUNCES {
                return Err(format!("{{bounces}} {b} must be from 1 to {MAX_BOUNCES}"));
            }
            if mode == ScatteringMode::Single && b != 1 {
                return Err(format!(
                    "{{bounces}} {b}: {{scattering}} single scatters once; use {{scattering}} path (or fast) for more"
                ));
            }
        }
        match mode {
            ScatteringMode::Fast => {}
            ScatteringMode::Path if o.ground.is_some() => {
                return Err(
                    "{ground}: the path tracer has no ground plane yet (use {scattering} single)"
                        .into(),
                );
            }
            ScatteringMode::Path => {}
            ScatteringMode::Single => {}
        }
        if let Some(e) = &environment
            && mode != ScatteringMode::Path
        {
            return Err(format!(
                "{{light}} env ({}): an environment light needs {{scattering}} path ({} scattering cannot light with one)",
                e.name,
                mode.name()
            ));
        }
        Ok(TransportPlan {
            mode,
            bounces: o.bounces,
            environment,
        })
    }
}
