//! Rendering: the tiled pixel loop driven by an integrator and its passes, the channels
//! assembled from the passes, and [`run`], a whole render: build the scene → render →
//! write, timing every stage.

mod bake_file;
pub mod channels;
mod device;
mod error;
pub mod error_budget;
pub mod gpu;
pub mod piece;
pub mod pixels;
mod prepare;
pub mod sequence;
pub mod stats;

pub use crate::scene::progress::{Progress, Silent};
pub use crate::scene::{RenderOptions, RenderPlan};

use crate::files::write_atomically;
use crate::integrate::fast::{FastScattering, WithMultiple};
use crate::integrate::ms_lattice::MsLattice;
use crate::integrate::ms_sweep::Sweeper;
use crate::integrate::path::{LightTransmittance, PathSettings, PathTracer};
use crate::integrate::single::SingleScattering;
use crate::integrate::{Illumination, Integrator, ScatteringMode};
use crate::output::{DeepExrOptions, DeepImage, Frame, write_deep_exr, write_exr, write_preview};
use crate::scene::Scene;
use crate::scene::plan::ShadowMode;
use crate::scene::reuse::FrameReuse;
pub use bake_file::bake_shadow_file;
use device::{Frontends, OnGpu, choose_device, render_on, report_bake, report_sweeps};
pub use error::RenderError;
use piece::Piece;
use prepare::{PreparedFrame, prepare_frame};
use stats::{RenderStats, Stage};
use std::path::{Path, PathBuf};
use std::time::Instant;

type Result<T> = std::result::Result<T, RenderError>;

/// A rendered image, not yet written: its channels, the EXR header it will carry, and
/// the stats so far (everything but the write stage).
pub struct RenderedImage {
    pub frame: Frame,
    pub exr: crate::output::ExrOptions,
    pub stats: RenderStats,
    /// With `--deep`: the deep image.
    pub deep: Option<DeepImage>,
}

/// Which frame of a sequence a render is, and which piece of it (none: a whole image).
#[derive(Clone, Copy, Debug, Default)]
pub struct FrameJob {
    pub frame: Option<i64>,
    pub piece: Option<Piece>,
}

/// Renders a plan and writes its outputs. Returns the stats (also written with --stats).
pub fn run(plan: &RenderPlan, progress: &dyn Progress) -> Result<RenderStats> {
    run_frame(
        plan,
        progress,
        &mut FrameReuse::default(),
        FrameJob::default(),
    )
}

/// Runs `work` on the plan's threads (`--threads`; all cores when not given): every
/// stage in it — load, shadow bake, lattice, pixel loop, write — then keeps to them.
fn on_plan_threads<T: Send>(
    plan: &RenderPlan,
    work: impl FnOnce() -> Result<T> + Send,
) -> Result<T> {
    match plan.sampling.threads {
        None => work(),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()?
            .install(work),
    }
}

/// [`run`] for one frame (or piece of one) of a sequence, reusing what `reuse` kept.
pub fn run_frame(
    plan: &RenderPlan,
    progress: &dyn Progress,
    reuse: &mut FrameReuse,
    job: FrameJob,
) -> Result<RenderStats> {
    on_plan_threads(plan, || {
        check_output_dirs(plan)?;
        let prepared = prepare_frame(plan, progress, reuse, job)?;
        render_prepared(plan, prepared, progress, None, job)
    })
}

