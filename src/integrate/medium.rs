//! What the volume is made of: coefficients, and the fields that feed the integral.

use crate::field::{ColorField, Field, IndexRay, lattice_offset};
use crate::integrate::blackbody::BlackbodyTable;
use glam::DVec3;

/// Absorption and scattering per world unit at density 1 (RGB), a density scale and the
/// Henyey–Greenstein anisotropy.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Medium {
    pub sigma_a: DVec3,
    pub sigma_s: DVec3,
    pub density_scale: f64,
    pub g: f64,
}

impl Medium {
    /// Extinction per world unit at density 1 (scale applied).
    pub fn sigma_t(&self) -> DVec3 {
        (self.sigma_a + self.sigma_s) * self.density_scale
    }
    /// Scattering per world unit at density 1 (scale applied).
    pub fn sigma_s_scaled(&self) -> DVec3 {
        self.sigma_s * self.density_scale
    }
    pub fn scatters(&self) -> bool {
        self.sigma_s_scaled().max_element() > 0.0
    }
}

/// A field sampled at the density's sample points. When the field shares the density
/// grid's lattice (same index→world map), the density's local index point is shifted by
/// an integer offset; otherwise the world point is mapped.
#[derive(Clone, Copy)]
pub struct Companion<'a> {
    pub field: &'a dyn Field,
    offset: Option<DVec3>,
}

impl<'a> Companion<'a> {
    pub fn new(field: &'a dyn Field, density: &dyn Field) -> Self {
        let offset = lattice_offset(field.transform(), density.transform());
        Companion { field, offset }
    }

    /// True if the companion is on the density's lattice (its cells line up).
    pub fn same_lattice(&self) -> bool {
        self.offset.is_some()
    }

    pub fn offset(&self) -> Option<DVec3> {
        self.offset
    }

    /// Mean value over `[a, b]` of a ray in the density's local index space (`w`: the
    /// world midpoint, used when the lattices differ).
    pub fn mean(&self, ray: &IndexRay, a: f64, b: f64, w: DVec3) -> f64 {
        match self.offset {
            Some(o) if b > a => {
                let shifted = IndexRay {
                    origin: ray.origin + o,
                    dir: ray.dir,
                };
                self.field.integral(&shifted, a, b) / (b - a)
            }
            _ => self.field.value_at_world(w) as f64,
        }
    }

    /// [`Field::piece_integrals`] of the companion along a ray of the density's local
    /// index space: `out[i] = ∫ over [ends[i−1], ends[i]]` (`ends[−1] = t0`), in one walk.
    /// `false` (nothing written) when the lattices differ; [`Companion::mean`] then
    /// samples the world midpoint per segment.
    pub fn piece_integrals(&self, ray: &IndexRay, t0: f64, ends: &[f64], out: &mut [f64]) -> bool {
        let Some(o) = self.offset else { return false };
        let shifted = IndexRay {
            origin: ray.origin + o,
            dir: ray.dir,
        };
        self.field.piece_integrals(&shifted, t0, ends, out);
        true
    }

    /// [`Field::values_along`] of the companion at `ray.at(t)` for each `t` (density's
    /// local index space); `false` (nothing written) when the lattices differ.
    pub fn values_along(&self, ray: &IndexRay, ts: &[f64], out: &mut [f32]) -> bool {
        let Some(o) = self.offset else { return false };
        let shifted = IndexRay {
            origin: ray.origin + o,
            dir: ray.dir,
        };
        self.field.values_along(&shifted, ts, out);
        true
    }

    #[inline]
    pub fn value(&self, p_density_index: DVec3, p_world: DVec3) -> f32 {
        match self.offset {
            Some(o) => self.field.value_at_index(p_density_index + o),
            None => self.field.value_at_world(p_world),
        }
    }
}

/// A colour grid (Houdini's `Cd`, Blender's `color`) that tints the scattering
/// coefficient: σs(x) = σs · ρ(x) · Cd(x), each channel clamped to [0, 1].
#[derive(Clone, Copy)]
pub struct ColorTint<'a> {
    grid: &'a dyn ColorField,
    offset: Option<DVec3>,
}

