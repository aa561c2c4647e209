//! The GPU: an adapter found through wgpu (Vulkan, Metal or DX12), its device with the
//! limits the adapter reports, the compute pipelines compiled for it, and the upload of
//! a scene's buffers (the samples stream through them: stream.rs).

use super::bind::size_text;
use super::busy::BusyTotal;
use super::grid_parts::{BindingRoom, GridBinding};
use super::resident::{KeptBuffers, Making};
use super::upload::{Buffers, DSM_BUFFERS, MarchFeatures};

/// An opened GPU and the pipelines compiled for it.
pub struct Gpu {
    pub(super) device: wgpu::Device,
    pub(super) queue: wgpu::Queue,
    /// The march, compiled on first use for each set of the parts a scene uses.
    marches: std::sync::Mutex<Vec<(MarchFeatures, wgpu::ComputePipeline)>>,
    /// The shadow bake's column march, compiled on first use for each layout of the
    /// grid's arrays.
    columns: Pipelines,
    /// The path tracer (path.wgsl), compiled on first use for each layout.
    pub(super) path: Pipelines,
    /// The sums of each pixel's paths (path_sums.wgsl), compiled on first use.
    pub(super) path_sums: std::sync::Mutex<Option<wgpu::ComputePipeline>>,
    /// The adapter as it names itself, its device type and backend.
    pub name: String,
    pub limits: wgpu::Limits,
    /// A device that runs on the CPU (Mesa's lavapipe, SwiftShader, WARP): `--device
    /// auto` does not take it, as murk's own CPU path renders faster, unless it was
    /// asked for by name (`named`).
    pub on_cpu: bool,
    /// The adapter was picked by name (`WGPU_ADAPTER_NAME`).
    pub named: bool,
    /// The device writes timestamps around compute passes ([`PassTimer`]).
    pub timestamps: bool,
    /// Seconds opening it took (finding the adapter, opening the device), until the
    /// first render's stats take them ([`Gpu::take_open_seconds`]).
    open_seconds: std::sync::Mutex<Option<f64>>,
}

/// The environment variable that lowers the largest buffer the GPU binds to this many
/// bytes: how a test makes a scene that fits any real GPU not fit.
pub const MAX_BINDING_VAR: &str = "MURK_GPU_MAX_BINDING";

/// The environment variable (set to 1) under which a grid cut into parts is marched
/// with shadow rays and path traced on an adapter that runs on the CPU, where they are
/// otherwise refused (lavapipe compiles the first wrongly and did not finish the
/// second; a real GPU renders both bit for bit as whole): how such a driver is checked
/// again.
pub const CUT_ANYWAY_VAR: &str = "MURK_GPU_CUT_ANYWAY";

/// Whether a grid cut into parts is refused under marched shadow rays and the path
/// tracer on `gpu`: on an adapter that runs on the CPU, unless [`CUT_ANYWAY_VAR`] asks.
pub(super) fn refuses_cut_grids(gpu: &Gpu) -> bool {
    gpu.on_cpu && !std::env::var(CUT_ANYWAY_VAR).is_ok_and(|v| v.trim() == "1")
}

/// What the march and the column march share (WGSL has no include): the parameters,
/// the grid's nodes and their lookups, rays and the voxel-cell walk; compiled before
/// each one's own source.
pub(super) const GRID_WGSL: &str = include_str!("grid.wgsl");

/// Pipelines compiled for a layout of the grid's arrays, each with its layout.
pub(super) type Pipelines = std::sync::Mutex<Vec<(GridBinding, wgpu::ComputePipeline)>>;

/// The march's sources after grid.wgsl and the arrays' accessors, in the order they are
/// compiled (the path tracer's follow).
pub(super) const MARCH_WGSL: [&str; 6] = [
    include_str!("march.wgsl"),
    include_str!("rays.wgsl"),
    include_str!("dsm.wgsl"),
    include_str!("lattice.wgsl"),
    include_str!("emission.wgsl"),
    include_str!("toward_light.wgsl"),
];

/// Storage buffers the march binds with the grid's arrays whole.
pub(super) const STORAGE_BUFFERS: u32 = 8;
/// Invocations per workgroup (`@workgroup_size` in march.wgsl).
pub(super) const WORKGROUP: u32 = 64;
/// Workgroups per dispatch dimension (WebGPU's least limit; the shader spreads a
/// larger dispatch over y).
pub(super) const GROUPS_X: u32 = 65535;

