//! The shadow bake's light columns on the GPU: a [`ColumnMarcher`] the render hands to
//! the bake under `--device gpu|auto`. The density grid's nodes are laid out and uploaded
//! once (as for the march); each batch of columns, set up by the bake in f64, goes up as
//! f32 from where each column's march starts, is marched by columns.wgsl (one invocation
//! a column) and read back. What the bake decides stays on the CPU.

use super::bind::entry;
use super::busy::{BusyTotal, PassTimer};
use super::context::{Gpu, encode_pass};
use super::grid_parts::GridBinding;
use super::readback::{buffer_with, catching_errors, read_mapped, readback_buffer, values_of};
use super::upload::{N_SAMPLES_AT, grid_arrays, grid_params};
use crate::field::{Field, VoxelGrid};
use crate::shadow::{BAKE_BATCH_SAMPLES, ColumnJob, ColumnMarcher, MarchedColumns};
use rayon::prelude::*;
use std::sync::Mutex;
use std::time::Instant;
use wgpu::util::DeviceExt;

/// Floats of a column's job (`Job` in columns.wgsl).
const JOB_FLOATS: usize = 32;
/// Storage buffers the column march binds with the grid's arrays whole.
const STORAGE_BUFFERS: u32 = 6;
/// Floats of a sample out: τ, ρ, ∂τ/∂x, ∂τ/∂y, ∂²τ/∂x∂y.
const SAMPLE_FLOATS: usize = 5;
/// The largest |index coordinate| of a column's start and the most voxels it may cross
/// that f32 marches as the CPU does (beyond, the bake marches the column on the CPU):
/// f32 positions there are 6e-5 voxels apart. At 4096 (tiles.vdb's root tile), 2e-4
/// apart, the slopes of τ across the light moved the image by 5.6e-3 relative RMSE.
const F32_REACH: f64 = 1024.0;

/// The environment variable that sets the samples a batch instead (how the benchmark
/// compares batch sizes in one build).
const BATCH_VAR: &str = "MURK_GPU_BAKE_BATCH";

/// Seconds and counts of the bake's work on the GPU.
#[derive(Clone, Copy, Debug, Default)]
pub struct BakeTimes {
    /// Laying the grid's nodes out and uploading them.
    pub upload: f64,
    /// The batches of columns: their f32 layout, upload, march and readback.
    pub columns: f64,
    /// Columns marched on the GPU.
    pub marched: u64,
    /// Of `columns`: the GPU's own time marching them, where the adapter times its
    /// passes.
    pub kernel: Option<f64>,
}

/// The grid uploaded for the columns: which grid (its address, for the render that
/// holds it), its buffers (each whole or in parts, as `grid` says) and parameters.
struct GridOnGpu {
    address: usize,
    tree: Vec<wgpu::Buffer>,
    vals: Vec<wgpu::Buffer>,
    grid: GridBinding,
    params: Vec<u32>,
}

/// The bake's light columns marched on a GPU, for one render.
pub struct GpuColumns {
    gpu: &'static Gpu,
    grid: Mutex<Option<GridOnGpu>>,
    times: Mutex<BakeTimes>,
    /// The GPU's own seconds in the column marches.
    busy: BusyTotal,
    /// The first failure, after which the bake marches on the CPU.
    failed: Mutex<Option<String>>,
    /// The most bytes the grid's arrays bind in one buffer, where lower than the
    /// adapter's largest binding.
    max_binding: Option<u64>,
}

impl GpuColumns {
    pub fn new(gpu: &'static Gpu) -> Self {
        GpuColumns {
            gpu,
            grid: Mutex::new(None),
            times: Mutex::new(BakeTimes::default()),
            busy: BusyTotal::default(),
            failed: Mutex::new(None),
            max_binding: None,
        }
    }

