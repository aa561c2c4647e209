//! Buffers a GPU stage needs for one dispatch only (the results it writes and the
//! host-visible buffers they are read back through), kept by the process's GPU once
//! given back and lent again to the next dispatch that needs one as large. A bake's
//! batches, the march after the bake and a sequence's frames then do not each allocate
//! them anew: on an NVIDIA H200 the bake's light columns spent 12 ms in their kernel and
//! 0.45 s around it, most of it in buffers of up to 168 MB made for every batch.

use std::sync::Mutex;

/// The most bytes kept spare: a buffer given back beyond it is freed.
const KEPT_BYTES: u64 = 1 << 30;

/// Buffers given back, free to lend.
#[derive(Default)]
pub(super) struct BufferPool {
    free: Mutex<Vec<wgpu::Buffer>>,
}

/// A buffer lent by a [`BufferPool`], given back when dropped. Drop it only once the
/// GPU is done with it (after the read-back of the work that used it).
pub(super) struct Lent<'a> {
    buffer: Option<wgpu::Buffer>,
    pool: &'a BufferPool,
}

impl std::ops::Deref for Lent<'_> {
    type Target = wgpu::Buffer;
    fn deref(&self) -> &wgpu::Buffer {
        self.buffer
            .as_ref()
            .expect("a lent buffer is held until dropped")
    }
}

impl Drop for Lent<'_> {
    fn drop(&mut self) {
        if let (Some(b), Ok(mut free)) = (self.buffer.take(), self.pool.free.lock()) {
            let kept: u64 = free.iter().map(|f| f.size()).sum();
            if kept + b.size() <= KEPT_BYTES {
                free.push(b);
            }
        }
    }
}

impl BufferPool {
    /// A buffer for `usage` of at least `bytes` and at most `most` bytes (a binding's
    /// limit, for a buffer bound whole; `most` ≥ `bytes`): the least such buffer given
    /// back, else a new one of `bytes` rounded up to a power of two (within `most`), so
    /// that sizes that vary from batch to batch reuse a few buffers. A shader bound to
    /// it reads only the elements its parameters count, not its length.
    pub fn lend<'a>(
        &'a self,
        device: &wgpu::Device,
        label: &str,
        usage: wgpu::BufferUsages,
        bytes: u64,
        most: u64,
    ) -> Lent<'a> {
        let bytes = bytes.max(16).next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT);
        let fits = |b: &wgpu::Buffer| b.usage() == usage && b.size() >= bytes && b.size() <= most;
        let reused = self.free.lock().ok().and_then(|mut free| {
            let least = (0..free.len())
                .filter(|&k| fits(&free[k]))
                .min_by_key(|&k| free[k].size())?;
            Some(free.swap_remove(least))
        });
        let buffer = reused.unwrap_or_else(|| {
            let size = bytes.next_power_of_two().min(most).max(bytes);
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        });
        Lent {
            buffer: Some(buffer),
            pool: self,
        }
    }
}