/// Encodes one compute pass (described by `desc`, which says where its timestamps go):
/// `pipeline` bound to `bind`, one invocation for each of `invocations`, in workgroups
/// of [`WORKGROUP`] over x, [`GROUPS_X`] at most, then over y (each shader takes its
/// index as `id.x + id.y * 65535 * 64`).
pub(super) fn encode_pass(
    encoder: &mut wgpu::CommandEncoder,
    desc: &wgpu::ComputePassDescriptor<'_>,
    pipeline: &wgpu::ComputePipeline,
    bind: &wgpu::BindGroup,
    invocations: usize,
) {
    let mut pass = encoder.begin_compute_pass(desc);
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, bind, &[]);
    let groups = (invocations as u32).div_ceil(WORKGROUP);
    pass.dispatch_workgroups(groups.min(GROUPS_X), groups.div_ceil(GROUPS_X), 1);
}

impl Gpu {
    /// The process's GPU, opened on first use and kept for every later render (with the
    /// pipelines compiled for it): a sequence's frames, or a test binary's renders, open
    /// it once.
    pub fn shared() -> Result<&'static Gpu, String> {
        static GPU: std::sync::OnceLock<Result<Gpu, String>> = std::sync::OnceLock::new();
        GPU.get_or_init(Gpu::open).as_ref().map_err(Clone::clone)
    }

    /// The seconds opening this GPU took, once: the stats' `gpu_open` of the render
    /// that opened it (a sequence's later frames, or a test binary's later renders, did
    /// not pay them).
    pub fn take_open_seconds(&self) -> Option<f64> {
        self.open_seconds.lock().ok().and_then(|mut s| s.take())
    }

    /// The first high-performance adapter wgpu finds, or why there is none.
    pub fn open() -> Result<Gpu, String> {
        let clock = std::time::Instant::now();
        let backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends,
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        // WGPU_ADAPTER_NAME picks an adapter by name; else the high-performance one.
        let (adapter, named) = pollster::block_on(async {
            match wgpu::util::initialize_adapter_from_env(&instance, None).await {
                Ok(a) => Ok((a, true)),
                Err(_) => instance
                    .request_adapter(&wgpu::RequestAdapterOptions {
                        power_preference: wgpu::PowerPreference::HighPerformance,
                        ..Default::default()
                    })
                    .await
                    .map(|a| (a, false)),
            }
        })
        .map_err(|e| format!("no GPU adapter found ({e})"))?;
        let info = adapter.get_info();
        let name = format!("{} ({:?}, {:?})", info.name, info.device_type, info.backend);
        let mut limits = adapter.limits();
        if let Some(cap) = std::env::var(MAX_BINDING_VAR)
            .ok()
            .and_then(|v| v.trim().parse::<u64>().ok())
        {
            // Lower limits are always valid to ask a device for.
            limits.max_storage_buffer_binding_size =
                limits.max_storage_buffer_binding_size.min(cap);
            limits.max_buffer_size = limits.max_buffer_size.min(cap);
        }
        if limits.max_storage_buffers_per_shader_stage < STORAGE_BUFFERS {
            return Err(format!(
                "{name} binds {} storage buffers per shader, the march needs {STORAGE_BUFFERS}",
                limits.max_storage_buffers_per_shader_stage
            ));
        }
        // Timestamps around the kernels, where the adapter has them: the stats' kernel
        // seconds.
        let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("murk"),
            required_features: if timestamps {
                wgpu::Features::TIMESTAMP_QUERY
            } else {
                wgpu::Features::empty()
            },
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| format!("{name}: cannot open the device ({e})"))?;
        Ok(Gpu {
            device,
            queue,
            marches: std::sync::Mutex::new(Vec::new()),
            columns: Pipelines::default(),
            path: Pipelines::default(),
            path_sums: std::sync::Mutex::new(None),
            name,
            limits,
            on_cpu: info.device_type == wgpu::DeviceType::Cpu,
            named,
            timestamps,
            open_seconds: std::sync::Mutex::new(Some(clock.elapsed().as_secs_f64())),
        })
    }

    /// The march compiled for the parts `features` (march.wgsl's overrides), on first
    /// use.
    pub(super) fn march_pipeline(
        &self,
        features: MarchFeatures,
    ) -> Result<wgpu::ComputePipeline, String> {
        let mut held = self.marches.lock().map_err(|_| "a poisoned lock")?;
        if let Some((_, p)) = held.iter().find(|(f, _)| *f == features) {
            return Ok(p.clone());
        }
        let constants = features.constants();
        let accessors = features.grid.wgsl();
        let mut sources = vec![GRID_WGSL, &accessors];
        sources.extend(MARCH_WGSL);
        let pipeline = compile_with(
            &self.device,
            &self.name,
            "march",
            &sources,
            "march_samples",
            &constants,
        )?;
        held.push((features, pipeline.clone()));
        Ok(pipeline)
    }

    /// The shadow bake's column march (columns.wgsl, after grid.wgsl) for the grid's
    /// arrays laid out as `grid`, compiled on first use.
    pub(super) fn columns_pipeline(
        &self,
        grid: GridBinding,
    ) -> Result<wgpu::ComputePipeline, String> {
        self.cached(&self.columns, grid, |accessors| {
            let sources = [GRID_WGSL, accessors, include_str!("columns.wgsl")];
            self.compile("column march", &sources, "march_columns")
        })
    }

    /// The pipeline `pipelines` holds for `grid`, else the one `compile` makes from the
    /// layout's accessors (kept for the next use).
    pub(super) fn cached(
        &self,
        pipelines: &Pipelines,
        grid: GridBinding,
        compile: impl FnOnce(&str) -> Result<wgpu::ComputePipeline, String>,
    ) -> Result<wgpu::ComputePipeline, String> {
        let mut held = pipelines.lock().map_err(|_| "a poisoned lock")?;
        if let Some((_, p)) = held.iter().find(|(g, _)| *g == grid) {
            return Ok(p.clone());
        }
        let pipeline = compile(&grid.wgsl())?;
        held.push((grid, pipeline.clone()));
        Ok(pipeline)
    }

    /// Compiles `sources` (WGSL, in this order) into a compute pipeline entered at
    /// `entry`; `label` names it, and what does not compile in the error.
    pub(super) fn compile(
        &self,
        label: &str,
        sources: &[&str],
        entry: &str,
    ) -> Result<wgpu::ComputePipeline, String> {
        compile_with(&self.device, &self.name, label, sources, entry, &[])
    }

    /// What the adapter binds, for [`GridBinding::choose`].
    pub(super) fn binding_room(&self) -> BindingRoom<'_> {
        BindingRoom {
            adapter: &self.name,
            max_binding: self.max_binding(),
            storage_buffers: self.limits.max_storage_buffers_per_shader_stage,
        }
    }

    /// The most bytes one storage buffer may bind.
    pub fn max_binding(&self) -> u64 {
        self.limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size)
    }

    /// Uploads a scene's buffers, checking each against the adapter's limits first
    /// (the shadow maps are already split, see [`Buffers::split_maps`]; the grid's
    /// arrays are cut into parts here where they exceed one binding, see
    /// [`GridBinding::choose`]), and the uploads against running out of memory. With `kept` (a
    /// sequence's), a buffer whose bytes the frame before uploaded is bound as it is, and
    /// this frame's buffers are kept for the next. Returns the bytes uploaded with them.
    pub fn upload(
        &self,
        b: &Buffers,
        kept: Option<&mut KeptBuffers>,
    ) -> Result<(Resident, u64), String> {
        let max = self.max_binding();
        let [tree_name, vals_name, ..] = b.sizes().map(|(what, _)| what);
        let grid = GridBinding::choose(
            &self.binding_room(),
            [tree_name, vals_name],
            b.tree.len(),
            b.vals.len(),
            STORAGE_BUFFERS,
        )?;
        if grid != GridBinding::Whole && b.features.marched && refuses_cut_grids(self) {
            // On lavapipe this pipeline leaves some camera rays early: the walk's loop
            // ends without taking its one exit, at rays that change with the driver's
            // vector width and with unrelated code (a miscompile; every index it reads
            // is in bounds, the shadow-map march and the bake's columns over the same
            // cut arrays are bit for bit the whole grid's, and so is this march on an
            // NVIDIA GPU). Refused there rather than rendered wrong.
            return Err(format!(
                "the grids' arrays exceed the largest buffer {} binds ({}), and a grid cut \
                 into parts is not marched with shadow rays (--shadows march) on an \
                 adapter that runs on the CPU",
                self.name,
                size_text(max)
            ));
        }
        for (what, bytes) in b.sizes().into_iter().skip(2) {
            if bytes > max {
                let total = match what {
                    "the shadow maps" => format!(
                        "{}, in {DSM_BUFFERS} buffers of {}",
                        size_text(b.dsm.len() as u64 * 4),
                        size_text(bytes)
                    ),
                    _ => size_text(bytes),
                };
                return Err(format!(
                    "{what} ({total}) exceed the largest buffer {} binds ({})",
                    self.name,
                    size_text(max)
                ));
            }
        }
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut making = Making::new(kept);
        let mut make = |label: &str, contents: &[u8]| making.buffer(&self.device, label, contents);
        let tree = grid.parts(&b.tree);
        let vals = grid.parts(&b.vals);
        let resident = Resident {
            tree: tree
                .iter()
                .map(|p| make("tree", bytemuck::cast_slice(p)))
                .collect(),
            vals: vals
                .iter()
                .map(|p| make("vals", bytemuck::cast_slice(p)))
                .collect(),
            dsm: std::array::from_fn(|k| make("dsm", bytemuck::cast_slice(&b.dsm_part(k)))),
            meta: make("meta", bytemuck::cast_slice(&b.meta)),
            params: b.params.clone(),
            stride: b.stride,
            features: MarchFeatures { grid, ..b.features },
            busy: BusyTotal::default(),
            waited: BusyTotal::default(),
        };
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(format!("{}: uploading the scene: {e}", self.name));
        }
        if let Some(e) = pollster::block_on(oom.pop()) {
            let words = b.tree.len() + b.vals.len() + b.dsm.len() + b.meta.len();
            return Err(format!(
                "{}: out of memory uploading the scene ({}: {e})",
                self.name,
                size_text(words as u64 * 4)
            ));
        }
        Ok((resident, making.finish()))
    }
}

