//! Helpers for the tests that march single rays against closed forms
//! (`closed_forms.rs`, `accuracy.rs`).

use glam::DVec3;
use murk::field::{Field, VoxelGrid};
use murk::integrate::{
    Illumination, MarchSettings, Medium, RayResult, Scratch, Volume, WorldRay, march,
};
use murk::shadow::{ShadowQuadrature, density_integral};
use murk::vdb::VdbFile;

pub fn fixture(name: &str) -> VoxelGrid {
    let path = format!("{}/fixtures/{name}", env!("CARGO_MANIFEST_DIR"));
    VoxelGrid::load(&VdbFile::open(path).unwrap(), "density").unwrap()
}

pub fn grey(v: f64) -> DVec3 {
    DVec3::splat(v)
}

pub fn medium(sigma_a: f64, sigma_s: f64, g: f64) -> Medium {
    Medium {
        sigma_a: grey(sigma_a),
        sigma_s: grey(sigma_s),
        density_scale: 1.0,
        g,
    }
}

/// A sun with shadows integrated by the shadow module (exactly, for these fields).
pub struct Sun<'a> {
    pub field: &'a dyn Field,
    /// Unit direction from a point toward the sun.
    pub toward: DVec3,
    pub irradiance: f64,
}

impl Illumination for Sun<'_> {
    fn light_count(&self) -> usize {
        1
    }
    fn incident(&self, _: usize, _: DVec3) -> (DVec3, DVec3) {
        (grey(self.irradiance), -self.toward)
    }
    fn density_to_light(&self, _: usize, x: DVec3) -> f64 {
        density_integral(
            self.field,
            x,
            self.toward,
            f64::INFINITY,
            ShadowQuadrature::Exact,
            1e30,
        )
    }
}

/// One ray at `step` voxels, never terminated.
pub fn ray(
    vol: &Volume,
    sun: Option<&Sun>,
    o: DVec3,
    d: DVec3,
    step: f64,
    jitter: f64,
) -> RayResult {
    let settings = MarchSettings {
        step_voxels: step,
        termination: 0.0,
    };
    ray_with(vol, sun, o, d, &settings, jitter)
}

/// One ray with the given march settings.
pub fn ray_with(
    vol: &Volume,
    sun: Option<&Sun>,
    o: DVec3,
    d: DVec3,
    settings: &MarchSettings,
    jitter: f64,
) -> RayResult {
    let mut scratch = Scratch::new(1);
    march(
        vol,
        sun.map(|s| s as &dyn Illumination),
        &WorldRay::new(o, d),
        settings,
        jitter,
        &mut scratch,
    )
}

pub fn rel(got: f64, want: f64) -> f64 {
    (got - want).abs() / want.abs().max(1e-300)
}
