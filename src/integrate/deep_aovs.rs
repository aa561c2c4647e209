//! Deep AOVs: the layers of the flat file (emission, scattered light, its indirect
//! part, each light's) as extra channels of every deep sample, premultiplied as colour
//! is, so that flattening one gives its flat layer.
//!
//! With AOVs on, a ray's `DeepTrace` (`integrate::deep`) keeps, beside each
//! point's opacity and colour, the layers' cumulative values there ([`aov_width`] of
//! them). The samples are the beauty's (merged by its opacity and colour): an AOV's value
//! in a sample is what its curve, the mean of the pixel's rays' (each split inside an
//! interval like colour, by opacity), gains over the sample divided by the transmittance
//! in front of it. Flattened, an AOV is then the mean of the rays' totals: the flat layer.
//! Inside a merged sample an AOV is placed in depth as the sample's opacity is.

use glam::DVec3;

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

/// Puts a march's layers (emission, indirect, each light's scattered light) into a
/// point's AOV values `now` (laid out as [`AOV_EMISSION`], [`AOV_INDIRECT`],
/// [`AOV_LIGHTS`] say); nothing where `now` is empty (no AOVs recorded).
pub fn put(now: &mut [f64], emission: DVec3, indirect: DVec3, per_light: &[DVec3]) {
    let mut at = |k: usize, v: DVec3| {
        if let Some(s) = now.get_mut(k..k + 3) {
            s.copy_from_slice(&v.to_array());
        }
    };
    at(AOV_EMISSION, emission);
    at(AOV_INDIRECT, indirect);
    for (l, v) in per_light.iter().enumerate() {
        at(AOV_LIGHTS + 3 * l, *v);
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