    /// As [`GpuColumns::new`], the grid's arrays laid out as though the adapter's
    /// largest storage binding were `bytes` (where that is lower): cut into parts when
    /// they exceed it. How a test marches the columns over a grid cut into parts, on any
    /// adapter, in a process whose other renders bind it whole.
    pub fn binding_at_most(gpu: &'static Gpu, bytes: u64) -> Self {
        GpuColumns {
            max_binding: Some(bytes),
            ..GpuColumns::new(gpu)
        }
    }

    /// The buffers the grid's node tables and values were uploaded in ([0, 0] before
    /// the first batch).
    pub fn grid_parts(&self) -> [usize; 2] {
        self.grid
            .lock()
            .ok()
            .and_then(|g| g.as_ref().map(|g| [g.tree.len(), g.vals.len()]))
            .unwrap_or([0, 0])
    }

    /// The GPU the columns are marched on.
    pub fn gpu(&self) -> &'static Gpu {
        self.gpu
    }

    pub fn times(&self) -> BakeTimes {
        BakeTimes {
            kernel: self.busy.seconds(),
            ..self.times.lock().map(|t| *t).unwrap_or_default()
        }
    }

    /// Why the GPU stopped marching the bake's columns, if it did.
    pub fn failure(&self) -> Option<String> {
        self.failed.lock().ok().and_then(|f| f.clone())
    }

    fn upload_grid(&self, grid: &VoxelGrid) -> Result<GridOnGpu, String> {
        let nodes = grid
            .nodes()
            .map_err(|_| "a density grid it cannot flatten".to_string())?;
        let arrays = grid_arrays(&nodes);
        let params = grid_params(grid, &nodes, &arrays);
        let mut room = self.gpu.binding_room();
        room.max_binding = room.max_binding.min(self.max_binding.unwrap_or(u64::MAX));
        let layout = GridBinding::choose(
            &room,
            [
                "the density grid's node tables",
                "the density grid's values",
            ],
            arrays.tree.len(),
            arrays.vals.len(),
            STORAGE_BUFFERS,
        )?;
        let make = |label: &str, contents: &[u8]| {
            self.gpu
                .device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents,
                    usage: wgpu::BufferUsages::STORAGE,
                })
        };
        let oom = self
            .gpu
            .device
            .push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let on_gpu = GridOnGpu {
            address: grid as *const VoxelGrid as usize,
            tree: layout
                .parts(&arrays.tree)
                .iter()
                .map(|p| make("tree", bytemuck::cast_slice(p)))
                .collect(),
            vals: layout
                .parts(&arrays.vals)
                .iter()
                .map(|p| make("vals", bytemuck::cast_slice(p)))
                .collect(),
            grid: layout,
            params,
        };
        match pollster::block_on(oom.pop()) {
            Some(e) => Err(format!(
                "{}: out of memory uploading the grid ({e})",
                self.gpu.name
            )),
            None => Ok(on_gpu),
        }
    }

    fn march_on_gpu(
        &self,
        grid: &VoxelGrid,
        jobs: &[ColumnJob],
        depths: &[f64],
    ) -> Result<MarchedColumns, String> {
        let mut held = self.grid.lock().map_err(|_| "a poisoned lock")?;
        let address = grid as *const VoxelGrid as usize;
        if held.as_ref().is_none_or(|g| g.address != address) {
            let t = Instant::now();
            *held = Some(self.upload_grid(grid)?);
            if let Ok(mut times) = self.times.lock() {
                times.upload += t.elapsed().as_secs_f64();
            }
        }
        let on_gpu = held.as_ref().ok_or("no grid")?;
        let t = Instant::now();
        let (packed, taken) = pack(jobs, depths);
        let depths: Vec<f32> = depths.par_iter().map(|&d| d as f32).collect();
        // Batches whose buffers each fit one binding.
        let max = self.gpu.max_binding() as usize;
        let per_batch = (max / (JOB_FLOATS * 4)).clamp(1, 1 << 22);
        // Most often one batch, whose samples are then taken as they are.
        let mut samples = Vec::new();
        let mut done = Vec::with_capacity(jobs.len());
        let mut start = 0;
        while start < jobs.len() {
            let mut end = (start + per_batch).min(jobs.len());
            // Fewer jobs where their samples would not fit a binding.
            let count = |a: usize, b: usize| jobs[a..b].iter().map(|j| j.count).sum::<usize>();
            while end > start + 1 && count(start, end) * SAMPLE_FLOATS * 4 > max {
                end = start + (end - start) / 2;
            }
            let (out, flags) = self.dispatch(on_gpu, &packed, &depths, jobs, start..end)?;
            if samples.is_empty() {
                samples = out;
            } else {
                samples.extend_from_slice(&out);
            }
            done.extend(flags);
            start = end;
        }
        for (d, &ok) in done.iter_mut().zip(&taken) {
            *d &= ok;
        }
        if let Ok(mut times) = self.times.lock() {
            times.columns += t.elapsed().as_secs_f64();
            times.marched += done.iter().filter(|&&d| d).count() as u64;
        }
        Ok(MarchedColumns { samples, done })
    }

    /// Marches jobs `range` (laid out in `packed`); their samples and done flags.
    fn dispatch(
        &self,
        grid: &GridOnGpu,
        packed: &[f32],
        depths: &[f32],
        jobs: &[ColumnJob],
        range: std::ops::Range<usize>,
    ) -> Result<(Vec<[f32; SAMPLE_FLOATS]>, Vec<bool>), String> {
        let gpu = self.gpu;
        let d = &gpu.device;
        let pipeline = gpu.columns_pipeline(grid.grid)?;
        let n = range.len();
        // Each job's first sample out, counted from the batch's first.
        let mut part = packed[range.start * JOB_FLOATS..range.end * JOB_FLOATS].to_vec();
        let mut samples = 0usize;
        for (k, job) in jobs[range].iter().enumerate() {
            part[k * JOB_FLOATS + 11] = f32::from_bits(samples as u32);
            samples += job.count;
        }
        let mut params = grid.params.clone();
        params[N_SAMPLES_AT] = n as u32;
        let storage = |label: &str, contents: &[u8]| {
            buffer_with(d, label, contents, wgpu::BufferUsages::STORAGE)
        };
        let jobs_buf = storage("columns", bytemuck::cast_slice(&part));
        let depths_buf = storage("depths", bytemuck::cast_slice(depths));
        let params = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("params"),
            contents: bytemuck::cast_slice(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        // Written on the GPU only: made there (zeroed by wgpu), never sent up.
        let (out_bytes, flags_bytes) = (
            (samples * SAMPLE_FLOATS * 4).max(16) as u64,
            (n * 4).max(16) as u64,
        );
        let written = |label: &str, bytes: u64| {
            d.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        let out = written("column samples", out_bytes);
        let flags = written("columns done", flags_bytes);
        let mut entries = grid.grid.entries(&grid.tree, &grid.vals);
        entries.extend([
            entry(0, &params),
            entry(9, &jobs_buf),
            entry(10, &depths_buf),
            entry(11, &out),
            entry(12, &flags),
        ]);
        let bind = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("columns"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        });
        let (out_back, flags_back) = (
            readback_buffer(d, out_bytes),
            readback_buffer(d, flags_bytes),
        );
        let mut values = Vec::new();
        let mut done = Vec::with_capacity(n);
        let timer = catching_errors(d, &gpu.name, "", || {
            let mut encoder = d.create_command_encoder(&Default::default());
            let timer = PassTimer::new(&gpu.device, gpu.timestamps);
            let desc = PassTimer::pass(timer.as_ref());
            encode_pass(&mut encoder, &desc, &pipeline, &bind, n);
            if let Some(t) = &timer {
                t.resolve(&mut encoder);
            }
            encoder.copy_buffer_to_buffer(&out, 0, &out_back, 0, out_bytes);
            encoder.copy_buffer_to_buffer(&flags, 0, &flags_back, 0, flags_bytes);
            gpu.queue.submit([encoder.finish()]);
            // Each read straight from the mapped buffer into what the bake takes.
            let backs = [out_back.slice(..out_bytes), flags_back.slice(..flags_bytes)];
            read_mapped(d, &gpu.name, "the columns", &backs, |k, bytes| {
                if k == 0 {
                    values = values_of(bytes, samples);
                } else {
                    let flags: &[u32] = bytemuck::cast_slice(&bytes[..n * 4]);
                    done.extend(flags.iter().map(|&f| f == 1));
                }
            })?;
            Ok(timer)
        })?;
        self.busy
            .add(timer.and_then(|t| t.seconds(&gpu.device, &gpu.queue)));
        Ok((values, done))
    }
}

