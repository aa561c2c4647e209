//! `--scattering path` on the GPU: the CPU's path tracer (src/integrate/path.rs) as a
//! compute shader (path.wgsl, path_tracking.wgsl), one invocation per camera sample,
//! over the march's uploaded grid and shadow maps and the path tracer's majorant grid
//! (its blocks' maxima and minima appended to `meta`). Each sample carries its random
//! streams' key ([`SampleRng::stream_key`]), so the GPU draws the CPU's numbers: where
//! f32 and f64 agree on every decision a path is the CPU's path. The samples, their rays
//! and the pixels' two passes are the single march's ([`super::pixels::assemble`]); each
//! sample's values are written into the pixel's passes on the CPU by the path tracer's
//! own [`crate::integrate::scatter_passes::ScatterPasses`].

use super::GpuTimes;
use super::context::{GROUPS_X, Gpu, MARCH_WGSL, Resident, WORKGROUP, entry};
use super::pixels::{Pick, assemble, sample_points};
use super::upload::{self, N_SAMPLES_AT, SAMPLE_FLOATS};
use crate::field::{Field, IndexRay};
use crate::integrate::integrator::{Integrator, SampleRng};
use crate::integrate::pass::PassKind;
use crate::integrate::path::PathTracer;
use crate::integrate::{MarchSettings, phase::HenyeyGreenstein};
use crate::render::pixels::{PixelJob, PixelPasses, finish_pixel};
use crate::scene::Scene;
use crate::scene::lights::LightShadow;
use glam::DVec3;
use rayon::prelude::*;
use std::time::Instant;
use wgpu::util::DeviceExt;

