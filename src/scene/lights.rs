//! How the render's lights reach a point: the deep shadow map of each light (baked here
//! or read from a cache), a shadow ray per query, or no shadows.

use super::light::Light;
use super::plan::{RenderPlan, ShadowMode};
use super::progress::Progress;
use crate::field::Field;
use crate::integrate::Illumination;
use crate::shadow::cache::CacheError;
use crate::shadow::{
    BakeSettings, ColumnMarcher, ShadowMap, ShadowMapStats, ShadowQuadrature, bake_with, cache,
    density_integral, verify,
};
use glam::DVec3;
use std::time::Instant;

/// One light's transmittance source.
#[derive(Clone)]
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
    pub shadows: std::borrow::Cow<'a, [LightShadow]>,
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
    fn distance_to_light(&self, light: usize, x: DVec3) -> f64 {
        self.lights[light].toward(x).1
    }
}

/// Points `--dsm-verify` measures at.
pub const VERIFY_POINTS: usize = 10_000;

/// Bakes (or, with a cache, reads) one map per light. `sigma_t` is per unit density;
/// `columns` marches the bake's light columns where it takes the density (the GPU).
pub fn bake_maps(
    plan: &RenderPlan,
    density: &dyn Field,
    density_hash: u64,
    sigma_t: DVec3,
    progress: &dyn Progress,
    columns: Option<&dyn ColumnMarcher>,
) -> Result<(Vec<ShadowMap>, Vec<ShadowMapStats>), CacheError> {
    let settings = BakeSettings::new(plan.shadows.dsm_tolerance, sigma_t);
    progress.start("baking shadow maps", plan.lights.len() as u64, "lights");
    let cached = match &plan.shadows.cache {
        Some(path) => Some(cache::read(path, density, density_hash, &plan.lights)?),
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
                    plan.shadows
                        .cache
                        .as_ref()
                        .map(|p| p.display().to_string())
                        .unwrap_or_default()
                ),
            ),
            None => {
                let (map, report) = bake_with(density, light.geometry(), &settings, columns);
                (map, report, "baked".to_string())
            }
        };
        let bake_seconds = t.elapsed().as_secs_f64();
        let verify = plan.shadows.dsm_verify.then(|| {
            verify(
                &map,
                density,
                light.geometry(),
                sigma_t,
                plan.shadows.dsm_tolerance,
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
        progress.advance(1);
    }
    progress.finish();
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
