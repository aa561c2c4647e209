//! The pixel loop of [`crate::render::pixels`] with the march on the GPU: the same
//! samples (centres, or `--spp` jittered ones, then the silhouette pixels again on the
//! stratified grid) and the same rays and jitter, made on the GPU from each sample's
//! pixel (picks.rs, rays.wgsl) and marched there in chunks streamed through it
//! (stream.rs); each sample's result (with the fast mode's multiply scattered part of
//! it, `indirect`) is written into the pixel's passes by [`SingleScattering::record`],
//! as the CPU's are, with the light the ground plane receives where the ray meets it.

use super::GpuTimes;
use super::context::{Gpu, Resident};
use super::picks::{CAMERA_BINDING, PICK_FLOATS, Pick, camera_rays, make_picks, sample_count};
use super::readback::catching_errors;
use super::stream;
use super::upload::{GROUND_FLOATS, RESULT_BASE, RESULT_EMISSION};
use crate::integrate::RayResult;
use crate::integrate::ground::GroundLight;
use crate::integrate::integrator::Integrator;
use crate::integrate::pass::PassKind;
use crate::integrate::single::SingleScattering;
use crate::render::pixels::{EDGE_ALPHA, PixelJob, PixelPasses, finish_pixel};
use glam::DVec3;
use rayon::prelude::*;

/// Writes the results of a chunk's samples (`made` of them, `rs` floats each) into its
/// pixels' values (`stride` each: the mean of each pixel's samples), as
/// [`crate::render::pixels::render_pixels`] takes them. Returns the march samples the
/// rays took.
fn record_results(
    job: &PixelJob<SingleScattering>,
    starts: &[usize],
    results: &[f32],
    rs: usize,
    values: &mut [f32],
) -> u64 {
    let integrator = job.integrator;
    let ground = integrator.ground();
    let lights = (rs - RESULT_BASE - if ground.is_some() { GROUND_FLOATS } else { 0 }) / 4;
    mean_of_samples(
        job,
        starts,
        values,
        || vec![DVec3::ZERO; lights],
        |acc, per_light, i| {
            let r = &results[i * rs..][..rs];
            let v = |j: usize| DVec3::new(r[j] as f64, r[j + 1] as f64, r[j + 2] as f64);
            for (l, pl) in per_light.iter_mut().enumerate() {
                *pl = v(RESULT_BASE + 4 * l);
            }
            // Where the ray met the ground (0: it did not).
            let at = RESULT_BASE + 4 * lights;
            let hit = ground.filter(|_| r[at + 3] > 0.0).map(|g| {
                let (open, through) = (v(at), v(at + 4));
                (g, r[at + 3] as f64, GroundLight::through(open, through))
            });
            let ray = RayResult {
                transmittance: v(4),
                optical_depth: if r[3] != 0.0 { DVec3::INFINITY } else { v(0) },
                emission: v(RESULT_EMISSION),
                scatter: per_light.iter().sum(),
                half_opacity_t: (r[7] >= 0.0).then_some(r[7] as f64),
                samples: r[8] as u64,
            };
            let depth_rate = r[RESULT_EMISSION + 3] as f64;
            integrator.record(&ray, hit, per_light, v(9), depth_rate, acc);
            ray.samples
        },
    )
}

/// Each pixel's values (`values`, the job's pass slots each) as the mean of its samples
/// (pixel k's are `starts[k]..starts[k + 1]`), on all threads: `add(sums, scratch, i)`
/// adds sample i into the pixel's sums (cleared for each pixel) and returns the density
/// samples it took; `scratch` makes each thread's scratch space. Returns their total.
pub(super) fn mean_of_samples<I: Integrator, T>(
    job: &PixelJob<I>,
    starts: &[usize],
    values: &mut [f32],
    scratch: impl Fn() -> T + Sync + Send,
    add: impl Fn(&mut [f64], &mut T, usize) -> u64 + Sync + Send,
) -> u64 {
    let layout = job.integrator.passes();
    let stride = layout.slots();
    let alpha_at = layout.offset_of_kind(PassKind::Alpha);
    let depth_at = layout.offset_of_kind(PassKind::Depth);
    values
        .par_chunks_mut(stride)
        .enumerate()
        // Each thread's sums, cleared for each pixel (not made anew for each).
        .map_init(
            || (vec![0f64; stride], scratch()),
            |(acc, scratch), (k, px)| {
                acc.fill(0.0);
                let samples: u64 = (starts[k]..starts[k + 1])
                    .map(|i| add(acc, scratch, i))
                    .sum();
                finish_pixel(px, acc, starts[k + 1] - starts[k], alpha_at, depth_at);
                samples
            },
        )
        .sum()
}

