//! Light transmittance: how much density lies between a point and a light.
//!
//! `march` integrates it along a shadow ray per query (the reference); the deep shadow
//! map (a baked, sparse structure of optical depth per light) comes behind the same
//! `--shadows` flag.

pub mod march;

pub use march::{ShadowQuadrature, density_integral};