impl<'a> ColorTint<'a> {
    /// The colour field.
    pub fn grid(&self) -> &'a dyn ColorField {
        self.grid
    }

    pub fn new(grid: &'a dyn ColorField, density: &dyn Field) -> Self {
        ColorTint {
            grid,
            offset: lattice_offset(grid.transform(), density.transform()),
        }
    }

    #[inline]
    pub fn at(&self, p: DVec3, w: DVec3) -> DVec3 {
        let q = match self.offset {
            Some(o) => p + o,
            None => self.grid.transform().world_to_index(w),
        };
        self.grid
            .color_at_index(q)
            .as_dvec3()
            .clamp(DVec3::ZERO, DVec3::ONE)
    }
}

/// Light emitted by the volume, per world unit (an emission coefficient, as Cycles
/// defines it: it glows whether or not there is density).
#[derive(Clone)]
pub struct Emission<'a> {
    /// `emission_grid × color × intensity`.
    pub grid: Option<Companion<'a>>,
    pub color: DVec3,
    pub intensity: f64,
    /// Blackbody emission from a temperature grid: Kelvin = value × scale + offset; the
    /// colour is the luminance-normalised blackbody colour times `blackbody_intensity`
    /// times (K / 1000)^4, so hotter is brighter as in Cycles' Principled Volume.
    pub temperature: Option<Companion<'a>>,
    pub temperature_scale: f64,
    pub temperature_offset: f64,
    pub blackbody_intensity: f64,
    pub table: BlackbodyTable,
    /// Further emitters whose coefficients add to this one's (the volumes of a scene of
    /// several, each with its own grids and settings): empty for one volume.
    pub more: Vec<Emission<'a>>,
}

impl<'a> Emission<'a> {
    /// Grey emission `intensity × grid` and no blackbody term.
    pub fn grey(grid: Companion<'a>, intensity: f64) -> Self {
        Emission {
            grid: Some(grid),
            color: DVec3::ONE,
            intensity,
            temperature: None,
            temperature_scale: 1.0,
            temperature_offset: 0.0,
            blackbody_intensity: 0.0,
            table: BlackbodyTable::new(1000.0, 2000.0, 2),
            more: Vec::new(),
        }
    }

    pub fn is_active(&self) -> bool {
        (self.grid.is_some() && self.intensity > 0.0 && self.color.max_element() > 0.0)
            || (self.temperature.is_some() && self.blackbody_intensity > 0.0)
            || self.more.iter().any(Emission::is_active)
    }

    /// Mean emission coefficient (RGB per world unit) over the segment `[a, b]` of a ray
    /// (local index space of the density grid). The emission grid's term is linear in
    /// its value, so its exact mean over the segment is used: emission proportional to
    /// extinction then integrates exactly. The blackbody term is evaluated at the
    /// segment's midpoint `p` (world `w`).
    #[inline]
    pub fn mean(&self, ray: &IndexRay, a: f64, b: f64, p: DVec3, w: DVec3) -> DVec3 {
        let grid_mean = self.grid.as_ref().map(|c| c.mean(ray, a, b, w));
        let temperature = self.temperature.as_ref().map(|c| c.value(p, w));
        self.from_samples(grid_mean, temperature) + self.others(ray, a, b, p, w)
    }

    /// The further emitters' ([`Emission::more`]) summed [`Emission::mean`] over the
    /// segment: what [`Emission::from_samples`], which holds this emitter's own grids
    /// only, leaves out.
    #[inline]
    pub fn others(&self, ray: &IndexRay, a: f64, b: f64, p: DVec3, w: DVec3) -> DVec3 {
        self.more
            .iter()
            .fold(DVec3::ZERO, |e, m| e + m.mean(ray, a, b, p, w))
    }

    /// The emission coefficient from the emission grid's mean over a segment
    /// (`grid_mean`) and the temperature grid's value at its midpoint (`temperature`,
    /// grid units), each `None` where there is no such grid; this emitter's own, without
    /// [`Emission::more`].
    #[inline]
    pub fn from_samples(&self, grid_mean: Option<f64>, temperature: Option<f32>) -> DVec3 {
        let mut e = DVec3::ZERO;
        if let Some(v) = grid_mean
            && v > 0.0
        {
            e += self.color * (v * self.intensity);
        }
        if let Some(v) = temperature {
            let k = v as f64 * self.temperature_scale + self.temperature_offset;
            if k > 0.0 && k.is_finite() {
                let rgb = DVec3::from_array(self.table.rgb_normalized_clamped(k));
                let brightness = (k / 1000.0).powi(4) * self.blackbody_intensity;
                e += rgb * brightness;
            }
        }
        e
    }
}
