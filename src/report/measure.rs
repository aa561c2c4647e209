//! A measured point of a convergence sweep and the measures of an image against its
//! reference (shared by `murk converge`'s sweeps).

use crate::output::{Frame, is_depth_channel, names};
use serde::Serialize;

/// A measured point: its settings as rendered, times, and error against the reference.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Measured {
    pub sweep: String,
    pub value: f64,
    pub step: f64,
    pub dsm_tolerance: f64,
    pub termination: f64,
    pub shadows: String,
    /// Median over the runs of the shadow-map bake (0 when marched).
    pub bake_seconds: f64,
    /// Median over the runs of the render stage.
    pub render_seconds: f64,
    pub total_seconds: f64,
    pub runs: usize,
    /// `‖L − L_ref‖₂ / ‖L_ref‖₂` over R, G, B of every pixel.
    pub rel_rmse: f64,
    pub max_alpha_error: f64,
    pub nan_inf: u64,
    /// Pixels with α outside [0, 1], negative radiance or radiance above its bound.
    pub bound_violations: u64,
}

fn rgb(f: &Frame) -> [&[f32]; 3] {
    [names::R, names::G, names::B].map(|n| f.channel(n).unwrap_or(&[]))
}

/// `‖L − L_ref‖₂ / ‖L_ref‖₂` over R, G, B.
pub fn rel_rmse(got: &Frame, want: &Frame) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (g, w) in rgb(got).iter().zip(rgb(want)) {
        for (a, b) in g.iter().zip(w) {
            let (a, b) = (*a as f64, *b as f64);
            num += (a - b) * (a - b);
            den += b * b;
        }
    }
    if den > 0.0 {
        (num / den).sqrt()
    } else {
        num.sqrt()
    }
}

pub fn max_alpha_error(got: &Frame, want: &Frame) -> f64 {
    match (got.channel(names::A), want.channel(names::A)) {
        (Some(g), Some(w)) => g
            .iter()
            .zip(w)
            .map(|(a, b)| (*a as f64 - *b as f64).abs())
            .fold(0.0, f64::max),
        _ => f64::NAN,
    }
}

/// NaN or ±Inf in any channel but depth (whose +inf means "never opaque").
pub fn count_nan_inf(f: &Frame) -> u64 {
    f.channels()
        .iter()
        .filter(|c| !is_depth_channel(c.name()))
        .map(|c| c.data().iter().filter(|v| !v.is_finite()).count() as u64)
        .sum()
}

/// Pixels with α outside [0, 1], or R, G or B negative or above `bound`.
pub fn bound_violations(f: &Frame, bound: f64) -> u64 {
    let a = f.channel(names::A).unwrap_or(&[]);
    let [r, g, b] = rgb(f);
    (0..f.pixel_count())
        .filter(|&i| {
            let alpha = a.get(i).copied().unwrap_or(0.0);
            let bad_alpha = !(0.0..=1.0).contains(&alpha);
            let bad_l = [r, g, b].iter().any(|c| {
                let l = c.get(i).copied().unwrap_or(0.0) as f64;
                l < 0.0 || l > bound * (1.0 + 1e-6)
            });
            bad_alpha || bad_l
        })
        .count() as u64
}
