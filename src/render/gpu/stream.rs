//! Camera samples streamed through a compute pipeline (the march's, the path tracer's)
//! in chunks, two in flight: while the GPU runs one chunk, the CPU takes the results of
//! the chunk before and makes the samples of the chunk after. Each of the two slots
//! keeps its buffers for the whole render (the staging buffer the samples are written
//! into, the samples and results on the GPU, the buffer the results are read from), so
//! a 4K frame's hundreds of megabytes pass through the same few pages, and the results
//! are taken straight from their mapping.

use super::GpuTimes;
use super::bind::entry;
use super::busy::PassTimer;
use super::context::{Gpu, Resident, encode_pass};
use super::readback::write_in_pieces;
use super::upload::N_SAMPLES_AT;
use std::borrow::Cow;
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::time::Instant;

/// The most samples a chunk holds: a path's cost has no bound, and a long dispatch may
/// be stopped by the driver's watchdog; and chunks this size keep a 960×540 frame in a
/// few, so that the GPU's work on one hides the CPU's on its neighbours.
pub(super) const CHUNK_SAMPLES: usize = 1 << 18;

/// The most samples a chunk of samples `in_floats` floats in and `out_floats` out may
/// hold on `gpu`: [`CHUNK_SAMPLES`], fewer where its buffers would exceed a binding.
pub(super) fn chunk_samples(gpu: &Gpu, in_floats: usize, out_floats: usize) -> usize {
    let per_sample = (in_floats.max(out_floats).max(1) * 4) as u64;
    ((gpu.max_binding() / per_sample) as usize).clamp(1, CHUNK_SAMPLES)
}

/// What a stream moves: floats a sample takes in and gives back, the most samples any
/// of its chunks holds, and where the results are summed on the GPU before they come
/// back, how.
#[derive(Clone, Copy)]
pub(super) struct Shape<'a> {
    pub in_floats: usize,
    pub out_floats: usize,
    pub max_samples: usize,
    pub sums: Option<Sums<'a>>,
}

/// A pass after the samples' that sums each pixel's results (`per_pixel` samples, laid
/// one pixel after another) into one of the same floats (path_sums.wgsl): the sums come
/// back, not the samples' results.
#[derive(Clone, Copy)]
pub(super) struct Sums<'a> {
    pub pipeline: &'a wgpu::ComputePipeline,
    pub per_pixel: usize,
    /// The medium's extinction per channel (the opacity of a sample is summed).
    pub sigma_t: [f32; 3],
}

impl Shape<'_> {
    /// How many results `count` samples give back: one a sample, or one a pixel.
    fn returned(self, count: usize) -> usize {
        match self.sums {
            Some(s) => count / s.per_pixel.max(1),
            None => count,
        }
    }

    /// Bytes of what `count` samples give back.
    fn out_bytes(self, count: usize) -> u64 {
        (self.returned(count) * self.out_floats * 4) as u64
    }
}

/// The buffers one chunk in flight uses.
struct Slot {
    params: wgpu::Buffer,
    staging: wgpu::Buffer,
    input: wgpu::Buffer,
    results: wgpu::Buffer,
    readback: wgpu::Buffer,
    bind: wgpu::BindGroup,
    /// Where the results are summed per pixel: the sums, their uniform and bind group.
    sums: Option<(wgpu::Buffer, wgpu::Buffer, wgpu::BindGroup)>,
    timer: Option<PassTimer>,
}

/// A chunk submitted: its slot, its submission, its samples, what its maker kept for
/// its taker, and the mappings it waits for.
struct InFlight<S> {
    chunk: usize,
    slot: usize,
    index: wgpu::SubmissionIndex,
    count: usize,
    kept: S,
    mapped: Receiver<Result<(), wgpu::BufferAsyncError>>,
    maps: usize,
}

