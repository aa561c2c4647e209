//! The lights, how their transmittance is found, and the ground plane they light:
//! `light` (or a scene's `[[lights]]`), `no_lights`, `shadows`, `dsm_tolerance`,
//! `dsm_verify`, `shadow_cache`, `shadow_step`, `ground`, `ground_visible`.

use super::defaults;
use super::values::step_voxels;
use crate::integrate::ground::Ground;
use crate::scene::PlanError;
use crate::scene::light::{EnvLight, Light};
use crate::scene::options::RenderOptions;
use std::path::PathBuf;

/// How light transmittance is found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadowMode {
    /// A deep shadow map per light, baked before the render.
    Dsm,
    /// A shadow ray per sample and light.
    March,
    /// No shadows (lights reach every point unattenuated).
    None,
}

impl ShadowMode {
    /// `shadows`, or its default: marched shadow rays for `reference`, else the map.
    pub(super) fn from_options(o: &RenderOptions) -> Result<ShadowMode, String> {
        let default_shadows = if o.reference { "march" } else { "dsm" };
        match o.shadows.as_deref().unwrap_or(default_shadows) {
            "dsm" => Ok(ShadowMode::Dsm),
            "march" => Ok(ShadowMode::March),
            "none" => Ok(ShadowMode::None),
            other => Err(format!(
                "{{shadows}} \"{other}\": expected march, dsm or none"
            )),
        }
    }
}

/// How the lights' transmittance is found.
#[derive(Clone, Debug, PartialEq)]
pub struct ShadowPlan {
    pub mode: ShadowMode,
    /// Largest transmittance error of the deep shadow map.
    pub dsm_tolerance: f64,
    pub dsm_verify: bool,
    pub cache: Option<PathBuf>,
    /// Marched shadow rays' step, voxels.
    pub step: f64,
}

impl ShadowPlan {
    /// `tolerance_share`: the map's part of `max_error`, when one is asked for.
    pub(super) fn from_options(
        o: &RenderOptions,
        mode: ShadowMode,
        tolerance_share: Option<f64>,
    ) -> Result<ShadowPlan, String> {
        let t = o
            .dsm_tolerance
            .unwrap_or(tolerance_share.unwrap_or(defaults::DSM_TOLERANCE));
        if !(t > 0.0 && t < 1.0) {
            return Err(format!("{{dsm_tolerance}} {t} must lie in (0, 1)"));
        }
        Ok(ShadowPlan {
            mode,
            dsm_tolerance: t,
            dsm_verify: o.dsm_verify,
            cache: o.shadow_cache.clone(),
            step: step_voxels(o.shadow_step, defaults::SHADOW_STEP, "{shadow_step}")?,
        })
    }
}

/// The ground plane, if asked for.
pub(super) fn ground(o: &RenderOptions) -> Result<Option<Ground>, String> {
    match o.ground {
        Some(y) if !y.is_finite() => Err("{ground} must be a finite height".into()),
        g => Ok(g.map(|height| Ground {
            height,
            visible: o.ground_visible,
        })),
    }
}

/// The text of a light's error, its options still named by key.
fn message(e: PlanError) -> String {
    match e {
        PlanError::Invalid(m) => m,
        other => other.to_string(),
    }
}

/// The lights and the environment light(s): a scene's named lights, else the `light`
/// flags (named `sun0`, `point0`, `env0`… in order), else the default sun; none with
/// `no_lights`. Each light gets its safe layer name; at most [`defaults::MAX_LIGHTS`].
pub(super) fn lights(o: &RenderOptions) -> Result<(Vec<Light>, Vec<EnvLight>), String> {
    let mut lights = Vec::new();
    let mut environment = Vec::new();
    if o.no_lights {
        return Ok((lights, environment));
    }
    if !o.lights.is_empty() {
        for l in &o.lights {
            if EnvLight::is_env_spec(&l.spec) {
                environment.push(EnvLight::parse(&l.spec, l.name.clone()).map_err(message)?);
            } else {
                lights.push(Light::parse(&l.spec, l.name.clone()).map_err(message)?);
            }
        }
    } else {
        let specs = if o.light.is_empty() {
            vec![defaults::LIGHT.to_string()]
        } else {
            o.light.clone()
        };
        let (mut suns, mut points) = (0, 0);
        for s in &specs {
            if EnvLight::is_env_spec(s) {
                let name = format!("env{}", environment.len());
                environment.push(EnvLight::parse(s, name).map_err(message)?);
                continue;
            }
            let name = if s.starts_with("point") {
                points += 1;
                format!("point{}", points - 1)
            } else {
                suns += 1;
                format!("sun{}", suns - 1)
            };
            lights.push(Light::parse(s, name).map_err(message)?);
        }
    }
    if lights.len() > defaults::MAX_LIGHTS {
        return Err(format!(
            "{} lights: murk renders at most {} (each costs a shadow map and three channels)",
            lights.len(),
            defaults::MAX_LIGHTS
        ));
    }
    safe_light_names(&mut lights)?;
    Ok((lights, environment))
}

/// A light's name as a layer name compositors read as one layer: ASCII letters, digits
/// and `_` kept, every other character (`.`, which Blender and Nuke read as a layer
/// separator, spaces, `-`, anything not ASCII) becomes `_`; an empty name is `light`.
pub fn safe_layer_name(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() { "light".into() } else { s }
}

/// Gives every light its safe layer name; two lights that map to one name are refused.
fn safe_light_names(lights: &mut [Light]) -> Result<(), String> {
    let mut seen: Vec<(String, String)> = Vec::new();
    for l in lights.iter_mut() {
        let safe = safe_layer_name(&l.name);
        if let Some((first, _)) = seen.iter().find(|(_, s)| *s == safe) {
            if *first == l.name {
                return Err(format!(
                    "two lights named \"{first}\": each light's scatter layer is named after it"
                ));
            }
            return Err(format!(
                "lights \"{first}\" and \"{}\" would both be the layer scatter_{safe}: name them apart",
                l.name
            ));
        }
        seen.push((l.name.clone(), safe.clone()));
        l.name = safe;
    }
    Ok(())
}