/// Renders a prepared frame of `plan` and writes its outputs (the scene's buffers kept
/// on the GPU from a sequence's frame before where `kept` holds them). Returns the stats.
fn render_prepared(
    plan: &RenderPlan,
    prepared: PreparedFrame,
    progress: &dyn Progress,
    kept: Option<&mut gpu::KeptBuffers>,
    job: FrameJob,
) -> Result<RenderStats> {
    let start = prepared.started();
    check_output_dirs(plan)?;
    let RenderedImage {
        frame,
        mut exr,
        stats: mut st,
        deep,
    } = render_image_prepared(plan, prepared, progress, kept, job)?;
    let t = Instant::now();
    exr.render_time_seconds = Some(start.elapsed().as_secs_f64());
    st.scene
        .notes
        .extend(crate::output::half_overflow_notes(&frame, &exr));
    // Every output or none: if a later one fails, the earlier ones of this run go.
    let mut written: Vec<&Path> = Vec::new();
    let result = (|| -> Result<()> {
        write_exr(&plan.outputs.path, &frame, &exr)?;
        written.push(&plan.outputs.path);
        if let (Some(d), Some(image)) = (&plan.outputs.deep, &deep) {
            let mut opts = deep_options(&exr, d.tolerance);
            opts.targets = crate::output::deep::flat_targets(&frame, &exr);
            let summary = write_deep_exr(&d.path, image, &opts)?;
            written.push(&d.path);
            st.scene.notes.push(deep_note(image, summary));
        }
        if let Some((path, opts)) = &plan.outputs.preview {
            write_preview(path, &frame, opts)?;
            written.push(path);
        }
        st.scene
            .stages
            .insert("write".into(), Stage::ran(t.elapsed().as_secs_f64()));
        st.total_seconds = start.elapsed().as_secs_f64();
        if let Some(path) = &plan.outputs.stats {
            write_stats(path, &st)?;
        }
        Ok(())
    })();
    if let Err(e) = result {
        for p in written {
            let _ = std::fs::remove_file(p);
        }
        return Err(e);
    }
    Ok(st)
}

/// Lattice nodes the fast approximation may spend per image pixel (16: the default
/// 64,000 from 80×45 up; the calibration images of scripts/calibrate_fast.py, 80×45 and
/// 160×90, are at or near the default), and the fewest it uses.
const FAST_NODES_PER_PIXEL: usize = 16;
const FAST_MIN_NODES: usize = 4_096;
/// `--scattering path` computes `A` and `Z` (the camera ray's exact opacity) on this
/// many of a pixel's samples: the exact walk cost more than the rest of a sample on the
/// demo cloud, and the opacity needs no more rays than `single` anti-aliases it with.
const PATH_OPACITY_SAMPLES: u32 = 16;

/// Renders a plan into memory: build the scene → render. Nothing is written.
pub fn render_image(plan: &RenderPlan) -> Result<RenderedImage> {
    render_image_with(plan, &Silent)
}

/// [`render_image`], reporting progress.
pub fn render_image_with(plan: &RenderPlan, progress: &dyn Progress) -> Result<RenderedImage> {
    render_image_frame(
        plan,
        progress,
        &mut FrameReuse::default(),
        FrameJob::default(),
    )
}

/// [`render_image_with`] for one frame or piece of a sequence, reusing what `reuse` kept.
pub fn render_image_frame(
    plan: &RenderPlan,
    progress: &dyn Progress,
    reuse: &mut FrameReuse,
    job: FrameJob,
) -> Result<RenderedImage> {
    on_plan_threads(plan, || render_image_frame_here(plan, progress, reuse, job))
}

fn render_image_frame_here(
    plan: &RenderPlan,
    progress: &dyn Progress,
    reuse: &mut FrameReuse,
    job: FrameJob,
) -> Result<RenderedImage> {
    let prepared = prepare_frame(plan, progress, reuse, job)?;
    render_image_prepared(plan, prepared, progress, None, job)
}