/// The picks of a stream's chunks ([`super::stream`]): as many whole pixels as fit
/// `max_samples` (each pixel of one pass takes as many samples as the first), how many
/// that is, and the most samples a chunk holds.
fn pick_chunks<'p, I: Integrator>(
    job: &PixelJob<I>,
    picks: &'p [Pick],
    max_samples: usize,
) -> (Vec<&'p [Pick]>, usize, usize) {
    let per_pick = picks
        .first()
        .map_or(1, |&p| (sample_count(job, p) as usize).max(1));
    let per_chunk = (max_samples / per_pick).max(1);
    let chunks: Vec<&[Pick]> = picks.chunks(per_chunk).collect();
    let most = chunks
        .iter()
        .map(|c| c.iter().map(|&p| sample_count(job, p) as usize).sum())
        .max()
        .unwrap_or(0);
    (chunks, per_chunk, most)
}

/// Renders `picks` on the GPU: each pixel's `stride` values, the mean of its samples as
/// [`crate::render::pixels::render_pixels`] takes it. Returns them and the march
/// samples the rays took.
fn render_picks(
    gpu: &Gpu,
    scene: &Resident,
    job: &PixelJob<SingleScattering>,
    picks: &[Pick],
    times: &mut GpuTimes,
) -> Result<(Vec<f32>, u64), String> {
    let frame = job.camera.frame();
    // One pass's picks share their stratified grid.
    let integrator = job.integrator;
    let camera = camera_rays(
        job,
        &frame,
        picks.first().map_or(0, |p| p.grid),
        integrator.density(),
        integrator.ground(),
    );
    let rs = scene.stride as usize;
    let pipeline = gpu.march_pipeline(scene.features)?;
    let through = Through {
        gpu,
        scene,
        pipeline: &pipeline,
        in_floats: PICK_FLOATS,
        out_floats: rs,
        uniforms: &[(CAMERA_BINDING, &camera)],
        sums: None,
    };
    stream_picks(
        &through,
        job,
        picks,
        |chunk, input| make_picks(job, chunk, PICK_FLOATS, input),
        |starts, results, px| record_results(job, starts, results, rs, px),
        times,
    )
}

/// Where [`stream_picks`] sends the samples: the pipeline run over them, the scene it
/// reads, the floats a sample takes in and gives back, the pipeline's own uniforms, and
/// where each pixel's results are summed on the GPU, how.
pub(super) struct Through<'a> {
    pub gpu: &'a Gpu,
    pub scene: &'a Resident,
    pub pipeline: &'a wgpu::ComputePipeline,
    pub in_floats: usize,
    pub out_floats: usize,
    /// Each uniform's binding and words.
    pub uniforms: &'a [(u32, &'a [u32])],
    pub sums: Option<stream::Sums<'a>>,
}

/// Runs `picks` through the GPU (`through`), streamed in chunks ([`stream::stream`]):
/// each chunk's samples are made by `make` while the GPU runs the chunk before, and
/// its pixels' values written by `record` (from what `make` kept and the results, or
/// with `through.sums` each pixel's sums) while the GPU runs the chunk after. Returns each pixel's values (the job's pass
/// slots each) and the density samples `record` counted.
pub(super) fn stream_picks<I: Integrator, M>(
    through: &Through,
    job: &PixelJob<I>,
    picks: &[Pick],
    make: impl Fn(&[Pick], &mut Vec<f32>) -> M,
    record: impl Fn(&M, &[f32], &mut [f32]) -> u64,
    times: &mut GpuTimes,
) -> Result<(Vec<f32>, u64), String> {
    let Through { gpu, scene, .. } = *through;
    let stride = job.integrator.passes().slots();
    let fit = stream::chunk_samples(gpu, through.in_floats, through.out_floats);
    let (chunks, per_chunk, max_samples) = pick_chunks(job, picks, fit);
    if let Some(m) = through.sums
        && picks
            .iter()
            .any(|&p| sample_count(job, p) as usize != m.per_pixel)
    {
        return Err(format!(
            "{}: pixels summed on the GPU that take other than {} samples",
            gpu.name, m.per_pixel
        ));
    }
    let shape = stream::Shape {
        in_floats: through.in_floats,
        out_floats: through.out_floats,
        max_samples,
        sums: through.sums,
    };
    let mut values = vec![0f32; picks.len() * stride];
    let mut samples = 0u64;
    catching_errors(&gpu.device, &gpu.name, "", || {
        stream::stream(
            gpu,
            scene,
            through.pipeline,
            shape,
            through.uniforms,
            chunks.len(),
            |k, input| make(chunks[k], input),
            |k, made, results| {
                let px = &mut values[k * per_chunk * stride..][..chunks[k].len() * stride];
                samples += record(&made, results, px);
            },
            times,
        )
    })?;
    Ok((values, samples))
}