/// Runs `pipeline` over `chunks` chunks of samples through the uploaded `scene`, bound
/// as the march binds it (the parameters with their `n_samples` at 0, the scene's
/// buffers, the samples at 5, the results at 6, then each of `uniforms` at its binding). `make(k,
/// into)` writes chunk k's samples into `into` (empty; at most `shape.max_samples`) and
/// returns what `take` needs of them besides their results; `take(k, kept, results)`
/// gets that and the chunk's results (`shape.out_floats` a sample, or a pixel where
/// `shape.sums` sums them), in chunk order.
/// Adds the seconds of `make` to `times.rays`, of `take` to `times.record`, and the
/// rest (filling the staging buffers, submitting, waiting) to `times.kernel`.
#[allow(clippy::too_many_arguments)]
pub(super) fn stream<S>(
    gpu: &Gpu,
    scene: &Resident,
    pipeline: &wgpu::ComputePipeline,
    shape: Shape,
    uniforms: &[(u32, &[u32])],
    chunks: usize,
    mut make: impl FnMut(usize, &mut Vec<f32>) -> S,
    mut take: impl FnMut(usize, S, &[f32]),
    times: &mut GpuTimes,
) -> Result<(), String> {
    let d = &gpu.device;
    let uniforms: Vec<(u32, wgpu::Buffer)> = uniforms
        .iter()
        .map(|&(k, w)| (k, uniform(d, "uniform", w, wgpu::BufferUsages::empty())))
        .collect();
    let mut slots: Vec<Slot> = Vec::with_capacity(2);
    let mut host: Vec<f32> = Vec::new();
    let mut flight: Option<InFlight<S>> = None;
    for k in 0..chunks {
        let clock = Instant::now();
        host.clear();
        let kept = make(k, &mut host);
        times.rays += clock.elapsed().as_secs_f64();
        let clock = Instant::now();
        let count = host.len() / shape.in_floats.max(1);
        if count > shape.max_samples {
            return Err(format!(
                "{}: a chunk of {count} samples where {} at most were made room for",
                gpu.name, shape.max_samples
            ));
        }
        if shape
            .sums
            .is_some_and(|m| !count.is_multiple_of(m.per_pixel.max(1)))
        {
            return Err(format!(
                "{}: a chunk of {count} samples that are not whole pixels",
                gpu.name
            ));
        }
        let s = k % 2;
        if slots.len() <= s {
            slots.push(make_slot(gpu, scene, pipeline, shape, &uniforms));
        }
        let slot = &slots[s];
        let samples = &host[..count * shape.in_floats];
        let index = submit(gpu, scene, pipeline, slot, shape, samples, count)?;
        // Mapped again once this chunk is done: its results to be read, its staging
        // buffer to be written with the chunk after next.
        let (tx, mapped) = channel();
        let out_bytes = shape.out_bytes(count);
        let mut maps = 0;
        for (buffer, mode) in [
            (slot.staging.slice(..), wgpu::MapMode::Write),
            (slot.readback.slice(..out_bytes.max(4)), wgpu::MapMode::Read),
        ]
        .into_iter()
        .chain(
            slot.timer
                .as_ref()
                .map(|t| (t.read_slice(), wgpu::MapMode::Read)),
        ) {
            let tx = tx.clone();
            buffer.map_async(mode, move |r| {
                let _ = tx.send(r);
            });
            maps += 1;
        }
        let next = InFlight {
            chunk: k,
            slot: s,
            index,
            count,
            kept,
            mapped,
            maps,
        };
        times.kernel += clock.elapsed().as_secs_f64();
        if let Some(before) = flight.replace(next) {
            finish(gpu, scene, &slots, shape, before, &mut take, times)?;
        }
    }
    if let Some(last) = flight {
        finish(gpu, scene, &slots, shape, last, &mut take, times)?;
    }
    let held: u64 = slots
        .iter()
        .map(|s| s.input.size() + s.results.size() + s.sums.as_ref().map_or(0, |m| m.0.size()))
        .sum();
    times.stream_bytes = times.stream_bytes.max(held);
    Ok(())
}

/// A uniform buffer holding `words`, with `more` usages.
fn uniform(d: &wgpu::Device, label: &str, words: &[u32], more: wgpu::BufferUsages) -> wgpu::Buffer {
    use wgpu::util::DeviceExt;
    d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: bytemuck::cast_slice(words),
        usage: wgpu::BufferUsages::UNIFORM | more,
    })
}

