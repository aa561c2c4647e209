//! `--scattering path` on the GPU: the CPU's path tracer (src/integrate/path.rs) as a
//! compute shader (path.wgsl, path_tracking.wgsl), one invocation per camera sample,
//! over the march's uploaded grid and shadow maps and the path tracer's majorant grid
//! (its blocks' maxima and minima appended to `meta`). Each sample's ray and its random
//! streams' key ([`crate::integrate::integrator::SampleRng::stream_key`]) are made on the
//! GPU from its pixel, as the march's are (rays.wgsl), so the GPU draws the CPU's numbers:
//! where f32 and f64 agree on every decision a path is the CPU's path. The samples and
//! the pixels' two passes are the single march's ([`super::pixels::assemble`]); each
//! pixel's samples are summed on the GPU (path_sums.wgsl), and the sums written into
//! the pixel's passes on the CPU by the path tracer's own
//! [`crate::integrate::scatter_passes::ScatterPasses`].

use super::GpuTimes;
use super::context::{GRID_WGSL, Gpu, MARCH_WGSL, Resident};
use super::grid_parts::GridBinding;
use super::picks::{CAMERA_BINDING, PICK_FLOATS, Pick, camera_rays, make_picks, sample_count};
use super::pixels::{Through, assemble, stream_picks};
use super::stream::Sums;
use super::upload;
use crate::field::Field;
use crate::integrate::integrator::Integrator;
use crate::integrate::pass::PassKind;
use crate::integrate::path::PathTracer;
use crate::integrate::phase::{HenyeyGreenstein, PhaseFunction};
use crate::render::pixels::{PixelJob, PixelPasses, finish_pixel, sample_stream};
use crate::scene::Scene;
use crate::scene::lights::LightShadow;
use glam::DVec3;
use rayon::prelude::*;
use std::time::Instant;

/// Floats a path sample takes in the input: its pick, then its flags.
const PATH_SAMPLE_FLOATS: usize = 2 * PICK_FLOATS;
/// The binding of the path tracer's parameters (path.wgsl's `PathParams`).
const PATH_BINDING: u32 = 9;
/// Floats of a result before the per-light radiance (8 a light: once, more than once):
/// the camera ray's, then the emission seen directly, after one event and after more.
const PATH_RESULT_BASE: usize = 16;

