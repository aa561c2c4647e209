//! The fast mode's lattice swept on the GPU: a [`Sweeper`] the render hands to
//! [`MsLattice::build_with`](crate::integrate::ms_lattice::MsLattice::build_with) where the
//! frame renders on a GPU. The lattice's densities go up once per light; each order, its
//! source (and the first order's phase weights) go up, every direction is swept plane by
//! plane (sweep.wgsl: one dispatch per plane step, all directions at once), the
//! directions' radiances are averaged per node in the CPU's order, and `J` and `G` come
//! back. What orders are swept, the sources and the tail stay on the CPU.

use super::bind::{entry, size_text};
use super::busy::{BusyTotal, PassTimer};
use super::context::{GROUPS_X, Gpu, WORKGROUP, encode_pass};
use super::readback::{catching_errors, read_mapped, readback_buffer};
use crate::integrate::ms_sweep::{
    DIRECTION_GROUP, OrderJob, OrderMoments, Sweeper, SweptLattice, geometry,
};
use crate::scene::plan::{LatticeDevice, RenderPlan};
use std::sync::Mutex;
use std::time::Instant;
use wgpu::util::DeviceExt;

/// Words of a direction's row in sweep.wgsl's `dirs`.
const DIR_WORDS: usize = 20;
/// Words of `SweepParams`, and where `step` is in it.
const PARAM_WORDS: usize = 16;
const STEP_AT: usize = 8;

/// Whether a frame rendered on `gpu` sweeps its lattice there: `MURK_GPU_LATTICE`
/// (the plan's `lattice`) or, by default, wherever the GPU is not itself run on the CPU.
pub fn sweeps_lattice(gpu: &Gpu, plan: &RenderPlan) -> bool {
    match plan.sampling.lattice {
        LatticeDevice::Auto => !gpu.on_cpu,
        LatticeDevice::Cpu => false,
        LatticeDevice::Gpu => true,
    }
}

/// The sweeps' two pipelines, compiled once per GPU.
struct Pipelines {
    sweep: wgpu::ComputePipeline,
    gather: wgpu::ComputePipeline,
}

fn compile(gpu: &Gpu, entry_point: &str) -> Result<wgpu::ComputePipeline, String> {
    gpu.compile("sweep", &[include_str!("sweep.wgsl")], entry_point)
}