/// One slot's buffers, sized for `shape`'s largest chunk, and their bind group.
fn make_slot(
    gpu: &Gpu,
    scene: &Resident,
    pipeline: &wgpu::ComputePipeline,
    shape: Shape,
    uniforms: &[(u32, wgpu::Buffer)],
) -> Slot {
    use wgpu::BufferUsages as U;
    let d = &gpu.device;
    // A buffer of `count` items of `floats` each.
    let buffer = |label: &str, count: usize, floats: usize, usage: U, mapped: bool| {
        d.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: ((count * floats * 4) as u64)
                .max(16)
                .next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT),
            usage,
            mapped_at_creation: mapped,
        })
    };
    let (i, o, n) = (shape.in_floats, shape.out_floats, shape.max_samples);
    let back = shape.returned(n);
    let params = uniform(d, "params", &scene.params, U::COPY_DST);
    let staging = buffer("samples staging", n, i, U::MAP_WRITE | U::COPY_SRC, true);
    let input = buffer("samples", n, i, U::STORAGE | U::COPY_DST, false);
    let results = buffer("results", n, o, U::STORAGE | U::COPY_SRC, false);
    let readback = buffer("readback", back, o, U::MAP_READ | U::COPY_DST, false);
    let sums = shape.sums.map(|m| {
        let sums = buffer("pixel sums", back, o, U::STORAGE | U::COPY_SRC, false);
        let words = sums_words(m, shape, 0);
        let params = uniform(d, "pixel sums", &words, U::COPY_DST);
        let bind = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("pixel sums"),
            layout: &m.pipeline.get_bind_group_layout(0),
            entries: &[
                entry(0, &params),
                entry(1, &results),
                entry(2, &input),
                entry(3, &sums),
            ],
        });
        (sums, params, bind)
    });
    let mut entries = scene.features.grid.entries(&scene.tree, &scene.vals);
    entries.extend([
        entry(0, &params),
        entry(3, &scene.dsm[0]),
        entry(4, &scene.meta),
        entry(5, &input),
        entry(6, &results),
        entry(7, &scene.dsm[1]),
        entry(8, &scene.dsm[2]),
    ]);
    entries.extend(uniforms.iter().map(|(k, b)| entry(*k, b)));
    let bind = d.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("samples"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    });
    Slot {
        params,
        staging,
        input,
        results,
        readback,
        bind,
        sums,
        timer: PassTimer::new(d, gpu.timestamps),
    }
}

/// The words of path_sums.wgsl's `Sums` for a chunk of `pixels` pixels.
fn sums_words(m: Sums, shape: Shape, pixels: usize) -> [u32; 8] {
    let [r, g, b] = m.sigma_t.map(f32::to_bits);
    let word = |v: usize| u32::try_from(v).unwrap_or(u32::MAX);
    [
        r,
        g,
        b,
        0,
        word(pixels),
        word(m.per_pixel),
        word(shape.out_floats),
        word(shape.in_floats),
    ]
}

