//! The deep shadow map against closed forms, against marched shadows, and through its
//! cache.
//!
//! Notation: σ the extinction per unit density, ρ the density, μ = cos θ of the sun's
//! angle to the slab normal, h a thickness.

#[path = "../common/mod.rs"]
mod common;
use common::tools;

use glam::DVec3;
use murk::field::shapes::ConstantBox;
use murk::field::{Field, VoxelGrid};
use murk::render::{RenderOptions, RenderPlan, render_image};
use murk::scene::light::Light;
use murk::shadow::ShadowMapStats;
use murk::shadow::cache as shadow_cache;
use murk::shadow::map::MAX_LEVEL;
use murk::shadow::{BakeSettings, LightGeometry, bake};
use murk::vdb::VdbFile;
use std::path::PathBuf;

const SIGMA: f64 = 2.1;
const TOL: f64 = 1e-3;

fn fixture_path(name: &str) -> PathBuf {
    PathBuf::from(format!("{}/fixtures/{name}", env!("CARGO_MANIFEST_DIR")))
}

fn fixture(name: &str) -> VoxelGrid {
    VoxelGrid::load(&VdbFile::open(fixture_path(name)).unwrap(), "density").unwrap()
}

fn settings() -> BakeSettings {
    BakeSettings::new(TOL, DVec3::splat(SIGMA))
}

mod against_march;
mod budget;
mod cache;
mod closed_forms;
