//! Which device renders a frame under `--device`, and a frame's march on the GPU.

use super::{Extent, RenderError, Result, channels, gpu, pixels, render_frame};
use crate::integrate::Integrator;
use crate::integrate::ms_lattice::MsLattice;
use crate::integrate::path::PathTracer;
use crate::integrate::single::SingleScattering;
use crate::output::{DeepImage, Frame};
use crate::render::stats::{RenderStats, Stage};
use crate::scene::plan::Device;
use crate::scene::progress::Progress;
use crate::scene::report::SceneReport;
use crate::scene::reuse::FrameReuse;
use crate::scene::{RenderPlan, Scene};
use std::sync::Arc;
use std::time::Instant;

/// Builds the scene, its shadow bake's light columns marched on the GPU where the render
/// may run there (`--device gpu|auto`, no deep output) and a GPU opens;
/// the GPU's marcher is returned for its times.
pub(super) fn build_scene(
    plan: &RenderPlan,
    progress: &dyn Progress,
    reuse: &mut FrameReuse,
) -> Result<(Scene, Option<Arc<gpu::GpuColumns>>)> {
    let may = plan.outputs.deep.is_none();
    let columns = may
        .then(|| gpu_for(plan.sampling.device, None))
        .and_then(|g| g.ok())
        .map(|g| Arc::new(gpu::GpuColumns::new(g)));
    reuse.columns = columns
        .clone()
        .map(|c| c as Arc<dyn crate::shadow::ColumnMarcher>);
    let scene = Scene::build_reusing(plan, progress, reuse);
    reuse.columns = None;
    Ok((scene?, columns))
}

/// The GPU's stages before the render in the stats: `gpu_open` (finding the adapter
/// and opening the device, in the render that did), `gpu_bake_upload` (the grid's
/// layout and upload for the columns), `gpu_bake` (the columns' batches: layout,
/// upload, march and readback) and of it `gpu_bake_kernel` (the GPU's own time marching
/// them, where the adapter times its passes), and a note where the GPU stopped marching
/// them.
pub(super) fn report_bake(columns: Option<&gpu::GpuColumns>, report: &mut SceneReport) {
    let Some(c) = columns else { return };
    report_open(c.gpu(), report);
    let times = c.times();
    if times.marched > 0 || times.upload > 0.0 {
        report
            .stages
            .insert("gpu_bake_upload".into(), Stage::ran(times.upload));
        report
            .stages
            .insert("gpu_bake".into(), Stage::ran(times.columns));
        if let Some(busy) = times.kernel {
            report
                .stages
                .insert("gpu_bake_kernel".into(), Stage::ran(busy));
        }
    }
    if let Some(why) = c.failure() {
        report.notes.push(format!(
            "the shadow bake's light columns were marched on the CPU: {why}"
        ));
    }
}

/// `gpu_open` in the stats, where this render opened `gpu` (finding the adapter and
/// opening the device).
fn report_open(gpu: &gpu::Gpu, report: &mut SceneReport) {
    if let Some(seconds) = gpu.take_open_seconds() {
        report.stages.insert("gpu_open".into(), Stage::ran(seconds));
    }
}

/// The lattice's sweeps on the GPU in the stats: `gpu_lattice` (uploads, sweeps,
/// averages and readbacks, inside `multiple_scattering`) and of it
/// `gpu_lattice_kernel` (the GPU's own time sweeping and averaging, where the adapter
/// times its passes), and a note where the GPU
/// stopped sweeping.
pub(super) fn report_sweeps(sweeper: Option<&gpu::GpuSweeper>, report: &mut SceneReport) {
    let Some(s) = sweeper else { return };
    let times = s.times();
    if times.orders > 0 {
        report
            .stages
            .insert("gpu_lattice".into(), Stage::ran(times.seconds));
        if let Some(busy) = times.kernel {
            report
                .stages
                .insert("gpu_lattice_kernel".into(), Stage::ran(busy));
        }
    }
    if let Some(why) = s.failure() {
        report.notes.push(format!(
            "the multiple-scattering lattice was swept on the CPU: {why}"
        ));
    }
}

