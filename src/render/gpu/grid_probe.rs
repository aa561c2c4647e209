//! The grid's arrays read back through the accessors the shaders use, for the tests of
//! the parts' boundaries ([`GridBinding`]).

use super::bind::entry;
use super::context::{Gpu, encode_pass};
use super::grid_parts::GridBinding;
use super::readback::{read_mapped, readback_buffer};

/// Every word of `tree` and `vals` read back through `tree_at` and `val_at` compiled for
/// `binding` on `gpu` (each array uploaded in that layout's parts): what the shaders see
/// at each index, for the tests of the parts' boundaries.
#[doc(hidden)]
pub fn read_back(
    gpu: &Gpu,
    binding: GridBinding,
    tree: &[u32],
    vals: &[f32],
) -> Result<(Vec<u32>, Vec<f32>), String> {
    use wgpu::util::DeviceExt;
    let d = &gpu.device;
    let (nt, nv) = (tree.len(), vals.len());
    let probe = format!(
        "@group(0) @binding(0) var<storage, read_write> words: array<u32>;\n\
         @compute @workgroup_size(64)\n\
         fn read_back(@builtin(global_invocation_id) id: vec3<u32>) {{\n\
         let i = id.x + id.y * 65535u * 64u;\n\
         if (i < {nt}u) {{ words[i] = tree_at(i); }}\n\
         if (i < {nv}u) {{ words[{nt}u + i] = bitcast<u32>(val_at(i)); }}\n}}\n"
    );
    let accessors = binding.wgsl();
    let pipeline = gpu.compile("read back", &[&accessors, &probe], "read_back")?;
    let upload = |label: &str, bytes: &[u8], usage| {
        d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytes,
            usage,
        })
    };
    let storage = wgpu::BufferUsages::STORAGE;
    let tree: Vec<_> = binding
        .parts(tree)
        .iter()
        .map(|p| upload("tree", bytemuck::cast_slice(p), storage))
        .collect();
    let vals: Vec<_> = binding
        .parts(vals)
        .iter()
        .map(|p| upload("vals", bytemuck::cast_slice(p), storage))
        .collect();
    let bytes = 4 * (nt + nv) as u64;
    // Every word is written by the probe (the GPU zeroes a new buffer).
    let out = d.create_buffer(&wgpu::BufferDescriptor {
        label: Some("words"),
        size: bytes,
        usage: storage | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let back = readback_buffer(d, bytes);
    let mut entries = binding.entries(&tree, &vals);
    entries.push(entry(0, &out));
    let bind = d.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("read back"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    });
    let mut encoder = d.create_command_encoder(&Default::default());
    encode_pass(
        &mut encoder,
        &Default::default(),
        &pipeline,
        &bind,
        nt.max(nv),
    );
    encoder.copy_buffer_to_buffer(&out, 0, &back, 0, bytes);
    gpu.queue.submit([encoder.finish()]);
    let mut words: Vec<u32> = Vec::new();
    read_mapped(d, &gpu.name, "the words", &[back.slice(..)], |_, bytes| {
        words = bytemuck::cast_slice(bytes).to_vec();
    })?;
    let vals = words[nt..].iter().map(|&w| f32::from_bits(w)).collect();
    Ok((words[..nt].to_vec(), vals))
}