/// The jobs as columns.wgsl reads them (f32, each from where its march starts), and
/// which of them f32 can march: a job too far out or too long is sent with no depths
/// and marched by the bake on the CPU.
fn pack(jobs: &[ColumnJob], depths: &[f64]) -> (Vec<f32>, Vec<bool>) {
    let mut packed = vec![0f32; jobs.len() * JOB_FLOATS];
    let mut taken = vec![true; jobs.len()];
    let each = jobs
        .par_iter()
        .zip(packed.par_chunks_exact_mut(JOB_FLOATS))
        .zip(taken.par_iter_mut());
    each.for_each(|((job, out), ok)| {
        let r = job.ray;
        let s = job.side;
        let vectors = [
            r.origin, r.dir, s.a.base, s.a.rate, s.b.base, s.b.rate, s.c.base, s.c.rate,
        ];
        for (k, v) in vectors.iter().enumerate() {
            out[k * 4..k * 4 + 3].copy_from_slice(&v.as_vec3().to_array());
        }
        let reach = r.origin.abs().max_element();
        // The voxels it crosses, to its last depth (depths ascend).
        let last = match job.count {
            0 => 0.0,
            n => depths
                .get(job.first + n - 1)
                .copied()
                .unwrap_or(f64::INFINITY),
        };
        let cells = r.dir.abs().element_sum() * last.max(0.0);
        let finite = vectors.iter().all(|v| v.is_finite());
        *ok = finite && reach < F32_REACH && cells < F32_REACH;
        out[3] = f32::from_bits(job.first as u32);
        out[7] = f32::from_bits(if *ok { job.count as u32 } else { 0 });
    });
    (packed, taken)
}

