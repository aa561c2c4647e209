//! How the GPU's stages that dispatch work and read its results back (the bake's
//! columns, the lattice's sweeps, the pass timer, the test probe) wait for them, and
//! how every stage (the march's and the path tracer's stream too) catches what went
//! wrong and fills and reads large mapped buffers: one way, with one wording.

/// A buffer of `bytes` that results are copied into for [`read_mapped`].
pub(super) fn readback_buffer(device: &wgpu::Device, bytes: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: bytes,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// Maps `buffers` (slices of buffers made by [`readback_buffer`] or lent for reading
/// back, their copies already submitted), waits for the device, and hands each one's
/// bytes to `take` with its index in `buffers`, unmapping it after. An error names the
/// adapter (`adapter`) and what was read (`what`).
pub(super) fn read_mapped(
    device: &wgpu::Device,
    adapter: &str,
    what: &str,
    buffers: &[wgpu::BufferSlice<'_>],
    mut take: impl FnMut(usize, &[u8]),
) -> Result<(), String> {
    let (tx, rx) = std::sync::mpsc::channel();
    for b in buffers {
        let tx = tx.clone();
        b.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
    }
    drop(tx);
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| format!("{adapter}: {e}"))?;
    let failed = |e: &dyn std::fmt::Display| format!("{adapter}: reading {what} back: {e}");
    for _ in buffers {
        match rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(failed(&e)),
            Err(e) => return Err(failed(&e)),
        }
    }
    for (k, b) in buffers.iter().enumerate() {
        let view = b
            .get_mapped_range()
            .map_err(|e| failed(&format!("{e:?}")))?;
        take(k, &view);
        drop(view);
        b.buffer().unmap();
    }
    Ok(())
}

/// Runs `work` (GPU work, with its results read back) inside error scopes: an
/// allocation that failed in it (`doing` says during what, after "out of memory"), else
/// a validation error it raised, is the error rather than what `work` returned, which
/// is most often only that error's consequence.
pub(super) fn catching_errors<T>(
    device: &wgpu::Device,
    adapter: &str,
    doing: &str,
    work: impl FnOnce() -> Result<T, String>,
) -> Result<T, String> {
    let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let oom = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let result = work();
    if let Some(e) = pollster::block_on(oom.pop()) {
        return Err(format!("{adapter}: out of memory{doing} ({e})"));
    }
    if let Some(e) = pollster::block_on(validation.pop()) {
        return Err(format!("{adapter}: {e}"));
    }
    result
}

/// Bytes each thread copies at a time into a mapped buffer: small enough that a
/// stream's chunk of samples (16 MB) spreads over every thread.
const COPY_PIECE: usize = 1 << 20;

/// Bytes each thread copies at a time out of a mapped buffer: small enough that a
/// bake's batch (about 10 MB) spreads over every thread.
const OUT_PIECE: usize = 1 << 18;

/// The first `n` values of mapped bytes, copied out on all threads
/// ([`crate::mem::concat_on_all_threads`]): a 4K frame's results or a bake's batch of
/// column samples are tens to hundreds of megabytes.
pub(super) fn values_of<T: bytemuck::Pod + Send + Sync>(bytes: &[u8], n: usize) -> Vec<T> {
    let from: &[T] = bytemuck::cast_slice(&bytes[..n * std::mem::size_of::<T>()]);
    crate::mem::concat_on_all_threads(&[from], OUT_PIECE / std::mem::size_of::<T>().max(1))
}

/// A buffer for `usage` holding `contents` (zero-padded to at least 16 bytes), written
/// into its mapping at creation on all threads: wgpu's `create_buffer_init` copies on
/// the calling thread alone, which for a scene's maps or a 4K frame's samples is
/// hundreds of megabytes.
pub(super) fn buffer_with(
    device: &wgpu::Device,
    label: &str,
    contents: &[u8],
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    let size = (contents.len() as u64)
        .max(16)
        .next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT);
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage,
        mapped_at_creation: true,
    });
    {
        // Mapped at creation, a buffer starts zeroed: only `contents` are written.
        let Ok(mut view) = buffer.slice(..).get_mapped_range_mut() else {
            // (Not seen: a buffer mapped at creation maps whole.) wgpu's own way, then.
            use wgpu::util::DeviceExt;
            return device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            });
        };
        write_in_pieces(&mut view, contents);
    }
    buffer.unmap();
    buffer
}

/// Writes `contents` at the start of `view` (a buffer mapped for writing) on all
/// threads, in pieces of [`COPY_PIECE`] bytes.
pub(super) fn write_in_pieces(view: &mut wgpu::BufferViewMut, contents: &[u8]) {
    use rayon::prelude::*;
    let (pieces, mut tail) = view.slice(..contents.len()).into_chunks::<COPY_PIECE>();
    let pieces: Vec<wgpu::WriteOnly<'_, [u8; COPY_PIECE]>> = pieces.into_iter().collect();
    let whole = pieces.len() * COPY_PIECE;
    pieces
        .into_par_iter()
        .zip(contents[..whole].par_chunks_exact(COPY_PIECE))
        .for_each(|(piece, from)| wgpu::WriteOnly::<'_, [u8]>::from(piece).copy_from_slice(from));
    tail.copy_from_slice(&contents[whole..]);
}
