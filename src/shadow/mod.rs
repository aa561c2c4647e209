//! Light transmittance: how much density lies between a point and a light.
//!
//! `march` integrates it along a shadow ray per query (the reference). The deep shadow
//! map bakes it once per light on a sparse, adaptive light-space lattice ([`chart`],
//! [`map`], [`bake`]) and answers each query from the samples around it; [`verify`] measures
//! the map against marched rays.

pub mod bake;
pub mod chart;
pub mod columns;
pub mod map;
pub mod march;
pub mod verify;

pub use bake::{BakeReport, BakeSettings, LightGeometry, bake};
pub use map::ShadowMap;
pub use march::{ShadowQuadrature, density_integral};
pub use verify::{VerifyReport, verify};