/// [`render_image_frame`] of a prepared frame.
fn render_image_prepared(
    plan: &RenderPlan,
    prepared: PreparedFrame,
    progress: &dyn Progress,
    kept: Option<&mut gpu::KeptBuffers>,
    job: FrameJob,
) -> Result<RenderedImage> {
    let start = prepared.started();
    let PreparedFrame {
        scene,
        columns,
        holdout,
        rows,
        ..
    } = prepared;
    let deep = plan.outputs.deep.as_ref().map(|d| d.tolerance);
    let extent = Extent {
        rows: rows.clone(),
        deep,
        deep_aovs: plan
            .outputs
            .deep
            .as_ref()
            .map_or(&[], |d| d.aovs.as_slice()),
        holdout: holdout.as_ref().map(|h| h.depths.as_slice()),
    };
    let traversal = scene.traversal();
    let volume = scene.volume(&traversal);
    let lights = scene.illumination();
    let lights_named = scene
        .scatters
        .then(|| (&lights as &dyn Illumination, scene.light_names()));
    let mut st = RenderStats {
        murk_version: env!("CARGO_PKG_VERSION").into(),
        input: plan.input.display().to_string(),
        output: plan.outputs.path.display().to_string(),
        width: plan.camera.width,
        height: plan.camera.height,
        spp: plan.sampling.spp,
        ..Default::default()
    };
    // Seconds the fast mode's lattice took (a stage of its own in the stats).
    let mut multiple_seconds = None;
    // The fast mode's lattice swept on the GPU (for its times).
    let mut sweeps = None;
    let (mut gpu, mut device_note) = choose_device(plan, &scene, &mut st.scene)?;
    // The integrator of the plan's scattering mode.
    let (frame, render_seconds, deep_image) = match plan.transport.mode {
        ScatteringMode::Single => {
            let make = |march| {
                SingleScattering::new(
                    &volume,
                    scene.emits,
                    lights_named.clone(),
                    scene.ground.map(|g| (g, &lights as &dyn Illumination)),
                    march,
                )
            };
            let integrator = make(error_budget::march_settings(plan, &scene, &mut st, make))
                .with_deep(deep.is_some())
                .with_deep_aovs(!extent.deep_aovs.is_empty());
            let on = Frontends {
                gpu: OnGpu::March(&integrator, None),
                cpu: &integrator,
            };
            render_on(
                (&mut gpu, &mut device_note, kept),
                on,
                &scene,
                plan,
                &extent,
                progress,
                &mut st,
            )?
        }
        ScatteringMode::Path => {
            let names = scene.lights.iter().map(|l| l.name.clone()).collect();
            let integrator = PathTracer::new(
                &volume,
                scene.emits,
                scene
                    .scatters
                    .then_some((&lights as &dyn Illumination, names)),
                scene
                    .environment
                    .as_ref()
                    .map(|e| (e.radiance, e.name.clone())),
                PathSettings {
                    bounces: plan.transport.path_bounces(),
                    transmittance: match plan.shadows.mode {
                        ShadowMode::March => LightTransmittance::RatioTracking,
                        ShadowMode::Dsm | ShadowMode::None => LightTransmittance::Lookup,
                    },
                },
            )
            .with_opacity_samples(PATH_OPACITY_SAMPLES, plan.sampling.spp);
            let on = Frontends {
                gpu: OnGpu::Path(&integrator, plan.medium.g),
                cpu: &integrator,
            };
            render_on(
                (&mut gpu, &mut device_note, kept),
                on,
                &scene,
                plan,
                &Extent {
                    deep: None,
                    ..extent.clone()
                },
                progress,
                &mut st,
            )?
        }
        ScatteringMode::Fast => {
            // Multiple scattering: the lattice of every light, solved before the pixels.
            let t = Instant::now();
            let mut fast = plan.transport.fast_settings();
            // No more nodes than the image can show: a small image needs no fine lattice.
            fast.lattice_nodes = fast
                .lattice_nodes
                .min(FAST_NODES_PER_PIXEL * plan.camera.width * plan.camera.height)
                .max(FAST_MIN_NODES);
            // Its sweeps on the GPU the frame renders on, where that is faster.
            let sweeper = gpu
                .filter(|g| gpu::sweeps_lattice(g, plan))
                .map(gpu::GpuSweeper::new);
            let lattice = lights_named.map(|(l, _)| {
                let sweeper = sweeper.as_ref().map(|s| s as &dyn Sweeper);
                MsLattice::build_with(&volume, l, &fast.lattice(), sweeper)
            });
            multiple_seconds = Some(t.elapsed().as_secs_f64());
            st.multiple_scattering = lattice.as_ref().map(|l| l.report.clone());
            sweeps = sweeper;
            let with = lattice.as_ref().map(|lattice| WithMultiple {
                direct: &lights,
                lattice,
            });
            let make = |march| {
                FastScattering::new(
                    &volume,
                    scene.emits,
                    with.as_ref().map(|w| (w, scene.light_names())),
                    scene.ground.map(|g| (g, &lights as &dyn Illumination)),
                    march,
                )
            };
            let integrator = make(error_budget::march_settings(plan, &scene, &mut st, make))
                .with_deep(deep.is_some())
                .with_deep_aovs(!extent.deep_aovs.is_empty());
            // On the GPU: the same march with the lattice gathered in it.
            let on = Frontends {
                gpu: OnGpu::March(integrator.single(), lattice.as_ref()),
                cpu: &integrator,
            };
            render_on(
                (&mut gpu, &mut device_note, kept),
                on,
                &scene,
                plan,
                &extent,
                progress,
                &mut st,
            )?
        }
    };
    let mut exr = plan.outputs.exr.clone();
    exr.plate = crate::output::Plate {
        overscan: plan.camera.overscan,
        pixel_aspect: scene.plate_camera.pixel_aspect(),
    };
    if let Some(f) = job.frame {
        exr.extra_strings
            .push((piece::attr::FRAME.into(), f.to_string()));
    }
    if let Some(p) = job.piece {
        exr.extra_strings.extend([
            (piece::attr::TILE.into(), p.to_string()),
            (
                piece::attr::TILE_ROWS.into(),
                format!("{}-{}", rows.start, rows.end),
            ),
            (
                piece::attr::STORAGE.into(),
                if exr.float { "float" } else { "half" }.into(),
            ),
            (piece::attr::COLORSPACE.into(), exr.colorspace.name().into()),
            (piece::attr::Z_EMPTY.into(), exr.z_empty.to_string()),
            (piece::attr::CROP.into(), exr.crop_data_window.to_string()),
            (piece::attr::OVERSCAN.into(), exr.plate.overscan_text()),
        ]);
    }
    // The header describes the image's camera (the plate's): its NDC cube is the
    // display window, the overscan beyond it.
    let camera = &scene.plate_camera;
    exr.world_to_camera = Some(camera.world_to_camera().as_mat4().to_cols_array_2d());
    let (near, far) = scene.depth_range();
    exr.world_to_ndc = Some(camera.world_to_ndc(near, far).as_mat4().to_cols_array_2d());
    exr.extra_strings.push((
        "murk/depthRule".into(),
        format!(
            "Z is the camera-space distance along the view axis where accumulated alpha first reaches 0.5; {} where it never does",
            if exr.z_empty.is_finite() {
                format!("{:e}", exr.z_empty)
            } else {
                "+inf".into()
            }
        ),
    ));
    st.channels = frame
        .channel_names()
        .iter()
        .map(|s| s.to_string())
        .collect();
    let gpu_stages = std::mem::take(&mut st.scene.stages);
    let (gpu_memory_bytes, gpu_upload_bytes, gpu_stream_bytes, gpu_grid_parts) = (
        st.scene.gpu_memory_bytes,
        st.scene.gpu_upload_bytes,
        st.scene.gpu_stream_bytes,
        st.scene.gpu_grid_parts,
    );
    st.scene = scene.report;
    st.scene.stages.extend(gpu_stages);
    st.scene.gpu_memory_bytes = gpu_memory_bytes;
    st.scene.gpu_upload_bytes = gpu_upload_bytes;
    st.scene.gpu_stream_bytes = gpu_stream_bytes;
    st.scene.gpu_grid_parts = gpu_grid_parts;
    st.scene.notes.extend(device_note);
    report_bake(columns.as_deref(), &mut st.scene);
    report_sweeps(sweeps.as_ref(), &mut st.scene);
    st.device = match &gpu {
        Some(g) => format!("gpu: {}", g.name),
        None => "cpu".into(),
    };
    if let Some(budget) = &st.error_budget {
        st.scene.notes.push(budget.note());
    }
    st.scene
        .stages
        .insert("render".into(), Stage::ran(render_seconds));
    if let Some(s) = multiple_seconds {
        st.scene
            .stages
            .insert("multiple_scattering".into(), Stage::ran(s));
    }
    st.total_seconds = start.elapsed().as_secs_f64();
    Ok(RenderedImage {
        frame,
        exr,
        stats: st,
        deep: deep_image,
    })
}

