//! How long the GPU itself ran a compute pass, from timestamp queries written at the
//! pass's start and end (where the adapter has them, wgpu's `TIMESTAMP_QUERY`): the
//! stats' `*_kernel` seconds, which tell the kernels' own time from the uploads,
//! readbacks and CPU work around them that the wall-clock stages also hold.

use super::readback::read_mapped;
use std::sync::atomic::{AtomicU64, Ordering};

/// Two timestamps around one compute pass, resolved into a buffer the CPU reads.
pub(super) struct PassTimer {
    set: wgpu::QuerySet,
    resolved: wgpu::Buffer,
    read: wgpu::Buffer,
}

/// Bytes of the two resolved timestamps.
const STAMP_BYTES: u64 = 16;

impl PassTimer {
    /// A timer for one pass on `d`, or `None` where it writes no timestamps (`stamps`).
    pub fn new(d: &wgpu::Device, stamps: bool) -> Option<Self> {
        if !stamps {
            return None;
        }
        let buffer = |label: &str, usage: wgpu::BufferUsages| {
            d.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: STAMP_BYTES,
                usage,
                mapped_at_creation: false,
            })
        };
        Some(PassTimer {
            set: d.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass timer"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            }),
            resolved: buffer(
                "pass timestamps",
                wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            ),
            read: buffer(
                "pass timestamps read",
                wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            ),
        })
    }

    /// The pass's descriptor, with its timestamps written where `timer` is one.
    pub fn pass(timer: Option<&PassTimer>) -> wgpu::ComputePassDescriptor<'_> {
        PassTimer::of_passes(timer, true, true)
    }

    /// The descriptor of one of several passes timed together, from the first's start
    /// (`first`) to the last's end (`last`), where `timer` is one.
    pub fn of_passes(
        timer: Option<&PassTimer>,
        first: bool,
        last: bool,
    ) -> wgpu::ComputePassDescriptor<'_> {
        wgpu::ComputePassDescriptor {
            label: None,
            timestamp_writes: timer.filter(|_| first || last).map(|t| {
                wgpu::ComputePassTimestampWrites {
                    query_set: &t.set,
                    beginning_of_pass_write_index: first.then_some(0),
                    end_of_pass_write_index: last.then_some(1),
                }
            }),
        }
    }

    /// Resolves the timestamps after the pass, for [`PassTimer::seconds`] to read once
    /// the encoder's work is done.
    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.resolve_query_set(&self.set, 0..2, &self.resolved, 0);
        encoder.copy_buffer_to_buffer(&self.resolved, 0, &self.read, 0, STAMP_BYTES);
    }

    /// Seconds between the pass's start and end; call after the submission it was
    /// resolved in has finished. `None` if they cannot be read.
    pub fn seconds(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Option<f64> {
        let mut stamps = [0u64; 2];
        read_mapped(
            device,
            "",
            "the timestamps",
            &[self.read.slice(..)],
            |_, bytes| {
                let words: &[u64] = bytemuck::cast_slice(bytes);
                stamps = [words[0], words[1]];
            },
        )
        .ok()?;
        elapsed(stamps, queue)
    }

    /// The buffer the timestamps are read from, for a caller that maps it with its own
    /// results (then [`PassTimer::mapped_seconds`]).
    pub fn read_slice(&self) -> wgpu::BufferSlice<'_> {
        self.read.slice(..)
    }

    /// [`PassTimer::seconds`] from the timestamps' buffer already mapped (see
    /// [`PassTimer::read_slice`]), unmapping it.
    pub fn mapped_seconds(&self, queue: &wgpu::Queue) -> Option<f64> {
        let stamps = {
            let view = self.read.slice(..).get_mapped_range().ok()?;
            let words: Vec<u64> = bytemuck::pod_collect_to_vec(&view[..STAMP_BYTES as usize]);
            [words[0], words[1]]
        };
        self.read.unmap();
        elapsed(stamps, queue)
    }
}

/// Seconds between two timestamps of `queue`'s, where the second is not before the first.
fn elapsed(stamps: [u64; 2], queue: &wgpu::Queue) -> Option<f64> {
    let ticks = stamps[1].checked_sub(stamps[0])?;
    Some(ticks as f64 * queue.get_timestamp_period() as f64 * 1e-9)
}

/// The GPU's own seconds summed over passes run from several threads: nothing until a
/// pass was timed.
#[derive(Debug, Default)]
pub(super) struct BusyTotal {
    nanos: AtomicU64,
    timed: AtomicU64,
}

impl BusyTotal {
    pub fn add(&self, seconds: Option<f64>) {
        if let Some(s) = seconds {
            self.nanos
                .fetch_add((s * 1e9).round() as u64, Ordering::Relaxed);
            self.timed.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// The seconds, where any pass was timed.
    pub fn seconds(&self) -> Option<f64> {
        (self.timed.load(Ordering::Relaxed) > 0)
            .then(|| self.nanos.load(Ordering::Relaxed) as f64 * 1e-9)
    }
}
