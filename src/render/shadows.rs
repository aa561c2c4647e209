//! How the render's lights reach a point: the deep shadow map of each light (baked here
//! or read from a cache), a shadow ray per query, or no shadows.

use super::light::Light;
use super::plan::{RenderPlan, ShadowMode};
use crate::field::Field;
use crate::integrate::Illumination;
use crate::shadow::{
    BakeReport, BakeSettings, ShadowMap, ShadowQuadrature, VerifyReport, bake, density_integral,
    verify,
};
use glam::DVec3;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use std::time::Instant;

/// One light's transmittance source.
pub enum LightShadow {
    /// A trilinear lookup in the light's deep shadow map.
    Map(ShadowMap),
    /// A shadow ray marched per query.
    Marched,
    /// No shadows.
    Unshadowed,
}

/// The lights of a render with their shadows.
pub struct SceneLights<'a> {
    pub lights: &'a [Light],
    pub density: &'a dyn Field,
    pub shadows: Vec<LightShadow>,
    pub quadrature: ShadowQuadrature,
    /// `∫ρ ds` past which transmittance is 0 for every channel (marched rays stop there).
    pub enough: f64,
}

impl Illumination for SceneLights<'_> {
    fn light_count(&self) -> usize {
        self.lights.len()
    }
    fn incident(&self, light: usize, x: DVec3) -> (DVec3, DVec3) {
        self.lights[light].incident(x)
    }
    #[inline]
    fn density_to_light(&self, light: usize, x: DVec3) -> f64 {
        match &self.shadows[light] {
            LightShadow::Map(m) => m.density_integral(x),
            LightShadow::Marched => {
                let (dir, dist) = self.lights[light].toward(x);
                density_integral(self.density, x, dir, dist, self.quadrature, self.enough)
            }
            LightShadow::Unshadowed => 0.0,
        }
    }
}

/// A deep shadow map as the stats report it.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct ShadowMapStats {
    pub light: String,
    /// `baked`, or `cache: FILE`.
    pub source: String,
    pub bake_seconds: f64,
    #[serde(flatten)]
    pub bake: BakeReport,
    /// With `--dsm-verify`: transmittance error against marched shadow rays.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub verify: Option<VerifyReport>,
}

/// Points `--dsm-verify` measures at.
pub const VERIFY_POINTS: usize = 10_000;

/// Bakes (or, with a cache, reads) one map per light. `sigma_t` is per unit density.
pub fn bake_maps(
    plan: &RenderPlan,
    density: &dyn Field,
    density_hash: u64,
    sigma_t: DVec3,
    quiet: bool,
) -> anyhow::Result<(Vec<ShadowMap>, Vec<ShadowMapStats>)> {
    let settings = BakeSettings::new(plan.dsm_tolerance, sigma_t);
    let progress = if quiet || !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(plan.lights.len() as u64)
    };
    progress.set_style(
        ProgressStyle::with_template(
            "{spinner} baking shadow maps [{bar:40}] {pos}/{len} lights {elapsed}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let cached = match &plan.shadow_cache {
        Some(path) => Some(super::shadow_cache::read(
            path,
            density,
            density_hash,
            &plan.lights,
        )?),
        None => None,
    };
    let mut maps = Vec::with_capacity(plan.lights.len());
    let mut stats = Vec::with_capacity(plan.lights.len());
    let mut cached = cached.map(|v| v.into_iter());
    for light in &plan.lights {
        let t = Instant::now();
        let (map, report, source) = match cached.as_mut().and_then(|c| c.next()) {
            Some((map, report)) => (
                map,
                report,
                format!(
                    "cache: {}",
                    plan.shadow_cache
                        .as_ref()
                        .map(|p| p.display().to_string())
                        .unwrap_or_default()
                ),
            ),
            None => {
                let (map, report) = bake(density, light.geometry(), &settings);
                (map, report, "baked".to_string())
            }
        };
        let bake_seconds = t.elapsed().as_secs_f64();
        let verify = plan.dsm_verify.then(|| {
            verify(
                &map,
                density,
                light.geometry(),
                sigma_t,
                plan.dsm_tolerance,
                VERIFY_POINTS,
                0x5eed,
            )
        });
        stats.push(ShadowMapStats {
            light: light.name.clone(),
            source,
            bake_seconds,
            bake: report,
            verify,
        });
        maps.push(map);
        progress.inc(1);
    }
    progress.finish_and_clear();
    Ok((maps, stats))
}

/// The transmittance source of every light for a plan's shadow mode.
pub fn light_shadows(mode: ShadowMode, maps: Vec<ShadowMap>, lights: usize) -> Vec<LightShadow> {
    match mode {
        ShadowMode::Dsm if maps.len() == lights => maps.into_iter().map(LightShadow::Map).collect(),
        // Not baked (nothing needs the lights' shadows): march, should anything ask.
        ShadowMode::Dsm => (0..lights).map(|_| LightShadow::Marched).collect(),
        ShadowMode::March => (0..lights).map(|_| LightShadow::Marched).collect(),
        ShadowMode::None => (0..lights).map(|_| LightShadow::Unshadowed).collect(),
    }
}
