//! The volume integral: stable per-segment optics, phase functions, blackbody emission
//! and the ray march that puts them together.

pub mod blackbody;
pub mod march;
pub mod medium;
pub mod optics;
pub mod phase;

pub use march::{Illumination, MarchSettings, RayResult, Scratch, Volume, WorldRay, march};
pub use medium::{ColorTint, Companion, Emission, Medium};