/// Renders the job's pixels by tracing `job.integrator`'s paths on `gpu` (the scene
/// passed [`super::unsupported`]; `g`: its Henyey–Greenstein asymmetry), the scene's
/// buffers kept from a sequence's frame before where `kept` holds them.
pub fn render_path(
    gpu: &Gpu,
    scene: &Scene,
    g: f64,
    job: &PixelJob<PathTracer>,
    kept: Option<&mut super::KeptBuffers>,
) -> Result<(PixelPasses, GpuTimes), String> {
    let t = Instant::now();
    let lights = scene.illumination();
    let traversal = scene.traversal();
    let volume = scene.volume(&traversal);
    let parts = job.integrator.parts();
    // Shadow rays tracked on the GPU read no map.
    let unshadowed: Vec<LightShadow> = (0..scene.lights.len())
        .map(|_| LightShadow::Unshadowed)
        .collect();
    let base = super::scene_parts(scene, &lights, &volume)?;
    let grid = base.grid;
    let mut buffers = upload::build(&upload::SceneParts {
        shadows: if parts.ratio_tracking {
            &unshadowed
        } else {
            base.shadows
        },
        scatters: parts.lights > 0,
        // The flights' blocks lie over the density's bounds (emission past it is
        // gathered to PathParams' bounds). The path tracer finds no ground and marches
        // no shadow ray of the march's kind.
        bounds: grid.active_bounds(),
        ..base
    })?;
    // The majorant grid: the path tracer's, else one of the same blocks.
    let built;
    let majorants = match parts.majorants {
        Some(m) => m,
        None => {
            built = crate::accel::MajorantGrid::build(grid, 4);
            &built
        }
    };
    let maj_base = buffers.meta.len();
    buffers.meta.extend(majorants.maxima());
    let min_base = buffers.meta.len();
    buffers.meta.extend(majorants.minima());
    buffers
        .meta
        .resize(buffers.meta.len().max(maj_base + 4), 0.0);
    let phase = phase_sampling(scene.phase.as_ref(), &mut buffers.meta)?;
    if buffers.meta.len() as u64 >= u32::MAX as u64 {
        return Err("a majorant grid over 2^32 floats".into());
    }
    let layout = t.elapsed().as_secs_f64();
    let resident_bytes = buffers.resident_bytes();
    buffers.split_maps(gpu.max_binding());
    let (resident, uploaded_bytes) = gpu.upload(&buffers, kept)?;
    drop(buffers);
    if resident.features.grid != GridBinding::Whole && super::context::refuses_cut_grids(gpu) {
        // On lavapipe the path tracer over a cut grid did not finish in minutes where
        // the whole grid's took two (not diagnosed; the march with marched shadow rays
        // over a cut grid is miscompiled there, context.rs); on an NVIDIA GPU it traces
        // the whole grid's paths bit for bit. Refused there.
        return Err(format!(
            "the grids' arrays exceed the largest buffer {} binds ({}), and a grid cut \
             into parts is not path traced on an adapter that runs on the CPU",
            gpu.name,
            super::bind::size_text(gpu.max_binding())
        ));
    }
    // Compiled for the grid's layout on first use (else found), timed apart from the
    // upload: the stats' `gpu_compile`.
    let compiling = Instant::now();
    path_pipeline(gpu, resident.features.grid)?;
    let compile = compiling.elapsed().as_secs_f64();
    let (origin, dims) = majorants.lattice();
    let tr = grid.transform();
    let inv = tr.inverse_linear();
    let translation = tr.index_to_world(DVec3::ZERO);
    let sigma_t = scene.medium.sigma_t();
    let f = |v: f64| (v as f32).to_bits();
    let col = |v: DVec3| [f(v.x), f(v.y), f(v.z), 0];
    let mut params: Vec<u32> = Vec::with_capacity(36);
    params.extend(col(inv.x_axis));
    params.extend(col(inv.y_axis));
    params.extend(col(inv.z_axis));
    params.extend(col(translation));
    params.extend([origin.x, origin.y, origin.z, majorants.block()].map(|v| v as u32));
    params.extend([dims.x as u32, dims.y as u32, dims.z as u32, maj_base as u32]);
    let n_lights = parts.lights.min(upload::MAX_LIGHTS);
    // The environment's layer follows the lights'.
    let dome = scene.environment.as_ref().filter(|_| parts.environment);
    let layers = n_lights + usize::from(dome.is_some());
    let stride = PATH_RESULT_BASE + 8 * layers;
    params.extend([
        f(HenyeyGreenstein::new(g).g()),
        parts.bounces.max(1),
        n_lights as u32,
        stride as u32,
        u32::from(sigma_t.x == sigma_t.y && sigma_t.y == sigma_t.z),
        min_base as u32,
        u32::from(parts.ratio_tracking),
        0,
    ]);
    let radiance = dome.map_or(DVec3::ZERO, |e| e.radiance);
    params.extend([
        f(radiance.x),
        f(radiance.y),
        f(radiance.z),
        f(if dome.is_some() { 1.0 } else { 0.0 }),
    ]);
    // Emission past the density is gathered to the bounds of the grids traversed with it.
    let emits = volume.emission.as_ref().is_some_and(|e| e.is_active());
    let b = Field::active_bounds(&traversal);
    let lo = b.min.as_dvec3();
    params.extend([f(lo.x), f(lo.y), f(lo.z), f(if emits { 1.0 } else { 0.0 })]);
    params.extend(col(b.max.as_dvec3()));
    params.extend(phase);
    let path_params = PathBatch {
        params,
        stride,
        layers,
    };
    let upload = t.elapsed().as_secs_f64() - compile;
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
    let passes = assemble(job, |picks| {
        trace_picks(gpu, &resident, &path_params, job, picks, &mut times)
    })?;
    times.march = t.elapsed().as_secs_f64();
    times.busy = resident.busy.seconds();
    times.wait = resident.waited.seconds();
    Ok((passes, times))
}

