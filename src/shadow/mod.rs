//! Light transmittance: how much density lies between a point and a light.
//!
//! `march` integrates it along a shadow ray per query (the reference). The deep shadow
//! map bakes it once per light on a sparse, adaptive light-space lattice ([`chart`],
//! [`map`], [`bake`]) and answers each query from the samples around it; [`verify`] measures
//! the map against marched rays.

pub mod bake;
pub mod brick;
pub mod cache;
mod cache_bricks;
mod cache_check;
mod cache_error;
mod cache_layout;
pub mod chart;
pub mod column_marcher;
pub mod columns;
pub mod flat;
mod lattice;
mod level_checks;
pub mod map;
pub mod march;
mod refine;
pub mod settings;
pub mod verify;

pub use bake::{bake, bake_with};
pub use column_marcher::{BAKE_BATCH_SAMPLES, ColumnJob, ColumnMarcher, MarchedColumns};
pub use map::ShadowMap;
pub use march::{ShadowQuadrature, density_integral};
pub use settings::{BakePhases, BakeReport, BakeSettings, LightGeometry};
pub use verify::{VerifyReport, verify};

/// A light as a shadow map and its cache know it: a name (the cache's grids carry it)
/// and where it is.
pub trait CachedLight {
    fn name(&self) -> &str;
    fn geometry(&self) -> LightGeometry;
}

/// A deep shadow map as the stats report it.
#[derive(Clone, Debug, Default, serde::Serialize)]
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

impl ShadowMapStats {
    /// One line when a budget or cap stopped refinement short of `tolerance`: how many
    /// bricks and what transmittance error to expect there. `None` when the map met it.
    pub fn shortfall(&self, tolerance: f64) -> Option<String> {
        let b = &self.bake;
        let mut parts = Vec::new();
        if b.lattice_coarsenings > 0 {
            parts.push(format!(
                "its lattice is {}× the voxel because a finer one did not fit the budget, so detail below that is blurred",
                1u64 << b.lattice_coarsenings.min(62) as u32
            ));
        }
        // Bricks kept at the finest level whose expected error is still within the
        // tolerance are not a shortfall; a budget stop always is.
        if b.bricks_stopped_by_budget > 0
            || (b.bricks_over_tolerance > 0 && b.over_tolerance_error > tolerance)
        {
            let budget = if b.bricks_stopped_by_budget > 0 {
                format!(
                    " ({} stopped by the sample or work budget)",
                    b.bricks_stopped_by_budget
                )
            } else {
                String::new()
            };
            parts.push(format!(
                "{} of {} bricks are likely over the tolerance {tolerance:e}{budget}, with transmittance errors up to about {:.1e} there",
                b.bricks_over_tolerance,
                b.bricks,
                b.over_tolerance_error.max(tolerance)
            ));
        }
        (!parts.is_empty())
            .then(|| format!("shadow map of light {}: {}", self.light, parts.join("; ")))
    }
}