/// The GPU `device` asks for: under `gpu` any adapter; under `auto` one that is not
/// itself run on the CPU (lavapipe, SwiftShader, WARP), which renders slower than murk's
/// own CPU path, unless `WGPU_ADAPTER_NAME` names it; none under `cpu`. Why not, where
/// there is none. An adapter opened and not taken has its `gpu_open` in `report` (where
/// given) all the same: the render waited for it.
fn gpu_for(
    device: Device,
    report: Option<&mut SceneReport>,
) -> std::result::Result<&'static gpu::Gpu, String> {
    match device {
        Device::Cpu => Err("--device cpu".into()),
        Device::Gpu => gpu::Gpu::shared(),
        Device::Auto => gpu::Gpu::shared().and_then(|g| {
            if g.on_cpu && !g.named {
                if let Some(r) = report {
                    report_open(g, r);
                }
                Err(format!(
                    "the only adapter, {}, runs on the CPU, slower than murk's own CPU path (--device gpu or WGPU_ADAPTER_NAME uses it)",
                    g.name
                ))
            } else {
                Ok(g)
            }
        }),
    }
}

/// The GPU a render runs on under `--device gpu|auto`, or none (the CPU); and under
/// `auto`, a note saying why the CPU renders. Under `gpu` a scene the GPU backend does not
/// render, or no GPU, is an error naming what is missing.
pub(super) fn choose_device(
    plan: &RenderPlan,
    scene: &Scene,
    report: &mut SceneReport,
) -> Result<(Option<&'static gpu::Gpu>, Option<String>)> {
    let device = plan.sampling.device;
    if device == Device::Cpu {
        return Ok((None, None));
    }
    let opened = match gpu::unsupported(plan, scene) {
        Some(feature) => Err(format!("the GPU backend does not render {feature} yet")),
        None if plan.outputs.deep.is_some() => {
            Err("the GPU backend does not write deep samples (--deep) yet".into())
        }
        None => gpu_for(device, Some(report)),
    };
    match opened {
        Ok(g) => Ok((Some(g), None)),
        Err(why) if device == Device::Gpu => {
            Err(RenderError::Device(format!("--device gpu: {why}")))
        }
        Err(why) => Ok((
            None,
            Some(format!("--device auto rendered on the CPU: {why}")),
        )),
    }
}

/// A frame's integrator on each device: on the GPU its single-scattering march, with
/// the fast mode's lattice to gather in it, or the path tracer's paths; on the CPU the
/// integrator itself.
pub(super) struct Frontends<'a, I> {
    pub gpu: OnGpu<'a>,
    pub cpu: &'a I,
}

/// What the GPU renders of a frame.
pub(super) enum OnGpu<'a> {
    /// The single-scattering march, with the fast mode's lattice gathered in it.
    March(&'a SingleScattering<'a>, Option<&'a MsLattice>),
    /// The path tracer's paths, with the phase function's asymmetry.
    Path(&'a PathTracer<'a>, f64),
}

/// Renders the frame on the GPU `device.0` when there is one (with the scene's buffers
/// a sequence keeps there, `device.2`), else on the CPU; where the GPU fails under
/// `--device auto`, on the CPU, with `device.1` the note saying why (and `device.0` none).
pub(super) fn render_on<I: Integrator>(
    device: (
        &mut Option<&'static gpu::Gpu>,
        &mut Option<String>,
        Option<&mut gpu::KeptBuffers>,
    ),
    on: Frontends<'_, I>,
    scene: &Scene,
    plan: &RenderPlan,
    extent: &Extent,
    progress: &dyn Progress,
    st: &mut RenderStats,
) -> Result<(Frame, f64, Option<DeepImage>)> {
    let (gpu, note, kept) = device;
    let on_gpu = match gpu {
        Some(g) => {
            let rows = extent.rows.clone();
            render_frame_gpu((g, kept), on.gpu, scene, plan, rows, extent.holdout, st)?
        }
        None => Err(String::new()),
    };
    match on_gpu {
        Ok((frame, seconds)) => Ok((frame, seconds, None)),
        Err(why) => {
            if gpu.take().is_some() {
                // Under auto only: `gpu` turned the failure into an error.
                *note = Some(format!("--device auto rendered on the CPU: {why}"));
            }
            render_frame(on.cpu, scene, plan, extent, progress, st)
        }
    }
}

