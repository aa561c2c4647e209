//! The GPU backend (`--device gpu|auto`): single scattering marched on a GPU through
//! wgpu (Vulkan, Metal, DX12) by WGSL compute shaders — the density grid's nodes and the
//! lights' deep shadow maps uploaded as storage buffers, one invocation per camera
//! sample — beside the CPU's pixel loop, with the same samples, rays and passes. Under
//! `--scattering fast` the multiple-scattering lattice, solved on the CPU, is uploaded
//! too and gathered in the same march, per segment, as the CPU's march does. Emission,
//! temperature and colour grids are packed after the density's nodes (grids.rs) and
//! sampled as the CPU samples them (emission.wgsl). Shadows are the maps' lookups or
//! shadow rays marched through the grid (`--shadows march`); the ground plane's light,
//! where a camera ray meets it, is found in the same kernel.
//!
//! Under `--scattering path` the path tracer's paths are traced on the GPU (path.rs,
//! path.wgsl) over the same uploaded grid and maps and the path tracer's majorants.
//!
//! What it renders is checked first ([`unsupported`]): a scene with anything else runs on
//! the CPU under `--device auto` (with a note naming it) and is refused under `gpu`.

mod bake;
mod bind;
mod busy;
mod context;
mod grid_parts;
mod grid_probe;
mod grids;
mod path;
mod picks;
mod pixels;
mod readback;
mod resident;
mod stream;
mod sweep;
mod upload;

pub use bake::{BakeTimes, GpuColumns};
pub use context::{CUT_ANYWAY_VAR, Gpu, MAX_BINDING_VAR};
pub use grid_parts::GridBinding;
pub use grid_probe::read_back;
pub use path::render_path;
pub use resident::KeptBuffers;
pub use sweep::{GpuSweeper, SweepTimes, sweeps_lattice};

use super::pixels::{PixelJob, PixelPasses};
use crate::field::grid_nodes::FlatGridError;
use crate::integrate::ms_lattice::MsLattice;
use crate::integrate::single::SingleScattering;
use crate::integrate::{MarchSettings, Volume};
use crate::scene::Scene;
use crate::scene::lights::SceneLights;
use crate::scene::plan::RenderPlan;
use std::time::Instant;

/// The first feature of the render that the GPU backend does not run, or `None` when
/// it runs all of them.
pub fn unsupported(plan: &RenderPlan, scene: &Scene) -> Option<String> {
    let Some(grid) = scene.fields.density.as_voxel_grid() else {
        return Some(if plan.volumes.is_some() {
            "several volumes ([[volume]] tables)".into()
        } else {
            "a density that is not a voxel grid (a mesh or a procedural field)".into()
        });
    };
    if let Err(e) = grid.nodes_check() {
        return Some(match e {
            FlatGridError::Channels => "a density grid of more than one channel".into(),
            FlatGridError::SparseRoot => "a density grid whose nodes lie far apart".into(),
        });
    }
    let traversal = scene.traversal();
    let volume = scene.volume(&traversal);
    if let Some(why) = grids::unsupported(&grids::Beside::of(&volume)) {
        return Some(why);
    }
    if scene.motion.is_some() {
        return Some("motion blur from a velocity grid (--shutter)".into());
    }
    if scene.fields.keyed.is_some() {
        return Some("volumes whose keyed placements move while the shutter is open".into());
    }
    if scene.camera_motion.is_some() {
        return Some("a camera moving while the shutter is open (--shutter)".into());
    }
    if scene.lights.len() > upload::MAX_LIGHTS {
        return Some(format!("more than {} lights", upload::MAX_LIGHTS));
    }
    None
}

/// What the march and the path tracer upload alike of `scene` (its lights `lights`,
/// its volume `volume`): the density's grid and nodes, the medium, the phase function,
/// the lights with their shadows, the grids beside the density and the bounds of the
/// cells a camera ray visits; the rest as a march without the fast mode's lattice or a
/// ground takes it, for the caller to set.
fn scene_parts<'a>(
    scene: &'a Scene,
    lights: &'a SceneLights,
    volume: &'a Volume<'a>,
) -> Result<upload::SceneParts<'a>, String> {
    let grid = scene
        .fields
        .density
        .as_voxel_grid()
        .ok_or("a density that is not a voxel grid")?;
    let nodes = grid
        .nodes()
        .map_err(|_| "a density grid it cannot flatten")?;
    Ok(upload::SceneParts {
        grid,
        nodes,
        medium: scene.medium,
        phase: scene.phase.as_ref(),
        lights: &scene.lights,
        shadows: &lights.shadows,
        settings: MarchSettings::default(),
        scatters: scene.scatters && scene.medium.scatters(),
        lattice: None,
        ground: false,
        quadrature: lights.quadrature,
        enough: lights.enough,
        beside: grids::Beside::of(volume),
        bounds: crate::field::Field::active_bounds(volume.traversal),
    })
}