/// [`crate::render::pixels::render_pixels`] with the march on the GPU.
pub fn render_pixels(
    gpu: &Gpu,
    scene: &Resident,
    job: &PixelJob<SingleScattering>,
    times: &mut GpuTimes,
) -> Result<PixelPasses, String> {
    assemble(job, |picks| render_picks(gpu, scene, job, picks, times))
}

/// [`crate::render::pixels::render_pixels`]'s two passes (the centres or the job's
/// samples, then the silhouette pixels again on the stratified grid) with each pass's
/// pixels rendered by `render` (each pixel's `stride` values and the density samples
/// taken), and the pixels laid out as planes.
pub(super) fn assemble<I: Integrator>(
    job: &PixelJob<I>,
    mut render: impl FnMut(&[Pick]) -> Result<(Vec<f32>, u64), String>,
) -> Result<PixelPasses, String> {
    let (w, h) = (job.camera.width, job.camera.height);
    let layout = job.integrator.passes().clone();
    let stride = layout.slots();
    let alpha_at = layout.offset_of_kind(PassKind::Alpha);
    let (r0, r1) = (job.rows.start.min(h), job.rows.end.min(h));
    let (c0, c1) = job.centre_rows();
    let centres: Vec<Pick> = (c0..c1)
        .flat_map(|y| (0..w).map(move |x| Pick { x, y, grid: 0 }))
        .collect();
    let (mut values, mut samples) = render(&centres)?;
    let mut resampled = 0u64;
    if let (true, Some(a)) = (job.edges() && r1 > r0, alpha_at) {
        let alpha = |x: usize, y: usize| values[((y - c0) * w + x) * stride + a];
        let is_edge = |x: usize, y: usize| {
            let here = alpha(x, y);
            (y.saturating_sub(1)..(y + 2).min(h)).any(|ny| {
                (x.saturating_sub(1)..(x + 2).min(w))
                    .any(|nx| (alpha(nx, ny) - here).abs() > EDGE_ALPHA)
            })
        };
        let edges: Vec<Pick> = (r0..r1)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter(|&(x, y)| is_edge(x, y))
            .map(|(x, y)| Pick {
                x,
                y,
                grid: job.antialias,
            })
            .collect();
        let (again, more) = render(&edges)?;
        for (p, px) in edges.iter().zip(again.chunks(stride)) {
            values[((p.y - c0) * w + p.x) * stride..][..stride].copy_from_slice(px);
        }
        samples += more;
        resampled = edges.len() as u64;
    }
    let mut planes: Vec<Vec<Vec<f32>>> = layout
        .passes()
        .iter()
        .map(|p| match p.kind {
            PassKind::Rgb => vec![vec![0f32; w * h]; 3],
            PassKind::Alpha | PassKind::Matte => vec![vec![0f32; w * h]],
            PassKind::Depth => vec![vec![f32::INFINITY; w * h]],
        })
        .collect();
    // Each plane filled on its own thread: at 4K, 8 M pixels of a score of channels.
    let mut filling: Vec<(usize, &mut Vec<f32>)> = Vec::new();
    for (p, pass_planes) in planes.iter_mut().enumerate() {
        let at = layout.offset(p);
        filling.extend(
            pass_planes
                .iter_mut()
                .enumerate()
                .map(|(c, plane)| (at + c, plane)),
        );
    }
    filling.into_par_iter().for_each(|(slot, plane)| {
        for y in r0..r1 {
            let row = &values[(y - c0) * w * stride..][..w * stride];
            for (v, px) in plane[y * w..(y + 1) * w]
                .iter_mut()
                .zip(row.chunks_exact(stride))
            {
                *v = px[slot];
            }
        }
    });
    Ok(PixelPasses {
        width: w,
        height: h,
        layout,
        planes,
        rays: ((c1.saturating_sub(c0) * w) as u64) * job.spp as u64
            + resampled * (job.antialias as u64).pow(2),
        samples,
        deep: None,
    })
}
