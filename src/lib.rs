//! murk — renders OpenVDB volume caches into multi-layer OpenEXR images.
//!
//! The pipeline flows one way through the modules:
//! [`vdb`] (file loading) → [`field`] (sampler trait, grids, procedural fields) →
//! [`accel`] (tree traversal, HDDA) → [`shadow`] (deep shadow maps and their cache) →
//! [`integrate`] (integrators, passes, phase functions, the volume integral) → [`scene`]
//! (what is rendered: input, fields in their roles, camera, lights) → [`render`] (the
//! pixel loop) → [`output`] (EXR, previews, stats);
//! [`report`] measures error and stability.
//!
//! A module imports only the modules before it in that order, with two exceptions:
//! [`output`] is imported by [`scene`] (the outputs' options) and [`render`] (which
//! writes) and imports no stage itself; [`files`] (atomic writes) and [`mem`] sit below
//! every stage. `tests/architecture.rs` checks this, and that no two files import each
//! other, from the `use` lines.

// `!(x > 0.0)` is how this crate says "not a positive number, or NaN": the negated
// comparisons are deliberate, so that NaN inputs take the rejecting branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accel;
pub mod field;
pub mod files;
pub mod integrate;
pub mod mem;
pub mod output;
pub mod render;
pub mod report;
pub mod scene;
pub mod shadow;
pub mod vdb;
pub mod vtk;