/// Seconds the GPU's stages took.
#[derive(Clone, Copy, Debug, Default)]
pub struct GpuTimes {
    /// Compiling the render's pipeline (the march's for the scene's parts, or the path
    /// tracer's) where this render was the first to need it: in no other stage.
    pub compile: f64,
    /// Flattening the grid and the maps, and uploading them.
    pub upload: f64,
    /// Generating the rays, marching them and reading the results back.
    pub march: f64,
    /// Of `upload`: laying the grid's nodes and the maps out as flat arrays.
    pub layout: f64,
    /// Of `march`: placing the samples on the CPU (each one's pixel and index, the GPU
    /// making its ray). The samples
    /// stream through the GPU in chunks (stream.rs), and the GPU's work on one chunk
    /// overlaps this stage's and `record`'s on its neighbours.
    pub rays: f64,
    /// Of `march`: the CPU's part in the GPU's work: writing the samples into the
    /// staging buffers, submitting the chunks and waiting for their results.
    pub kernel: f64,
    /// Of `march`: adding each sample's results into its pixel's passes on the CPU.
    pub record: f64,
    /// The GPU's own time in the march's passes, where the adapter times its passes:
    /// within `rays` + `kernel` + `record`, as the passes overlap the first and the
    /// last.
    pub busy: Option<f64>,
    /// Of `kernel`: the CPU waiting for each chunk's results, the GPU's work (its passes,
    /// `busy`, with the copies of samples and results between host and GPU) that the
    /// CPU's work on the chunks around it did not hide.
    pub wait: Option<f64>,
    /// Bytes of the scene's buffers on the GPU (not the samples and results streamed).
    pub resident_bytes: usize,
    /// Of them, the bytes this frame uploaded: all of them, but in a sequence only those
    /// that differ from the frame before's (see [`KeptBuffers`]).
    pub uploaded_bytes: u64,
    /// Bytes of the buffers on the GPU the samples stream through (stream.rs: the inputs
    /// and results of the chunks in flight), the most any of the render's streams held.
    pub stream_bytes: u64,
    /// The buffers the grids' node tables and their values went in: 1 each while they
    /// fit the adapter's largest binding, else up to 4 parts each.
    pub grid_parts: [usize; 2],
}

/// Renders the job's pixels on `gpu` (the scene passed [`unsupported`]), with the fast
/// mode's multiple scattering from `lattice` where given (its lights the scene's); the
/// scene's buffers kept from a sequence's frame before where `kept` holds them.
pub fn render_pixels(
    gpu: &Gpu,
    scene: &Scene,
    lattice: Option<&MsLattice>,
    job: &PixelJob<SingleScattering>,
    kept: Option<&mut KeptBuffers>,
) -> Result<(PixelPasses, GpuTimes), String> {
    let t = Instant::now();
    let lights = scene.illumination();
    let traversal = scene.traversal();
    let volume = scene.volume(&traversal);
    let mut buffers = upload::build(&upload::SceneParts {
        settings: job.integrator.settings(),
        lattice,
        ground: job.integrator.ground().is_some(),
        ..scene_parts(scene, &lights, &volume)?
    })?;
    let layout = t.elapsed().as_secs_f64();
    let resident_bytes = buffers.resident_bytes();
    buffers.split_maps(gpu.max_binding());
    let (resident, uploaded_bytes) = gpu.upload(&buffers, kept)?;
    drop(buffers);
    let upload = t.elapsed().as_secs_f64();
    // The march compiled for the scene's parts before the march is timed (on first
    // use; else found): the stats' `gpu_compile`.
    let t = Instant::now();
    gpu.march_pipeline(resident.features)?;
    let compile = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut times = GpuTimes {
        compile,
        upload,
        layout,
        resident_bytes,
        uploaded_bytes,
        grid_parts: resident.grid_parts(),
        ..GpuTimes::default()
    };
    let passes = pixels::render_pixels(gpu, &resident, job, &mut times)?;
    times.march = t.elapsed().as_secs_f64();
    times.busy = resident.busy.seconds();
    times.wait = resident.waited.seconds();
    Ok((passes, times))
}
