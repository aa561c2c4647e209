//! murk — renders OpenVDB volume caches into multi-layer OpenEXR images.
//!
//! The pipeline flows one way through the modules:
//! [`vdb`] (file loading) → [`field`] (sampler trait, grids, procedural fields) →
//! [`accel`] (tree traversal, HDDA) → [`shadow`] → [`integrate`] (the volume integral) →
//! [`render`] (camera, lights, scene, tiles) → [`output`] (EXR, previews, stats);
//! [`report`] measures error and stability.

pub mod accel;
pub mod field;
pub mod integrate;
pub mod output;
pub mod render;
pub mod report;
pub mod shadow;
pub mod vdb;
