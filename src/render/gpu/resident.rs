//! What a sequence keeps on the GPU from one frame to the next: the scene's buffers of
//! the frame before (the grids' nodes, the shadow maps, the lights, tables and lattice),
//! each with a fingerprint of its bytes. A frame whose buffer would hold the same bytes
//! binds the one already there and uploads nothing of it; one whose bytes differ (a new
//! grid, maps baked for moved lights) is uploaded, and the frame before's is let go. So
//! at most one frame's buffers are held between frames, and a single render, which has
//! no [`KeptBuffers`], holds none past its own.

use super::readback::buffer_with;
use rayon::prelude::*;
use std::hash::{DefaultHasher, Hash, Hasher};

/// The scene's buffers kept on the GPU across the frames of one sequence.
#[derive(Default)]
pub struct KeptBuffers {
    /// The last frame's buffers, each with the fingerprint of its bytes.
    held: Vec<(u64, wgpu::Buffer)>,
    /// Frames whose scene buffers were all kept from the frame before (nothing uploaded).
    pub frames_kept: usize,
}

impl KeptBuffers {
    /// Bytes held on the GPU between frames.
    pub fn bytes(&self) -> u64 {
        self.held.iter().map(|(_, b)| b.size()).sum()
    }
}

/// The buffers of one upload: made, or taken from those kept where the bytes are the same.
pub(super) struct Making<'a> {
    kept: Option<&'a mut KeptBuffers>,
    /// The frame before's buffers not yet taken.
    before: Vec<(u64, wgpu::Buffer)>,
    made: Vec<(u64, wgpu::Buffer)>,
    /// Bytes uploaded so far.
    pub uploaded: u64,
}

impl<'a> Making<'a> {
    /// Takes what `kept` holds (nothing without it: every buffer is uploaded).
    pub fn new(mut kept: Option<&'a mut KeptBuffers>) -> Self {
        let before = kept
            .as_deref_mut()
            .map(|k| std::mem::take(&mut k.held))
            .unwrap_or_default();
        Making {
            kept,
            before,
            made: Vec::new(),
            uploaded: 0,
        }
    }

    /// A storage buffer holding `contents`: the kept one with the same bytes, else a new one.
    pub fn buffer(&mut self, device: &wgpu::Device, label: &str, contents: &[u8]) -> wgpu::Buffer {
        let key = self.kept.is_some().then(|| fingerprint(label, contents));
        let same = key.and_then(|key| self.before.iter().position(|(k, _)| *k == key));
        let buffer = match same {
            Some(at) => self.before.swap_remove(at).1,
            None => {
                self.uploaded += contents.len() as u64;
                buffer_with(device, label, contents, wgpu::BufferUsages::STORAGE)
            }
        };
        if let Some(key) = key {
            self.made.push((key, buffer.clone()));
        }
        buffer
    }

    /// The upload went through: its buffers are kept for the next frame (the frame
    /// before's that it did not take are let go). Returns the bytes uploaded. (A
    /// `Making` dropped unfinished keeps nothing: the next frame uploads everything.)
    pub fn finish(self) -> u64 {
        if let Some(k) = self.kept {
            k.held = self.made;
            if self.uploaded == 0 {
                k.frames_kept += 1;
            }
        }
        self.uploaded
    }
}

/// A fingerprint of a buffer's label, length and bytes (64 bits of std's SipHash over
/// 1 MiB pieces, hashed in parallel, then over the pieces' hashes): equal bytes give
/// equal fingerprints in one process; different bytes the same one with odds of 2^-64.
fn fingerprint(label: &str, bytes: &[u8]) -> u64 {
    let pieces: Vec<u64> = bytes
        .par_chunks(1 << 20)
        .map(|c| {
            let mut h = DefaultHasher::new();
            c.hash(&mut h);
            h.finish()
        })
        .collect();
    let mut h = DefaultHasher::new();
    label.hash(&mut h);
    bytes.len().hash(&mut h);
    pieces.hash(&mut h);
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::fingerprint;

    #[test]
    fn fingerprints_tell_apart_labels_lengths_and_any_byte() {
        let bytes: Vec<u8> = (0..3 << 20).map(|i| (i * 7 % 251) as u8).collect();
        let f = fingerprint("vals", &bytes);
        assert_eq!(f, fingerprint("vals", &bytes.clone()));
        assert_ne!(f, fingerprint("tree", &bytes));
        assert_ne!(f, fingerprint("vals", &bytes[..bytes.len() - 1]));
        for at in [0, 1 << 20, bytes.len() - 1] {
            let mut other = bytes.clone();
            other[at] ^= 1;
            assert_ne!(f, fingerprint("vals", &other), "byte {at}");
        }
    }
}
