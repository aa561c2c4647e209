//! What the volume is made of and how it glows: the grids in their roles, the medium
//! (`sigma_a`, `sigma_s`, `density_scale`, `g`), the phase function and emission.

use super::defaults;
use super::values::{colour, drop_radius, non_negative};
use crate::integrate::Medium;
use crate::scene::options::RenderOptions;
use glam::DVec3;

/// A grid role as requested: detect it, use this grid, or leave it out.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum GridChoice {
    Detect,
    Named(String),
    Off,
}

impl GridChoice {
    pub(super) fn from(v: &Option<String>) -> GridChoice {
        match v.as_deref() {
            None => GridChoice::Detect,
            Some("none") | Some("") => GridChoice::Off,
            Some(n) => GridChoice::Named(n.to_string()),
        }
    }
}

/// Which field fills each role.
#[derive(Clone, Debug, PartialEq)]
pub struct GridRoles {
    pub density: GridChoice,
    pub emission: GridChoice,
    pub temperature: GridChoice,
    pub color: GridChoice,
}

impl GridRoles {
    pub(super) fn from_options(o: &RenderOptions) -> GridRoles {
        GridRoles {
            density: GridChoice::from(&o.density_grid),
            emission: GridChoice::from(&o.emission_grid),
            temperature: GridChoice::from(&o.temperature_grid),
            color: GridChoice::from(&o.color_grid),
        }
    }
}

/// The medium's coefficients and Henyey–Greenstein anisotropy.
pub(super) fn medium(o: &RenderOptions) -> Result<Medium, String> {
    let g = o.g.unwrap_or(defaults::G);
    if !(g > -1.0 && g < 1.0) {
        return Err(format!("{{g}} {g} must lie in (-1, 1)"));
    }
    Ok(Medium {
        sigma_a: colour(&o.sigma_a, DVec3::splat(defaults::SIGMA_A), "{sigma_a}")?,
        sigma_s: colour(&o.sigma_s, DVec3::splat(defaults::SIGMA_S), "{sigma_s}")?,
        density_scale: non_negative(o.density_scale, defaults::DENSITY_SCALE, "{density_scale}")?,
        g,
    })
}

/// The water-drop radius in µm (`drop_radius`), checked whatever the phase function.
pub(super) fn drop_radius_um(o: &RenderOptions) -> Result<f64, String> {
    drop_radius(o.drop_radius)
}

/// Emission: an emission field's colour and intensity, and blackbody emission from a
/// temperature field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmissionPlan {
    pub color: DVec3,
    pub intensity: f64,
    /// Kelvin = value × scale + offset.
    pub temperature_scale: f64,
    pub temperature_offset: f64,
    pub blackbody_intensity: f64,
}

impl EmissionPlan {
    pub(super) fn from_options(o: &RenderOptions) -> Result<EmissionPlan, String> {
        let temperature_offset = o.temperature_offset.unwrap_or(defaults::TEMPERATURE_OFFSET);
        if !temperature_offset.is_finite() {
            return Err(format!(
                "{{temperature_offset}} {temperature_offset} must be a finite number of kelvins"
            ));
        }
        Ok(EmissionPlan {
            color: colour(
                &o.emission_color,
                DVec3::from_array(defaults::EMISSION_COLOR),
                "{emission_color}",
            )?,
            intensity: non_negative(
                o.emission_intensity,
                defaults::EMISSION_INTENSITY,
                "{emission_intensity}",
            )?,
            temperature_scale: non_negative(
                o.temperature_scale,
                defaults::TEMPERATURE_SCALE,
                "{temperature_scale}",
            )?,
            temperature_offset,
            blackbody_intensity: non_negative(
                o.blackbody_intensity,
                defaults::BLACKBODY_INTENSITY,
                "{blackbody_intensity}",
            )?,
        })
    }
}
