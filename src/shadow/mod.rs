//! Light transmittance: how much density lies between a point and a light.
//!
//! `march` integrates it along a shadow ray per query (the reference). The deep shadow
//! map bakes it once per light on a sparse, adaptive light-space lattice ([`chart`],
//! [`map`], [`bake`]) and answers each query from the samples around it; [`verify`] measures
//! the map against marched rays.

pub mod bake;
pub mod cache;
pub mod chart;
pub mod columns;
mod lattice;
pub mod map;
pub mod march;
pub mod verify;

pub use bake::{BakeReport, BakeSettings, LightGeometry, bake};
pub use map::ShadowMap;
pub use march::{ShadowQuadrature, density_integral};
pub use verify::{VerifyReport, verify};

/// A light as a shadow map and its cache know it: a name (the cache's grids carry it)
/// and where it is.
pub trait CachedLight {
    fn name(&self) -> &str;
    fn geometry(&self) -> LightGeometry;
}

/// A deep shadow map as the stats report it.
#[derive(Clone, Debug, Default, serde::Serialize, PartialEq)]
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