/// Writes `samples` (`count` of them) into the slot's staging buffer (mapped for
/// writing: at its creation, or by the wait for its chunk before) and submits their
/// copy to the GPU, `pipeline`'s pass over them and their results' copy back.
fn submit(
    gpu: &Gpu,
    scene: &Resident,
    pipeline: &wgpu::ComputePipeline,
    slot: &Slot,
    shape: Shape,
    samples: &[f32],
    count: usize,
) -> Result<wgpu::SubmissionIndex, String> {
    let in_bytes = std::mem::size_of_val(samples) as u64;
    let out_bytes = shape.out_bytes(count);
    {
        let mut view = slot
            .staging
            .slice(..)
            .get_mapped_range_mut()
            .map_err(|e| format!("{}: writing the samples: {e:?}", gpu.name))?;
        write_in_pieces(&mut view, bytemuck::cast_slice(samples));
    }
    slot.staging.unmap();
    let mut params = scene.params.clone();
    params[N_SAMPLES_AT] = count as u32;
    gpu.queue
        .write_buffer(&slot.params, 0, bytemuck::cast_slice(&params));
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    if in_bytes > 0 {
        encoder.copy_buffer_to_buffer(&slot.staging, 0, &slot.input, 0, in_bytes);
    }
    // Encoded for an empty chunk too, so that its timestamps are written.
    let desc = PassTimer::pass(slot.timer.as_ref());
    encode_pass(&mut encoder, &desc, pipeline, &slot.bind, count);
    if let Some(t) = &slot.timer {
        t.resolve(&mut encoder);
    }
    let mut back = &slot.results;
    if let (Some(m), Some((sums, params, bind))) = (shape.sums, &slot.sums) {
        let pixels = shape.returned(count);
        let words = sums_words(m, shape, pixels);
        gpu.queue
            .write_buffer(params, 0, bytemuck::cast_slice(&words));
        encode_pass(&mut encoder, &Default::default(), m.pipeline, bind, pixels);
        back = sums;
    }
    if out_bytes > 0 {
        encoder.copy_buffer_to_buffer(back, 0, &slot.readback, 0, out_bytes);
    }
    Ok(gpu.queue.submit([encoder.finish()]))
}

/// How long a finished chunk's mappings may take to be called back.
const MAP_PATIENCE: std::time::Duration = std::time::Duration::from_secs(30);

/// Waits for chunk `f` to finish, hands its results to `take` straight from their
/// mapping, and leaves its slot's staging buffer mapped for the chunk after next.
fn finish<S>(
    gpu: &Gpu,
    scene: &Resident,
    slots: &[Slot],
    shape: Shape,
    f: InFlight<S>,
    take: &mut impl FnMut(usize, S, &[f32]),
    times: &mut GpuTimes,
) -> Result<(), String> {
    let clock = Instant::now();
    let slot = &slots[f.slot];
    gpu.device
        .poll(wgpu::PollType::Wait {
            submission_index: Some(f.index),
            timeout: None,
        })
        .map_err(|e| format!("{}: {e}", gpu.name))?;
    let failed = |e: &dyn std::fmt::Debug| format!("{}: reading the results back: {e:?}", gpu.name);
    let done = Instant::now();
    for _ in 0..f.maps {
        // The submission is done; its mappings are called back by this wait, or (where
        // another thread polls the device too) by that thread's poll: a driver that
        // never calls back fails the render instead of hanging it.
        let mapped = loop {
            match f.mapped.recv_timeout(std::time::Duration::from_millis(1)) {
                Ok(r) => break r,
                Err(RecvTimeoutError::Timeout) if done.elapsed() > MAP_PATIENCE => {
                    return Err(format!(
                        "{}: the results were not handed back {} s after the GPU finished",
                        gpu.name,
                        MAP_PATIENCE.as_secs()
                    ));
                }
                Err(RecvTimeoutError::Timeout) => {
                    gpu.device
                        .poll(wgpu::PollType::Poll)
                        .map_err(|e| format!("{}: {e}", gpu.name))?;
                }
                Err(e) => return Err(failed(&e)),
            }
        };
        mapped.map_err(|e| failed(&e))?;
    }
    scene.waited.add(Some(clock.elapsed().as_secs_f64()));
    let out_bytes = shape.out_bytes(f.count);
    let took = {
        let view = slot
            .readback
            .slice(..out_bytes.max(4))
            .get_mapped_range()
            .map_err(|e| failed(&e))?;
        let bytes = &view[..out_bytes as usize];
        // A mapping is aligned for its floats; where one were not, they are copied.
        let results: Cow<[f32]> = bytemuck::try_cast_slice(bytes).map_or_else(
            |_| Cow::Owned(bytemuck::pod_collect_to_vec(bytes)),
            Cow::Borrowed,
        );
        let t = Instant::now();
        take(f.chunk, f.kept, &results);
        t.elapsed().as_secs_f64()
    };
    slot.readback.unmap();
    if let Some(t) = &slot.timer {
        scene.busy.add(t.mapped_seconds(&gpu.queue));
    }
    times.record += took;
    times.kernel += clock.elapsed().as_secs_f64() - took;
    Ok(())
}