/// The pipelines of `gpu` (a process's GPU lives as long as it: compiled once each).
fn pipelines(gpu: &'static Gpu) -> Result<&'static Pipelines, String> {
    type Compiled = Vec<(usize, Result<&'static Pipelines, String>)>;
    static COMPILED: Mutex<Compiled> = Mutex::new(Vec::new());
    let mut held = COMPILED.lock().map_err(|_| "a poisoned lock")?;
    let address = gpu as *const Gpu as usize;
    if let Some((_, p)) = held.iter().find(|(a, _)| *a == address) {
        return p.clone();
    }
    let p = compile(gpu, "sweep_plane").and_then(|sweep| {
        let gather = compile(gpu, "gather_moments")?;
        Ok(&*Box::leak(Box::new(Pipelines { sweep, gather })))
    });
    held.push((address, p.clone()));
    p
}

/// Seconds of the lattice's work on the GPU.
#[derive(Clone, Copy, Debug, Default)]
pub struct SweepTimes {
    /// Uploads, sweeps, averages and readbacks, all orders and lights.
    pub seconds: f64,
    /// Orders swept on the GPU.
    pub orders: u64,
    /// Of `seconds`: the GPU's own time in the sweeps and averages, where the adapter
    /// times its passes.
    pub kernel: Option<f64>,
}

/// The lattice's sweeps on a GPU, for one render.
pub struct GpuSweeper {
    gpu: &'static Gpu,
    times: Mutex<SweepTimes>,
    /// The GPU's own seconds in the sweeps' and averages' passes.
    busy: BusyTotal,
    /// The first failure (the CPU swept the rest).
    failed: Mutex<Option<String>>,
}

impl GpuSweeper {
    pub fn new(gpu: &'static Gpu) -> Self {
        GpuSweeper {
            gpu,
            times: Mutex::new(SweepTimes::default()),
            busy: BusyTotal::default(),
            failed: Mutex::new(None),
        }
    }

    pub fn times(&self) -> SweepTimes {
        SweepTimes {
            kernel: self.busy.seconds(),
            ..self.times.lock().map(|t| *t).unwrap_or_default()
        }
    }

    /// Why the GPU stopped sweeping, if it did.
    pub fn failure(&self) -> Option<String> {
        self.failed.lock().ok().and_then(|f| f.clone())
    }

    fn fail<T>(&self, r: Result<T, String>) -> Result<T, String> {
        if let Err(e) = &r
            && let Ok(mut f) = self.failed.lock()
        {
            f.get_or_insert_with(|| e.clone());
        }
        r
    }

    fn time(&self, t: Instant, order: bool) {
        if let Ok(mut times) = self.times.lock() {
            times.seconds += t.elapsed().as_secs_f64();
            times.orders += order as u64;
        }
    }
}

impl Sweeper for GpuSweeper {
    fn open(
        &self,
        dims: [usize; 3],
        rho: &[f32],
        channels: usize,
        directions: usize,
    ) -> Result<Box<dyn SweptLattice + '_>, String> {
        let t = Instant::now();
        let opened = self.fail(Lattice::open(self, dims, rho, channels, directions));
        self.time(t, false);
        Ok(Box::new(opened?))
    }

    fn name(&self) -> String {
        format!("gpu: {}", self.gpu.name)
    }
}

/// A lattice's buffers on the GPU.
struct Lattice<'s> {
    owner: &'s GpuSweeper,
    pipes: &'static Pipelines,
    dims: [usize; 3],
    channels: usize,
    directions: usize,
    rho: wgpu::Buffer,
    source: wgpu::Buffer,
    radiance: wgpu::Buffer,
    j: wgpu::Buffer,
    g: wgpu::Buffer,
    /// The plane steps' indices, copied into the parameters before each dispatch.
    steps: wgpu::Buffer,
}