/// The path tracer's own parameters (`PathParams` in path.wgsl) and its results' layout.
struct PathBatch {
    params: Vec<u32>,
    /// Floats per sample's result.
    stride: usize,
    /// The lights' layers, the environment's last.
    layers: usize,
}

/// Traces `picks` on the GPU: each pixel's values, the mean of its samples as the CPU's
/// pixel loop takes it (summed on the GPU), and the density samples the paths took.
fn trace_picks(
    gpu: &Gpu,
    scene: &Resident,
    batch: &PathBatch,
    job: &PixelJob<PathTracer>,
    picks: &[Pick],
    times: &mut GpuTimes,
) -> Result<(Vec<f32>, u64), String> {
    let frame = job.camera.frame();
    let parts = job.integrator.parts();
    // One pass's picks share their stratified grid, and so their samples' streams.
    let grid = picks.first().map_or(0, |p| p.grid);
    let per_pixel = picks.first().map_or(1, |&p| sample_count(job, p) as usize);
    let camera = camera_rays(job, &frame, grid, parts.density, None);
    let pipeline = path_pipeline(gpu, scene.features.grid)?;
    let sums = sums_pipeline(gpu)?;
    let through = Through {
        gpu,
        scene,
        pipeline: &pipeline,
        in_floats: PATH_SAMPLE_FLOATS,
        out_floats: batch.stride,
        uniforms: &[(PATH_BINDING, &batch.params), (CAMERA_BINDING, &camera)],
        sums: Some(Sums {
            pipeline: &sums,
            per_pixel,
            sigma_t: parts.sigma_t.to_array().map(|c| c as f32),
        }),
    };
    // The weight of each sample's opacity (none: not computed), the same in every pixel.
    let weights: Vec<Option<f64>> = (0..per_pixel as u32)
        .map(|s| job.integrator.alpha_weight(sample_stream(grid, s)))
        .collect();
    let weight = weights.iter().flatten().next().copied().unwrap_or(0.0);
    if weights.iter().flatten().any(|&w| w != weight) {
        return Err("samples whose opacities are weighted differently".into());
    }
    stream_picks(
        &through,
        job,
        picks,
        |chunk, input| make_paths(job, chunk, &weights, input),
        |(), sums, px| record_paths(job, batch, weight, per_pixel, sums, px),
        times,
    )
}

/// Writes the samples of `picks` into `input` ([`PATH_SAMPLE_FLOATS`] each): its pick
/// (the GPU makes its ray and its random streams' key from it), then 1 where its
/// opacity is wanted (`weights`: each of a pixel's samples').
fn make_paths(
    job: &PixelJob<PathTracer>,
    picks: &[Pick],
    weights: &[Option<f64>],
    input: &mut Vec<f32>,
) {
    make_picks(job, picks, PATH_SAMPLE_FLOATS, input);
    input
        .par_chunks_exact_mut(PATH_SAMPLE_FLOATS * weights.len().max(1))
        .for_each(|pixel| {
            for (sample, w) in pixel.chunks_exact_mut(PATH_SAMPLE_FLOATS).zip(weights) {
                sample[PICK_FLOATS] = if w.is_some() { 1.0 } else { 0.0 };
            }
        });
}