impl ColumnMarcher for GpuColumns {
    fn takes(&self, density: &dyn Field) -> bool {
        let free = self.failed.lock().is_ok_and(|f| f.is_none());
        free && density
            .as_voxel_grid()
            .is_some_and(|g| g.nodes_check().is_ok())
    }

    /// The bake's own batch ([`BAKE_BATCH_SAMPLES`]), or [`BATCH_VAR`]'s. On an NVIDIA
    /// H200 sixteen times as many samples a batch (fewer, fuller dispatches: the kernel
    /// 12 ms against 90 ms) took the light columns twice as long in all (0.43–0.49 s
    /// against 0.22–0.23 s), four times as many 0.39–0.41 s. What grows with the batch
    /// is the work around the kernel (the batch's set-up, its read-back, the CPU's
    /// passes over arrays of up to 168 MB), and not the buffers' allocation: buffers
    /// kept and lent again between batches did not change it.
    fn batch_samples(&self) -> usize {
        std::env::var(BATCH_VAR)
            .ok()
            .and_then(|v| v.trim().parse::<usize>().ok())
            .filter(|&n| n > 0)
            .unwrap_or(BAKE_BATCH_SAMPLES)
    }

    fn march(
        &self,
        density: &dyn Field,
        jobs: &[ColumnJob],
        depths: &[f64],
    ) -> Result<MarchedColumns, String> {
        let grid = density
            .as_voxel_grid()
            .ok_or("a density that is not a voxel grid")?;
        let marched = self.march_on_gpu(grid, jobs, depths);
        if let Err(e) = &marched
            && let Ok(mut f) = self.failed.lock()
        {
            f.get_or_insert_with(|| e.clone());
        }
        marched
    }
}
