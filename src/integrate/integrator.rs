//! The integrator seam: an integrator declares the passes it writes and computes one
//! camera sample's values for them. The pixel loop (`render`) knows nothing else about
//! how light is transported.

use super::deep::DeepTrace;
use super::march::WorldRay;
use super::pass::PassLayout;
use crate::field::random::{SplitMix64, mix64, unit_f64};

/// A deterministic hash of a pixel sample's `k`-th random dimension to [0, 1)
/// (SplitMix64's mixer): the same for any thread count, tile order or tiling.
pub fn unit_random(seed: u64, x: usize, y: usize, s: u32, k: u32) -> f64 {
    let z = seed
        .wrapping_add((x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15))
        .wrapping_add((y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F))
        .wrapping_add(((s as u64) << 32 | k as u64).wrapping_mul(0x1656_67B1_9E37_79F9));
    unit_f64(mix64(z))
}

/// The time of sample `s` of the `n` a pixel (x, y) takes, in the shutter `[open,
/// close]` (frames): one in each of `n` equal parts of the shutter, at an offset within
/// its part drawn once per pixel, mirrored in every other part (`r`, `1 − r`, `r`, …).
/// Each time is uniform in its part, so the pixel's mean is unbiased; the mirrored pairs
/// make it exact for anything linear in time, and its error for anything piecewise
/// smooth falls as 1/n² rather than 1/n. It depends only on the pixel and the seed.
pub fn shutter_time(seed: u64, x: usize, y: usize, s: u32, n: u32, shutter: (f64, f64)) -> f64 {
    // Sample index u32::MAX is never taken: its numbers are the pixel's own.
    let r = unit_random(seed, x, y, u32::MAX, SHUTTER_DIMENSION);
    let s = s.min(n.saturating_sub(1));
    let within = if s.is_multiple_of(2) { r } else { 1.0 - r };
    let f = (s as f64 + within) / n.max(1) as f64;
    shutter.0 + (shutter.1 - shutter.0) * f
}

/// The random dimension of a pixel's shutter offset ([`shutter_time`]).
const SHUTTER_DIMENSION: u32 = 0x5417;

/// [`SampleRng::stream`]'s multiplier of a stream's id.
const STREAM_ID_MUL: u64 = 0xD6E8_FEB8_6659_FD93;

/// The random numbers of one pixel sample, drawn in order. Dimensions 1 and 2 are the
/// pixel loop's jitter inside the pixel; an integrator's draws are 0, 3, 4, 5, …
#[derive(Clone, Copy, Debug)]
pub struct SampleRng {
    seed: u64,
    x: usize,
    y: usize,
    s: u32,
    k: u32,
}

impl SampleRng {
    pub fn new(seed: u64, x: usize, y: usize, s: u32) -> Self {
        SampleRng {
            seed,
            x,
            y,
            s,
            k: 0,
        }
    }

    /// Which of the pixel's samples this is (0, 1, …).
    pub fn sample_index(&self) -> u32 {
        self.s
    }

    /// The next uniform number in [0, 1).
    #[inline]
    pub fn uniform(&mut self) -> f64 {
        let k = self.k;
        self.k = if k == 0 { 3 } else { k.wrapping_add(1) };
        unit_random(self.seed, self.x, self.y, self.s, k)
    }

    /// An endless stream of random numbers of its own for this pixel sample, told apart
    /// by `id`: for integrators whose number of draws has no bound (a path's flights and
    /// shadow rays), each part drawing from its own stream so that how many numbers one
    /// part takes does not shift the others'.
    pub fn stream(&self, id: u64) -> SplitMix64 {
        SplitMix64(mix64(self.stream_key() ^ id.wrapping_mul(STREAM_ID_MUL)))
    }

    /// What every [`SampleRng::stream`] of this pixel sample is derived from: stream `id`
    /// starts at `mix64(key ^ id · 0xD6E8_FEB8_6659_FD93)` (the GPU's path tracer draws
    /// the same numbers from it).
    pub fn stream_key(&self) -> u64 {
        let z = self
            .seed
            .wrapping_add((self.x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15))
            .wrapping_add((self.y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F))
            .wrapping_add((self.s as u64).wrapping_mul(0x1656_67B1_9E37_79F9));
        mix64(z)
    }
}

/// One camera sample: the ray, and how fast camera-space depth grows along it (the
/// cosine between the ray and the viewing axis): depth at ray parameter t is
/// `t × depth_rate`. `ray.time` is when it is taken.
#[derive(Clone, Copy, Debug)]
pub struct CameraSample {
    pub ray: WorldRay,
    pub depth_rate: f64,
}

/// Computes what a camera ray sees.
pub trait Integrator: Sync {
    /// Per-thread buffers, made once per worker so the per-ray work does not allocate.
    type Scratch: Send;

    /// The passes this integrator writes, in the order their channels are written.
    fn passes(&self) -> &PassLayout;

    fn scratch(&self) -> Self::Scratch;

    /// Integrates one camera sample and adds its values to `acc` (one pixel's buffer,
    /// laid out by [`Integrator::passes`]). Returns the density samples it took.
    fn sample(
        &self,
        camera: &CameraSample,
        rng: &mut SampleRng,
        scratch: &mut Self::Scratch,
        acc: &mut [f64],
    ) -> u64;

    /// The deep record of the camera sample [`Integrator::sample`] just integrated, in
    /// ray parameters: kept by integrators built with deep output on, else none.
    fn deep_trace<'s>(&self, scratch: &'s Self::Scratch) -> Option<&'s DeepTrace> {
        let _ = scratch;
        None
    }

    /// The layers whose values deep records keep when asked (deep AOVs), in the order
    /// of the passes; none for integrators without deep output.
    fn deep_aovs(&self) -> Vec<super::deep::DeepAov> {
        Vec::new()
    }
}