/// [`Gpu::compile`] on `device` (of the adapter `name`), with the sources' overrides
/// set to `constants` (the others keep their defaults).
fn compile_with(
    device: &wgpu::Device,
    name: &str,
    label: &str,
    sources: &[&str],
    entry: &str,
    constants: &[(&str, f64)],
) -> Result<wgpu::ComputePipeline, String> {
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(sources.join("\n").into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: None,
        module: &module,
        entry_point: Some(entry),
        compilation_options: wgpu::PipelineCompilationOptions {
            constants,
            ..Default::default()
        },
        cache: None,
    });
    match pollster::block_on(scope.pop()) {
        Some(e) => Err(format!("{name}: the {label} does not compile ({e})")),
        None => Ok(pipeline),
    }
}

/// A scene's buffers on the GPU.
pub struct Resident {
    /// The grids' node tables and values, each in one buffer or in parts
    /// (`features.grid`).
    pub(super) tree: Vec<wgpu::Buffer>,
    pub(super) vals: Vec<wgpu::Buffer>,
    /// The shadow maps, in [`DSM_BUFFERS`] parts.
    pub(super) dsm: [wgpu::Buffer; DSM_BUFFERS],
    pub(super) meta: wgpu::Buffer,
    pub(super) params: Vec<u32>,
    /// Floats per sample in the results.
    pub stride: u32,
    /// The march's parts the scene uses and its arrays' layout (the pipeline it is
    /// marched with).
    pub(super) features: MarchFeatures,
    /// The GPU's own seconds in the passes run over these buffers.
    pub(super) busy: BusyTotal,
    /// Seconds the CPU waited for those passes, from each submission to its results
    /// mapped: the GPU's work, its copies to and from the host, and their scheduling.
    pub(super) waited: BusyTotal,
}

impl Resident {
    /// The buffers the grids' node tables and their values went in.
    pub fn grid_parts(&self) -> [usize; 2] {
        [self.tree.len(), self.vals.len()]
    }
}