/// The deep file's header: the flat file's camera matrices and murk's strings.
fn deep_options(exr: &crate::output::ExrOptions, tolerance: f64) -> DeepExrOptions {
    let mut extra_strings = exr.extra_strings.clone();
    extra_strings.push(("murk/deepTolerance".into(), tolerance.to_string()));
    DeepExrOptions {
        world_to_camera: exr.world_to_camera,
        world_to_ndc: exr.world_to_ndc,
        extra_strings,
        colorspace: exr.colorspace,
        half: !exr.float,
        tolerance,
        plate: exr.plate,
        targets: Vec::new(),
    }
}

/// The stats' note on the deep file: its samples and size.
fn deep_note(image: &DeepImage, written: crate::output::deep::DeepWriteSummary) -> String {
    let covered = image.pixels.iter().filter(|p| !p.is_empty()).count();
    let (samples, bytes) = (written.samples, written.bytes);
    format!(
        "deep: {samples} samples, {:.1} per covered pixel ({covered} pixels), at most {}; {bytes} bytes",
        samples as f64 / covered.max(1) as f64,
        written.max_samples_per_pixel
    )
}

/// Which pixels a render computes and what it keeps of them: its rows, deep samples
/// (with their merge tolerance) and the holdout's depth per pixel.
#[derive(Clone)]
struct Extent<'a> {
    rows: std::ops::Range<usize>,
    deep: Option<f64>,
    /// `--deep-aovs` as given.
    deep_aovs: &'a [String],
    holdout: Option<&'a [f32]>,
}