/// Writes a chunk's pixels' sums (path_sums.wgsl: `per_pixel` samples each) into their
/// values: the mean of each pixel's samples, the opacities weighted by `weight`. Returns
/// the density samples the paths took.
fn record_paths(
    job: &PixelJob<PathTracer>,
    batch: &PathBatch,
    weight: f64,
    per_pixel: usize,
    sums: &[f32],
    values: &mut [f32],
) -> u64 {
    let parts = job.integrator.parts();
    let passes = parts.passes;
    let layout = job.integrator.passes();
    let stride = layout.slots();
    let (alpha_at, depth_at) = (
        layout.offset_of_kind(PassKind::Alpha),
        layout.offset_of_kind(PassKind::Depth),
    );
    values
        .par_chunks_mut(stride)
        .zip(sums.par_chunks_exact(batch.stride))
        // Each thread's sums, cleared for each pixel (not made anew for each).
        .map_init(
            || vec![0f64; stride],
            |acc, (px, r)| {
                acc.fill(0.0);
                passes.add_alpha(acc, r[0] as f64 * weight);
                passes.add_depths(acc, r[1] as f64, r[3] as f64);
                let v = |j: usize| DVec3::new(r[j] as f64, r[j + 1] as f64, r[j + 2] as f64);
                if parts.emits {
                    passes.add_emission(acc, v(4));
                    passes.add_scattered_emission(acc, 1, v(8));
                    passes.add_scattered_emission(acc, 2, v(12));
                }
                for l in 0..batch.layers {
                    let at = PATH_RESULT_BASE + 8 * l;
                    passes.add_scattered(acc, l, 1, v(at));
                    passes.add_scattered(acc, l, 2, v(at + 4));
                }
                finish_pixel(px, acc, per_pixel, alpha_at, depth_at);
                // The samples' count, summed as an integer.
                u64::from(r[2].to_bits())
            },
        )
        .sum()
}

/// Appends to `meta` how the phase function is sampled where it is a table (water
/// drops: per node the cumulative probability as two floats, hi + lo, `1 − cos θ` and
/// its bin's density, as `WaterDrop::sample` draws θ); `PathParams.phase`: 1, where
/// they start and the bins (all 0 for Henyey–Greenstein, sampled in closed form).
fn phase_sampling(phase: &dyn PhaseFunction, meta: &mut Vec<f32>) -> Result<[u32; 4], String> {
    let Some(t) = phase.table() else {
        return Ok([0; 4]);
    };
    let n = t.cdf.len();
    if n < 2 || t.one_minus_cos.len() != n || t.bin_pdf.len() + 1 != n {
        return Err("a phase table whose sampling bins do not match its nodes".into());
    }
    let base = meta.len();
    for i in 0..n {
        let pdf = t.bin_pdf.get(i).copied().unwrap_or(0.0);
        let hi = t.cdf[i] as f32;
        let lo = (t.cdf[i] - hi as f64) as f32;
        meta.extend([hi, lo, t.one_minus_cos[i] as f32, pdf as f32]);
    }
    Ok([1, base as u32, (n - 1) as u32, 0])
}

/// The pass that sums each pixel's paths (path_sums.wgsl), compiled on first use.
fn sums_pipeline(gpu: &Gpu) -> Result<wgpu::ComputePipeline, String> {
    let mut held = gpu.path_sums.lock().map_err(|_| "a poisoned lock")?;
    if let Some(p) = held.as_ref() {
        return Ok(p.clone());
    }
    let pipeline = gpu.compile(
        "path pixel sums",
        &[include_str!("path_sums.wgsl")],
        "path_pixel_sums",
    )?;
    *held = Some(pipeline.clone());
    Ok(pipeline)
}

/// The path tracer's pipeline (path.wgsl and path_tracking.wgsl after the march's
/// sources) for the grid's arrays laid out as `grid`, compiled on first use.
fn path_pipeline(gpu: &Gpu, grid: GridBinding) -> Result<wgpu::ComputePipeline, String> {
    gpu.cached(&gpu.path, grid, |accessors| {
        let mut sources = vec![GRID_WGSL, accessors];
        sources.extend(MARCH_WGSL);
        sources.extend([
            include_str!("path.wgsl"),
            include_str!("path_tracking.wgsl"),
        ]);
        gpu.compile("path tracer", &sources, "path_samples")
    })
}