/// [`render_frame`] with the march on `gpu.0` (the scene's buffers kept there from a
/// sequence's frame before where `gpu.1` holds them): the stages `gpu_upload` and
/// `render` (rays, march and readback) go in the stats. What failed on the GPU (a grid
/// over its buffer limit, say) is an error under `--device gpu`, and the inner `Err`
/// (the CPU renders instead) under `auto`.
fn render_frame_gpu(
    (gpu, kept): (&gpu::Gpu, Option<&mut gpu::KeptBuffers>),
    work: OnGpu,
    scene: &Scene,
    plan: &RenderPlan,
    rows: std::ops::Range<usize>,
    holdout: Option<&[f32]>,
    st: &mut RenderStats,
) -> Result<std::result::Result<(Frame, f64), String>> {
    let t = Instant::now();
    let rendered = match work {
        OnGpu::March(single, lattice) => {
            let job = gpu_job(single, scene, plan, rows, holdout);
            gpu::render_pixels(gpu, scene, lattice, &job, kept)
        }
        OnGpu::Path(path, g) => {
            let job = gpu_job(path, scene, plan, rows, holdout);
            gpu::render_path(gpu, scene, g, &job, kept)
        }
    };
    let (passes, times) = match rendered {
        Ok(done) => done,
        Err(why) if plan.sampling.device == Device::Auto => return Ok(Err(why)),
        Err(why) => return Err(RenderError::Device(format!("--device gpu: {why}"))),
    };
    // The pipeline's compile is its own stage, not the render's.
    let render_seconds = (t.elapsed().as_secs_f64() - times.compile).max(0.0);
    st.scene
        .stages
        .insert("gpu_upload".into(), Stage::ran(times.upload));
    for (name, seconds) in [
        ("gpu_compile", times.compile),
        ("gpu_layout", times.layout),
        ("gpu_rays", times.rays),
        ("gpu_march", times.kernel),
        ("gpu_record", times.record),
    ] {
        st.scene.stages.insert(name.into(), Stage::ran(seconds));
    }
    if let Some(busy) = times.busy {
        st.scene
            .stages
            .insert("gpu_march_kernel".into(), Stage::ran(busy));
    }
    if let Some(wait) = times.wait {
        st.scene
            .stages
            .insert("gpu_march_wait".into(), Stage::ran(wait));
    }
    st.scene.gpu_memory_bytes = times.resident_bytes;
    st.scene.gpu_upload_bytes = times.uploaded_bytes;
    st.scene.gpu_stream_bytes = times.stream_bytes;
    st.scene.gpu_grid_parts = times.grid_parts;
    st.rays = passes.rays;
    st.samples = passes.samples;
    st.samples_per_second = passes.samples as f64 / times.march.max(1e-9);
    Ok(Ok((channels::assemble(&passes)?, render_seconds)))
}

/// The GPU's pixel job: the frame's rows, still (the GPU renders no shutter), no deep output.
fn gpu_job<'a, I: Integrator>(
    integrator: &'a I,
    scene: &'a Scene,
    plan: &RenderPlan,
    rows: std::ops::Range<usize>,
    holdout: Option<&'a [f32]>,
) -> pixels::PixelJob<'a, I> {
    pixels::PixelJob {
        integrator,
        camera: &scene.camera,
        spp: plan.sampling.spp,
        seed: plan.sampling.seed,
        rows,
        antialias: plan.sampling.antialias,
        deep: None,
        deep_aovs: &[],
        holdout,
        shutter: None,
        camera_motion: None,
        centred: false,
        overscan: plan.camera.overscan,
    }
}