/// Runs the pixel loop of `integrator` over the scene's camera on the plan's threads,
/// and assembles the frame from its passes. Returns it and the loop's seconds.
fn render_frame<I: Integrator>(
    integrator: &I,
    scene: &Scene,
    plan: &RenderPlan,
    extent: &Extent,
    progress: &dyn Progress,
    st: &mut RenderStats,
) -> Result<(Frame, f64, Option<DeepImage>)> {
    let aovs = match extent.deep {
        Some(_) if !extent.deep_aovs.is_empty() => {
            crate::integrate::deep::select_aovs(&integrator.deep_aovs(), extent.deep_aovs)
                .map_err(|e| RenderError::Flag(format!("--deep-aovs {e}")))?
        }
        _ => Vec::new(),
    };
    let t = Instant::now();
    let job = pixels::PixelJob {
        integrator,
        camera: &scene.camera,
        // The plan's, or what `--max-error` chose for the shutter's noise.
        spp: st.spp,
        seed: plan.sampling.seed,
        rows: extent.rows.clone(),
        antialias: plan.sampling.antialias,
        deep: extent.deep,
        deep_aovs: &aovs,
        holdout: extent.holdout,
        shutter: plan.motion.shutter,
        camera_motion: scene.camera_motion.as_ref(),
        centred: st
            .error_budget
            .as_ref()
            .and_then(|b| b.shutter_noise.as_ref())
            .is_some_and(|n| n.centred),
        overscan: plan.camera.overscan,
    };
    progress.start("rendering", job.tiles() as u64, "tiles");
    // On the plan's threads: the caller runs inside `on_plan_threads`.
    let mut passes = pixels::render_pixels(&job, progress);
    progress.finish();
    let render_seconds = t.elapsed().as_secs_f64();
    st.rays = passes.rays;
    st.samples = passes.samples;
    st.samples_per_second = passes.samples as f64 / render_seconds.max(1e-9);
    let deep = passes.deep.take().map(|pixels| {
        let layers = aovs.iter().map(|a| a.layer.clone()).collect();
        pixels::deep_image(pixels, passes.width, passes.height, layers)
    });
    Ok((channels::assemble(&passes)?, render_seconds, deep))
}

/// Writes the stats as pretty JSON, atomically; `-` writes them to standard output.
fn write_stats(path: &Path, st: &RenderStats) -> Result<()> {
    let text = serde_json::to_string_pretty(st)?;
    if path == Path::new("-") {
        use std::io::Write;
        let mut out = std::io::stdout().lock();
        return out
            .write_all(text.as_bytes())
            .and_then(|_| out.write_all(b"\n"))
            .map_err(RenderError::Stdout);
    }
    write_atomically(path, |tmp| {
        std::fs::write(tmp, text.as_bytes())
            .map_err(|e| RenderError::output_path(path, e.to_string()))
    })
}

/// Before any work: makes every output's folder if missing and checks it writable.
fn check_output_dirs(plan: &RenderPlan) -> Result<()> {
    for path in output_paths(plan) {
        crate::files::place::prepare(path)?;
    }
    Ok(())
}

/// The files a render of `plan` writes (not `--stats -`, standard output).
pub fn output_paths(plan: &RenderPlan) -> impl Iterator<Item = &Path> {
    [
        Some(&plan.outputs.path),
        plan.outputs.preview.as_ref().map(|p| &p.0),
        plan.outputs.stats.as_ref().filter(|p| p.as_os_str() != "-"),
        plan.outputs.deep.as_ref().map(|d| &d.path),
    ]
    .into_iter()
    .flatten()
    .map(PathBuf::as_path)
}
