//! Deep AOVs: the layers of the flat file (emission, scattered light, its indirect
//! part, each light's) as extra channels of every deep sample, premultiplied as colour
//! is, so that flattening one gives its flat layer.
//!
//! With AOVs on, a ray's [`DeepTrace`](super::deep::DeepTrace) keeps, beside each
//! point's opacity and colour, the layers' cumulative values there ([`aov_width`] of
//! them). The samples are the beauty's (merged by its opacity and colour): an AOV's value
//! in a sample is what its curve, the mean of the pixel's rays' (each split inside an
//! interval like colour, by opacity), gains over the sample divided by the transmittance
//! in front of it. Flattened, an AOV is then the mean of the rays' totals: the flat layer.
//! Inside a merged sample an AOV is placed in depth as the sample's opacity is.

use super::deep::{DeepPoint, Where, locate, split};

/// Where a trace's AOV values start: emission (R, G, B), ...
pub const AOV_EMISSION: usize = 0;
/// ... light scattered two or more times, ...
pub const AOV_INDIRECT: usize = 3;
/// ... and each light's scattered light, three values each.
pub const AOV_LIGHTS: usize = 6;

/// The AOV values per point of a trace with `lights` lights.
pub fn aov_width(lights: usize) -> usize {
    AOV_LIGHTS + 3 * lights
}

/// A deep AOV: the flat file's layer it matches and the trace's values it sums (each
/// the first of three: R, G, B).
#[derive(Clone, Debug, PartialEq)]
pub struct DeepAov {
    pub layer: String,
    pub rows: Vec<usize>,
}

/// What a pixel's rays recorded for its AOVs: per ray its AOV values (`width` per
/// point of its curve), and the AOVs wanted.
pub struct PixelAovs<'a> {
    pub rows: &'a [Vec<f64>],
    pub width: usize,
    pub wanted: &'a [DeepAov],
}

/// The AOVs of a pixel's samples: its rays' curves (in depth) with their AOV values, and
/// the AOVs wanted. Each sample's value of an AOV is what the AOV's curve (the mean of the
/// rays', each split by OpenEXR's rule like colour) gains over the sample, over the
/// transmittance in front of it, so each AOV flattens to the mean of the rays' totals:
/// the flat layer.
pub(super) struct AovWalk<'a> {
    pub(super) curves: &'a [Vec<DeepPoint>],
    pub(super) rows: &'a [Vec<f64>],
    pub(super) width: usize,
    pub(super) wanted: &'a [DeepAov],
    pub(super) cursors: Vec<usize>,
    /// What the samples so far add up to, flattened.
    pub(super) done: Vec<f64>,
    pub(super) now: Vec<f64>,
}

impl AovWalk<'_> {
    /// The AOVs' cumulative values at `depth` (growing over calls) into `now`.
    fn at(&mut self, depth: f64) {
        self.now.iter_mut().for_each(|v| *v = 0.0);
        let n = self.curves.len().max(1) as f64;
        for ((curve, rows), cur) in self.curves.iter().zip(self.rows).zip(&mut self.cursors) {
            let (i, j, share) = match locate(curve, depth, cur) {
                Where::Zero => continue,
                Where::Hold(i) => (i, i, 0.0),
                Where::Between(i, j, f) => (i, j, split(&curve[i], &curve[j], f).1),
            };
            let at = |k: usize| curve[k].row as usize * self.width;
            let (Some(ri), Some(rj)) = (rows.get(at(i)..), rows.get(at(j)..)) else {
                continue;
            };
            for (k, aov) in self.wanted.iter().enumerate() {
                for &r in &aov.rows {
                    for c in 0..3 {
                        let (a, b) = (ri[r + c], rj[r + c]);
                        self.now[3 * k + c] += (a + (b - a) * share) / n;
                    }
                }
            }
        }
    }

    /// The sample that ends at `depth` with transmittance `t0` in front of it.
    pub(super) fn sample(&mut self, depth: f64, t0: f64, out: &mut Vec<f32>) {
        self.at(depth);
        for (d, v) in self.done.iter_mut().zip(&self.now) {
            out.push(((v - *d) / t0) as f32);
            *d = *v;
        }
    }
}

/// The deep AOVs of `wanted` (`emission`, `scatter`, `indirect`, `lights`: the layers
/// `scatter_<light>`, `all`: every one) among those a render has (`available`), in its
/// order. A wanted one the render lacks is an error naming it.
pub fn select_aovs(available: &[DeepAov], wanted: &[String]) -> Result<Vec<DeepAov>, String> {
    let per_light = |a: &DeepAov| a.layer.starts_with("scatter_");
    let mut keep = vec![false; available.len()];
    for w in wanted {
        let found: Vec<usize> = (0..available.len())
            .filter(|&i| match w.as_str() {
                "all" => true,
                "lights" => per_light(&available[i]),
                name => available[i].layer == name,
            })
            .collect();
        if found.is_empty() {
            return Err(match w.as_str() {
                "lights" => "lights: this render has no per-light layers (they are written \
                             with two or more scattering lights; with one, scatter is its light)"
                    .to_string(),
                "all" => "all: this render has no layers to add (nothing emits or scatters)".into(),
                name => format!("{name}: this render writes no {name} layer"),
            });
        }
        found.into_iter().for_each(|i| keep[i] = true);
    }
    Ok(available
        .iter()
        .zip(keep)
        .filter(|(_, k)| *k)
        .map(|(a, _)| a.clone())
        .collect())
}