/// Floats a path sample takes in the input: the march's sample, then its key and flags.
const PATH_SAMPLE_FLOATS: usize = 2 * SAMPLE_FLOATS;
/// Floats of a result before the per-light radiance (8 a light: once, more than once).
const PATH_RESULT_BASE: usize = 4;
/// The most samples one dispatch traces: a path's cost has no bound a march's has, and
/// a long dispatch may be stopped by the driver's watchdog.
const PATH_BATCH: usize = 1 << 18;

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
    // Compiled before the samples are timed (a setup cost, as the upload is).
    path_pipeline(gpu)?;
    let grid = scene
        .fields
        .density
        .as_voxel_grid()
        .ok_or("a density that is not a voxel grid")?;
    let nodes = grid
        .nodes()
        .map_err(|_| "a density grid it cannot flatten")?;
    let lights = scene.illumination();
    let parts = job.integrator.parts();
    // Shadow rays tracked on the GPU read no map.
    let unshadowed: Vec<LightShadow> = (0..scene.lights.len())
        .map(|_| LightShadow::Unshadowed)
        .collect();
    let mut buffers = upload::build(&upload::SceneParts {
        grid,
        nodes,
        medium: scene.medium,
        phase: scene.phase.as_ref(),
        lights: &scene.lights,
        shadows: if parts.ratio_tracking {
            &unshadowed
        } else {
            &lights.shadows
        },
        settings: MarchSettings::default(),
        scatters: parts.lights > 0,
        lattice: None,
        // Emission and colour grids are refused under path.
        beside: super::grids::Beside {
            emission: None,
            color: None,
        },
        bounds: grid.active_bounds(),
        // The path tracer finds no ground (refused with path) and marches no shadow ray
        // of the march's kind.
        ground: false,
        quadrature: lights.quadrature,
        enough: lights.enough,
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
    if buffers.meta.len() as u64 >= u32::MAX as u64 {
        return Err("a majorant grid over 2^32 floats".into());
    }
    let layout = t.elapsed().as_secs_f64();
    let resident_bytes = buffers.resident_bytes();
    buffers.split_maps(gpu.max_binding());
    let (resident, uploaded_bytes) = gpu.upload(&buffers, kept)?;
    drop(buffers);
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
    let path_params = PathBatch {
        params,
        stride,
        layers,
    };
    let upload = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut times = GpuTimes {
        upload,
        layout,
        resident_bytes,
        uploaded_bytes,
        ..GpuTimes::default()
    };
    let passes = assemble(job, |picks| {
        trace_picks(gpu, &resident, &path_params, job, picks, &mut times)
    })?;
    times.march = t.elapsed().as_secs_f64();
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
/// pixel loop takes it, and the density samples the paths took. The pixels go in
/// chunks of about [`PATH_BATCH`] samples, each made, traced and recorded in turn, so
/// the samples' arrays stay that small whatever the image.
fn trace_picks(
    gpu: &Gpu,
    scene: &Resident,
    batch: &PathBatch,
    job: &PixelJob<PathTracer>,
    picks: &[Pick],
    times: &mut GpuTimes,
) -> Result<(Vec<f32>, u64), String> {
    let per_pick = picks
        .first()
        .map_or(1, |&p| sample_points(job, p).len().max(1));
    let mut values = Vec::new();
    let mut samples = 0;
    for chunk in picks.chunks((PATH_BATCH / per_pick).max(1)) {
        let (v, n) = trace_chunk(gpu, scene, batch, job, chunk, times)?;
        values.extend(v);
        samples += n;
    }
    Ok((values, samples))
}

/// [`trace_picks`] of one chunk.
fn trace_chunk(
    gpu: &Gpu,
    scene: &Resident,
    batch: &PathBatch,
    job: &PixelJob<PathTracer>,
    picks: &[Pick],
    times: &mut GpuTimes,
) -> Result<(Vec<f32>, u64), String> {
    let clock = Instant::now();
    let integrator = job.integrator;
    let layout = integrator.passes();
    let stride = layout.slots();
    let alpha_at = layout.offset_of_kind(PassKind::Alpha);
    let depth_at = layout.offset_of_kind(PassKind::Depth);
    let frame = job.camera.frame();
    let parts = integrator.parts();
    let density = parts.density;
    let points: Vec<Vec<(f64, f64, u32)>> =
        picks.par_iter().map(|&p| sample_points(job, p)).collect();
    let mut starts = Vec::with_capacity(picks.len() + 1);
    let mut total = 0;
    for p in &points {
        starts.push(total);
        total += p.len();
    }
    starts.push(total);
    let mut input = vec![0f32; total * PATH_SAMPLE_FLOATS];
    // Per sample: its depth rate and the weight of its opacity (none: not computed).
    let mut extra = vec![(0f64, None::<f64>); total];
    input
        .par_chunks_mut(PATH_SAMPLE_FLOATS)
        .zip(extra.par_iter_mut())
        .enumerate()
        .for_each(|(i, (out, extra))| {
            let k = starts.partition_point(|&s| s <= i) - 1;
            let (p, (jx, jy, stream)) = (picks[k], points[k][i - starts[k]]);
            let sample = job.camera_sample(&frame, p.x, p.y, jx, jy, None);
            let ray = sample.ray;
            let (sx, sy) = job.stream_pixel(p.x, p.y);
            let rng = SampleRng::new(job.seed, sx, sy, stream);
            let index = IndexRay::new(density, ray.origin, ray.dir);
            let put = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32];
            out[..3].copy_from_slice(&put(ray.origin));
            out[4..7].copy_from_slice(&put(ray.dir));
            out[7] = ray.t_max.min(f32::MAX as f64) as f32;
            out[8..11].copy_from_slice(&put(index.origin));
            out[11] = ray.t_min.min(f32::MAX as f64) as f32;
            out[12..15].copy_from_slice(&put(index.dir));
            let key = rng.stream_key();
            for (q, o) in out[16..20].iter_mut().enumerate() {
                *o = ((key >> (16 * q)) & 0xffff) as f32;
            }
            let weight = integrator.alpha_weight(rng.sample_index());
            out[20] = if weight.is_some() { 1.0 } else { 0.0 };
            *extra = (sample.depth_rate, weight);
        });
    times.rays += clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    let mut results = Vec::with_capacity(total * batch.stride);
    for start in (0..total).step_by(PATH_BATCH) {
        let count = PATH_BATCH.min(total - start);
        let part = &input[start * PATH_SAMPLE_FLOATS..(start + count) * PATH_SAMPLE_FLOATS];
        results.extend(dispatch(gpu, scene, batch, part, count)?);
    }
    times.kernel += clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    let (passes, sigma_t) = (parts.passes, parts.sigma_t);
    let rs = batch.stride;
    let mut values = vec![0f32; picks.len() * stride];
    let samples: u64 = values
        .par_chunks_mut(stride)
        .enumerate()
        .map(|(k, px)| {
            let mut acc = vec![0f64; stride];
            let mut n_samples = 0u64;
            for i in starts[k]..starts[k + 1] {
                let r = &results[i * rs..][..rs];
                let (depth_rate, weight) = extra[i];
                if let Some(w) = weight {
                    let depth = r[0] as f64;
                    let alpha = (DVec3::ONE - (-sigma_t * depth).exp()).element_sum() / 3.0;
                    passes.add_alpha(&mut acc, alpha.clamp(0.0, 1.0) * w);
                    if r[1] >= 0.0 {
                        passes.add_depth(&mut acc, r[1] as f64 * depth_rate);
                    }
                }
                n_samples += r[2] as u64;
                let v = |j: usize| DVec3::new(r[j] as f64, r[j + 1] as f64, r[j + 2] as f64);
                for l in 0..batch.layers {
                    let at = PATH_RESULT_BASE + 8 * l;
                    passes.add_scattered(&mut acc, l, 1, v(at));
                    passes.add_scattered(&mut acc, l, 2, v(at + 4));
                }
            }
            finish_pixel(px, &acc, starts[k + 1] - starts[k], alpha_at, depth_at);
            n_samples
        })
        .sum();
    times.record += clock.elapsed().as_secs_f64();
    Ok((values, samples))
}

/// Traces `count` samples (their floats `samples`) in one dispatch; their results.
fn dispatch(
    gpu: &Gpu,
    scene: &Resident,
    batch: &PathBatch,
    samples: &[f32],
    count: usize,
) -> Result<Vec<f32>, String> {
    let pipeline = path_pipeline(gpu)?;
    let d = &gpu.device;
    let scope = d.push_error_scope(wgpu::ErrorFilter::Validation);
    let oom = d.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let mut params = scene.params.clone();
    params[N_SAMPLES_AT] = count as u32;
    let uniform = |label: &str, words: &[u32]| {
        d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytemuck::cast_slice(words),
            usage: wgpu::BufferUsages::UNIFORM,
        })
    };
    let params = uniform("params", &params);
    let path_params = uniform("path params", &batch.params);
    let input = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("path samples"),
        contents: bytemuck::cast_slice(samples),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let bytes = (count * batch.stride * 4).max(16) as u64;
    let results = d.create_buffer(&wgpu::BufferDescriptor {
        label: Some("path results"),
        size: bytes,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let readback = d.create_buffer(&wgpu::BufferDescriptor {
        label: Some("path readback"),
        size: bytes,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let bind = d.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("path"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            entry(0, &params),
            entry(1, &scene.tree),
            entry(2, &scene.vals),
            entry(3, &scene.dsm[0]),
            entry(4, &scene.meta),
            entry(5, &input),
            entry(6, &results),
            entry(7, &scene.dsm[1]),
            entry(8, &scene.dsm[2]),
            entry(9, &path_params),
        ],
    });
    let mut encoder = d.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &bind, &[]);
        let groups = (count as u32).div_ceil(WORKGROUP);
        pass.dispatch_workgroups(groups.min(GROUPS_X), groups.div_ceil(GROUPS_X), 1);
    }
    encoder.copy_buffer_to_buffer(&results, 0, &readback, 0, bytes);
    gpu.queue.submit([encoder.finish()]);
    let (tx, rx) = std::sync::mpsc::channel();
    readback.slice(..).map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    d.poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| format!("{}: {e}", gpu.name))?;
    let mapped = rx
        .recv()
        .map_err(|e| e.to_string())
        .and_then(|r| r.map_err(|e| e.to_string()));
    if let Some(e) = pollster::block_on(oom.pop()) {
        return Err(format!("{}: out of memory ({e})", gpu.name));
    }
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(format!("{}: {e}", gpu.name));
    }
    mapped.map_err(|e| format!("{}: reading the paths back: {e}", gpu.name))?;
    let view = readback
        .slice(..)
        .get_mapped_range()
        .map_err(|e| format!("{}: reading the paths back: {e:?}", gpu.name))?;
    let mut values: Vec<f32> = bytemuck::cast_slice(&view).to_vec();
    drop(view);
    readback.unmap();
    values.truncate(count * batch.stride);
    Ok(values)
}

/// The path tracer's pipeline (path.wgsl and path_tracking.wgsl after the march's
/// sources), compiled on first use.
fn path_pipeline(gpu: &Gpu) -> Result<&wgpu::ComputePipeline, String> {
    let compiled = gpu.path.get_or_init(|| {
        let d = &gpu.device;
        let scope = d.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut sources = MARCH_WGSL.to_vec();
        sources.extend([
            include_str!("path.wgsl"),
            include_str!("path_tracking.wgsl"),
        ]);
        let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("path"),
            source: wgpu::ShaderSource::Wgsl(sources.join("\n").into()),
        });
        let pipeline = d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("path"),
            layout: None,
            module: &module,
            entry_point: Some("path_samples"),
            compilation_options: Default::default(),
            cache: None,
        });
        match pollster::block_on(scope.pop()) {
            Some(e) => Err(format!(
                "{}: the path tracer does not compile ({e})",
                gpu.name
            )),
            None => Ok(pipeline),
        }
    });
    compiled.as_ref().map_err(Clone::clone)
}
