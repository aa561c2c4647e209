//! `--max-error`'s density level: the coarsest level of the density's mip pyramid (each
//! level the one before with its 2×2×2 blocks averaged, [`VoxelGrid::coarser`]) whose
//! image a pilot measures within a share of the error. The whole render then uses that
//! level — the shadow bake, the `fast` lattice and the camera march — so its cost falls
//! with the voxels: a level has an eighth of the voxels of the one before, and a ray
//! crosses half as many.
//!
//! The pilot renders [`LEVEL_PILOT_PIXELS`] pixel centres with single scattering and shadow
//! rays marched exactly (no map is baked yet), at one world step
//! ([`LEVEL_PILOT_STEP`] voxels of the full grid) and termination for every level, so the
//! difference between a level's pilot and the full grid's is the level's alone. Levels
//! are tried from the finest coarse one up; the first whose relative RMSE is over
//! [`level_share`] stops the search. The step, the termination and the map's tolerance
//! share what is left of the error (`MarchPlan::remaining_error`).
//!
//! Not tried where the density is not one voxel grid, where emission, temperature or
//! colour grids sit on its lattice (they would need their own levels), where a shadow
//! cache is read (it holds the full grid's maps), where the volume moves (velocity
//! grids), or where nothing scatters (the radiance
//! would not see the level, but alpha would).

use super::Scene;
use super::lights::{LightShadow, SceneLights};
use super::pilot::{PILOT_PIXELS, pixel_lattice, relative_rmse, render_pilot};
use super::plan::{MarchPlan, RenderPlan};
use crate::field::{Field, VoxelGrid};
use crate::integrate::single::SingleScattering;
use crate::integrate::{Illumination, MarchSettings, Volume};
use crate::shadow::ShadowQuadrature;
use serde::Serialize;
use std::time::Instant;

/// The coarsest level tried: 8 voxels of the full grid to one.
pub const MAX_DENSITY_LEVEL: u8 = 3;
/// The pilot's step, in voxels of the full grid (the same world step at every level).
pub const LEVEL_PILOT_STEP: f64 = 4.0;
/// Pixels the level's pilot renders: half the step pilot's (its full-grid render marches
/// a shadow ray per step, and it is rendered before the map is baked).
pub const LEVEL_PILOT_PIXELS: usize = PILOT_PIXELS / 2;
/// The pilot's termination: what lies behind T = 2 % changes the radiance by less.
const LEVEL_PILOT_TERMINATION: f64 = 0.02;

/// The part of `--max-error` a level's error may take: the other three sources then
/// share at least `√3/2` of it.
pub fn level_share(max_error: f64) -> f64 {
    max_error / 2.0
}

/// What the level's pilot chose (the stats' `density_level`).
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct DensityLevelReport {
    /// 0: the grid as read; k: 2ᵏ of its voxels to one along each axis.
    pub level: u8,
    /// The chosen level's voxel edge, world units.
    pub voxel_size: f64,
    /// The chosen level's measured relative error (0 at level 0).
    pub error: f64,
    /// Each level tried from 1 up, its measured error.
    pub tried: Vec<f64>,
    pub pilot_seconds: f64,
}

impl DensityLevelReport {
    pub fn note(&self) -> String {
        let tried: Vec<String> = self.tried.iter().map(|e| format!("{e:.2e}")).collect();
        format!(
            "--max-error: density level {} (voxel {:.4}; the pilot measured {} for levels 1..; {:.2} s)",
            self.level,
            self.voxel_size,
            if tried.is_empty() {
                "nothing".into()
            } else {
                tried.join(", ")
            },
            self.pilot_seconds
        )
    }
}

/// Why the scene's density has no coarser level to choose from, or `None`.
fn unsupported(scene: &Scene, plan: &RenderPlan) -> Option<&'static str> {
    let f = &scene.fields;
    if f.emission.is_some()
        || f.temperature.is_some()
        || f.color.is_some()
        || !f.emitters.is_empty()
    {
        Some("emission, temperature or colour grids")
    } else if scene.moves() {
        Some("something moves while the shutter is open")
    } else if plan.shadows.cache.is_some() {
        Some("a shadow cache")
    } else if !scene.scatters {
        Some("nothing scatters")
    } else if f.parts.is_some() || f.density.as_voxel_grid().is_none() {
        Some("the density is not one voxel grid")
    } else {
        None
    }
}

/// Chooses the density's level for `max_error` and puts it in the scene (its
/// `fields.density`), recording what was measured. Level 0 leaves the scene as it is.
/// Returns the plan to bake the map with where a level was taken: its tolerance the
/// map's share of what the level's error leaves.
pub fn apply(scene: &mut Scene, plan: &RenderPlan, max_error: f64) -> Option<RenderPlan> {
    if let Some(why) = unsupported(scene, plan) {
        scene.report.notes.push(format!(
            "--max-error: the density is marched at its own voxels ({why})"
        ));
        return None;
    }
    let grid = scene.fields.density.as_voxel_grid()?;
    let (chosen, report) = choose(scene, grid, level_share(max_error));
    scene.report.notes.push(report.note());
    let error = report.error;
    scene.density_level = Some(report);
    let g = chosen?;
    scene.fields.density = Box::new(g);
    let mut p = plan.clone();
    p.shadows.dsm_tolerance = MarchPlan::tolerance_of(MarchPlan::remaining_error(max_error, error));
    Some(p)
}

/// The pilot over the levels of `grid`: the chosen level (`None` for the grid itself) and
/// the report.
fn choose(scene: &Scene, grid: &VoxelGrid, share: f64) -> (Option<VoxelGrid>, DensityLevelReport) {
    let start = Instant::now();
    let pixels = pixel_lattice(scene.camera.width, scene.camera.height, LEVEL_PILOT_PIXELS);
    let names = scene.light_names();
    let render = |density: &dyn Field, level: u8| {
        let volume = Volume {
            phase: scene.phase.clone(),
            ..Volume::of(density, scene.medium)
        };
        let lights = SceneLights {
            lights: &scene.lights,
            density,
            shadows: vec![LightShadow::Marched; scene.lights.len()].into(),
            quadrature: ShadowQuadrature::Exact,
            enough: scene.plan_shadows.1,
        };
        let integrator = SingleScattering::new(
            &volume,
            false,
            Some((&lights as &dyn Illumination, names.clone())),
            scene.ground.map(|g| (g, &lights as &dyn Illumination)),
            MarchSettings {
                step_voxels: LEVEL_PILOT_STEP / f64::from(1u32 << level),
                termination: LEVEL_PILOT_TERMINATION,
            },
        );
        render_pilot(&integrator, &scene.camera, 0, &pixels)
    };
    let full = render(grid, 0);
    let mut report = DensityLevelReport {
        voxel_size: grid.smallest_voxel(),
        ..Default::default()
    };
    // The last level accepted (each made from the one before).
    let mut kept: Option<VoxelGrid> = None;
    for level in 1..=MAX_DENSITY_LEVEL {
        let from = kept.as_ref().unwrap_or(grid);
        let Some(coarse) = from.coarser() else { break };
        let e = relative_rmse(&render(&coarse, level), &full);
        report.tried.push(e);
        if !(e <= share) {
            break;
        }
        report.level = level;
        report.error = e;
        report.voxel_size = coarse.smallest_voxel();
        kept = Some(coarse);
    }
    report.pilot_seconds = start.elapsed().as_secs_f64();
    (kept, report)
}
