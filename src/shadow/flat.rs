//! A deep shadow map's chart as flat 32-bit words, for a renderer that looks τ up itself
//! (the GPU backend): the brick position table, the bricks, and their samples, in the
//! layout [`ChartMap`] keeps them, so that a port of [`ChartMap::density_integral_at`]
//! reads the same numbers.

use super::brick::BrickForm;
use super::chart::{ChartKind, LateralBlend};
use super::map::{ChartMap, NO_BRICK};
use glam::{DVec3, IVec3};
use rayon::prelude::*;

/// Words per brick in [`FlatChart::bricks`]: key x, y, z (i32 bits), `level | form << 8`
/// (form: 0 Hermite, 1 Linear, 2 Constant), offset of its first sample, then its four
/// scales (f32 bits).
pub const BRICK_WORDS: usize = 9;
/// Words per Hermite sample in [`FlatChart::hermite`]: τ (f32 bits), then the four packed
/// quantities as i16 pairs, low half first.
pub const SAMPLE_WORDS: usize = 3;

/// One chart, flat.
#[derive(Clone, Debug)]
pub struct FlatChart {
    /// False: parallel columns from the plane through `point` (a sun); true: columns
    /// leaving `point` (a point light) with lateral scale `scale`.
    pub perspective: bool,
    pub point: DVec3,
    pub scale: f64,
    /// Per lateral axis: Hermite (false) or linear (true) blend.
    pub linear_lateral: [bool; 2],
    pub e1: DVec3,
    pub e2: DVec3,
    pub e3: DVec3,
    pub unit: f64,
    /// The brick table covers keys `lo .. lo + dims`, x fastest; [`FlatChart::NONE`]
    /// where no brick is.
    pub lo: IVec3,
    pub dims: IVec3,
    pub slots: Vec<u32>,
    pub bricks: Vec<u32>,
    pub hermite: Vec<u32>,
    /// Linear bricks' 16-bit steps, one a word.
    pub linear: Vec<u32>,
}

impl FlatChart {
    pub const NONE: u32 = NO_BRICK;
}

impl ChartMap {
    /// This chart as flat words.
    pub fn flat(&self) -> FlatChart {
        let c = &self.chart;
        let (perspective, point, scale) = match c.kind {
            ChartKind::Parallel { origin } => (false, origin, 0.0),
            ChartKind::Perspective { light, scale } => (true, light, scale),
        };
        let mut bricks = Vec::with_capacity(self.bricks.len() * BRICK_WORDS);
        for b in &self.bricks {
            let form = match b.form {
                BrickForm::Hermite => 0u32,
                BrickForm::Linear => 1,
                BrickForm::Constant => 2,
            };
            bricks.extend([
                b.key.x as u32,
                b.key.y as u32,
                b.key.z as u32,
                u32::from(b.level) | form << 8,
                b.offset,
            ]);
            bricks.extend(b.scales.map(f32::to_bits));
        }
        let half = |v: i16| u32::from(v as u16);
        // Sized at once and packed on every thread: a map's samples run to 10⁸ bytes.
        let mut hermite = vec![0u32; self.samples.len() * SAMPLE_WORDS];
        hermite
            .par_chunks_mut(SAMPLE_WORDS)
            .zip(self.samples.par_iter())
            .for_each(|(out, s)| {
                out.copy_from_slice(&[
                    s.tau.to_bits(),
                    half(s.rest[0]) | half(s.rest[1]) << 16,
                    half(s.rest[2]) | half(s.rest[3]) << 16,
                ])
            });
        FlatChart {
            perspective,
            point,
            scale,
            linear_lateral: c.lateral.map(|l| l == LateralBlend::Linear),
            e1: c.e1,
            e2: c.e2,
            e3: c.e3,
            unit: c.unit,
            lo: self.lo,
            dims: self.dims,
            slots: self.slots.clone(),
            bricks,
            hermite,
            linear: self.linear.iter().map(|&v| u32::from(v)).collect(),
        }
    }
}