impl<'s> Lattice<'s> {
    fn open(
        owner: &'s GpuSweeper,
        dims: [usize; 3],
        rho: &[f32],
        channels: usize,
        directions: usize,
    ) -> Result<Lattice<'s>, String> {
        let gpu = owner.gpu;
        let nodes = dims.iter().product::<usize>();
        if nodes == 0 || !(1..=3).contains(&channels) || directions == 0 || rho.len() != nodes {
            return Err("an empty lattice".into());
        }
        let max = gpu.max_binding();
        let radiance_bytes = (directions * nodes * channels * 4) as u64;
        if radiance_bytes > max || nodes as u64 * 16 > u32::MAX as u64 {
            return Err(format!(
                "the lattice's radiances ({}) exceed the largest buffer {} binds ({})",
                size_text(radiance_bytes),
                gpu.name,
                size_text(max)
            ));
        }
        let pipes = pipelines(gpu)?;
        let d = &gpu.device;
        let oom = d.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let storage = |label: &str, bytes: usize, usage: wgpu::BufferUsages| {
            d.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes.max(16) as u64,
                usage: wgpu::BufferUsages::STORAGE | usage,
                mapped_at_creation: false,
            })
        };
        let steps: Vec<u32> = (0..dims.iter().copied().max().unwrap_or(0) as u32).collect();
        let lattice = Lattice {
            owner,
            pipes,
            dims,
            channels,
            directions,
            rho: d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("lattice densities"),
                contents: bytemuck::cast_slice(rho),
                usage: wgpu::BufferUsages::STORAGE,
            }),
            source: storage(
                "lattice source",
                nodes * channels * 4,
                wgpu::BufferUsages::COPY_DST,
            ),
            radiance: storage(
                "lattice radiances",
                radiance_bytes as usize,
                wgpu::BufferUsages::empty(),
            ),
            j: storage(
                "lattice J",
                nodes * channels * 4,
                wgpu::BufferUsages::COPY_SRC,
            ),
            g: storage(
                "lattice G",
                nodes * channels * 12,
                wgpu::BufferUsages::COPY_SRC,
            ),
            steps: d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("plane steps"),
                contents: bytemuck::cast_slice(&steps),
                usage: wgpu::BufferUsages::COPY_SRC,
            }),
        };
        if let Some(e) = pollster::block_on(oom.pop()) {
            return Err(format!("{}: out of memory for the lattice ({e})", gpu.name));
        }
        Ok(lattice)
    }

    fn sweep(&self, job: &OrderJob) -> Result<OrderMoments, String> {
        let gpu = self.owner.gpu;
        let d = &gpu.device;
        let (c, nodes) = (self.channels, self.dims.iter().product::<usize>());
        let n_dirs = job.dirs.len();
        let weights_len = if job.weight_stride == 0 {
            n_dirs
        } else {
            nodes * job.weight_stride
        };
        if n_dirs == 0
            || n_dirs > self.directions
            || job.source.len() != nodes * c
            || job.sigma_t.len() < c
            || job.albedo.len() < c
            || job.weights.len() < weights_len
            || (job.weight_stride != 0 && job.weight_stride < n_dirs)
        {
            return Err("an order the lattice was not opened for".into());
        }
        if (job.weights.len() * 4) as u64 > gpu.max_binding() {
            return Err(format!(
                "the first order's phase weights ({}) exceed the largest buffer {} binds",
                size_text(job.weights.len() as u64 * 4),
                gpu.name
            ));
        }
        // The directions' geometry, as the CPU's sweep sets it up.
        let mut dirs = vec![0u32; n_dirs * DIR_WORDS];
        let mut plane_max = 0;
        let mut steps = 0;
        for (row, dir) in dirs.chunks_exact_mut(DIR_WORDS).zip(job.dirs) {
            let s = geometry(*dir, job.h);
            let [a, b, cax] = s.axes;
            plane_max = plane_max.max(self.dims[b] * self.dims[cax]);
            steps = steps.max(self.dims[a]);
            row[..6].copy_from_slice(&[
                a as u32,
                b as u32,
                cax as u32,
                s.forward as u32,
                s.fb as i32 as u32,
                s.fc as i32 as u32,
            ]);
            for (k, w) in s.w.iter().enumerate() {
                row[8 + k] = w.to_bits();
            }
            for ch in 0..c {
                row[12 + ch] = ((job.sigma_t[ch] * s.step) as f32).to_bits();
            }
            for (k, v) in dir.as_vec3().to_array().iter().enumerate() {
                row[16 + k] = v.to_bits();
            }
        }
        let albedo = |ch: usize| job.albedo.get(ch).map_or(0, |a| (*a as f32).to_bits());
        let row = GROUPS_X * WORKGROUP;
        let mut params = [0u32; PARAM_WORDS];
        params.copy_from_slice(&[
            self.dims[0] as u32,
            self.dims[1] as u32,
            self.dims[2] as u32,
            nodes as u32,
            c as u32,
            n_dirs as u32,
            plane_max as u32,
            job.weight_stride as u32,
            0,
            job.flux as u32,
            albedo(0),
            albedo(1),
            albedo(2),
            (1.0 / n_dirs as f32).to_bits(),
            row,
            DIRECTION_GROUP as u32,
        ]);
        let init = |label: &str, contents: &[u8], usage: wgpu::BufferUsages| {
            d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
        };
        let params = init(
            "sweep params",
            bytemuck::cast_slice(&params),
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let weights = init(
            "phase weights",
            bytemuck::cast_slice(&job.weights[..weights_len]),
            wgpu::BufferUsages::STORAGE,
        );
        let dirs = init(
            "directions",
            bytemuck::cast_slice(&dirs),
            wgpu::BufferUsages::STORAGE,
        );
        gpu.queue
            .write_buffer(&self.source, 0, bytemuck::cast_slice(job.source));
        let j_bytes = (nodes * c * 4) as u64;
        let g_bytes = if job.flux { 3 * j_bytes } else { 0 };
        let readback = readback_buffer(d, j_bytes + g_bytes);
        let bind = |p: &wgpu::ComputePipeline, entries: &[(u32, &wgpu::Buffer)]| {
            let entries: Vec<_> = entries.iter().map(|(k, b)| entry(*k, b)).collect();
            d.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("sweep"),
                layout: &p.get_bind_group_layout(0),
                entries: &entries,
            })
        };
        let sweep_bind = bind(
            &self.pipes.sweep,
            &[
                (0, &params),
                (1, &self.rho),
                (2, &self.source),
                (3, &weights),
                (4, &dirs),
                (5, &self.radiance),
            ],
        );
        let gather_bind = bind(
            &self.pipes.gather,
            &[
                (0, &params),
                (4, &dirs),
                (5, &self.radiance),
                (6, &self.j),
                (7, &self.g),
            ],
        );
        let timer = PassTimer::new(d, gpu.timestamps);
        let swept = catching_errors(d, &gpu.name, " sweeping the lattice", || {
            let mut encoder = d.create_command_encoder(&Default::default());
            // Timed from the first sweep's start to the average's end.
            let dispatch = |encoder: &mut wgpu::CommandEncoder,
                            p: &wgpu::ComputePipeline,
                            b: &wgpu::BindGroup,
                            n: usize,
                            (first, last): (bool, bool)| {
                let desc = PassTimer::of_passes(timer.as_ref(), first, last);
                encode_pass(encoder, &desc, p, b, n);
            };
            // Plane after plane: each dispatch reads the plane the one before it wrote.
            for step in 0..steps {
                encoder.copy_buffer_to_buffer(
                    &self.steps,
                    (step * 4) as u64,
                    &params,
                    (STEP_AT * 4) as u64,
                    4,
                );
                dispatch(
                    &mut encoder,
                    &self.pipes.sweep,
                    &sweep_bind,
                    n_dirs * plane_max,
                    (step == 0, false),
                );
            }
            dispatch(
                &mut encoder,
                &self.pipes.gather,
                &gather_bind,
                nodes,
                (steps == 0, true),
            );
            if let Some(t) = &timer {
                t.resolve(&mut encoder);
            }
            encoder.copy_buffer_to_buffer(&self.j, 0, &readback, 0, j_bytes);
            if g_bytes > 0 {
                encoder.copy_buffer_to_buffer(&self.g, 0, &readback, j_bytes, g_bytes);
            }
            gpu.queue.submit([encoder.finish()]);
            let mut moments = OrderMoments {
                j: Vec::new(),
                g: Vec::new(),
            };
            read_mapped(
                d,
                &gpu.name,
                "the lattice",
                &[readback.slice(..)],
                |_, bytes| {
                    let values: &[f32] = bytemuck::cast_slice(bytes);
                    let (j, g) = values.split_at(nodes * c);
                    moments.j = j.to_vec();
                    moments.g = g.to_vec();
                },
            )?;
            Ok(moments)
        });
        if swept.is_ok() {
            self.owner
                .busy
                .add(timer.and_then(|t| t.seconds(&gpu.device, &gpu.queue)));
        }
        swept
    }
}

impl SweptLattice for Lattice<'_> {
    fn order(&mut self, job: &OrderJob) -> Result<OrderMoments, String> {
        let t = Instant::now();
        let swept = self.owner.fail(self.sweep(job));
        self.owner.time(t, swept.is_ok());
        swept
    }
}
