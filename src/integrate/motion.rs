//! Motion blur of a volume from its velocity: a camera sample taken at a time in the
//! shutter marches the volume's fields as they are then ([`crate::field::advect`]).

use super::medium::{ColorTint, Companion, Emission};
use crate::field::advect::{Advected, AdvectedColor, VelocityField};
use crate::field::{ColorField, Field};

/// How a volume moves: its velocity field and how many of the velocity's time units a
/// frame is (`1/fps` for a velocity per second, 1 for one per frame), times
/// `--velocity-scale`.
#[derive(Clone, Copy)]
pub struct Motion<'a> {
    pub velocity: &'a dyn VelocityField,
    pub per_frame: f64,
}

impl Motion<'_> {
    /// The advection's time offset (velocity time units) at `frames` from the frame.
    pub fn shift(&self, frames: f64) -> f64 {
        frames * self.per_frame
    }

    /// The farthest anything moves (world units) at most `frames` from the frame.
    pub fn max_displacement(&self, frames: f64) -> f64 {
        (self.shift(frames) * self.velocity.max_speed()).abs()
    }
}

/// The fields of a volume at one time offset, which a moved `Volume` borrows.
pub struct MovedFields<'a> {
    pub density: Advected<'a>,
    /// `None` where the traversal is the density itself.
    pub traversal: Option<Advected<'a>>,
    pub emission: Option<Advected<'a>>,
    pub temperature: Option<Advected<'a>>,
    pub color: Option<AdvectedColor<'a>>,
}

impl<'a> MovedFields<'a> {
    /// `density`, `traversal`, the emission's grids and the colour tint `shift` time
    /// units from the frame.
    pub fn new(
        density: &'a dyn Field,
        traversal: &'a dyn Field,
        emission: Option<&Emission<'a>>,
        color: Option<&ColorTint<'a>>,
        velocity: &'a dyn VelocityField,
        shift: f64,
    ) -> Self {
        let same = std::ptr::eq(
            traversal as *const _ as *const u8,
            density as *const _ as *const u8,
        );
        let moved = |f: &'a dyn Field| Advected::new(f, velocity, shift);
        MovedFields {
            density: moved(density),
            traversal: (!same).then(|| moved(traversal)),
            emission: emission
                .and_then(|e| e.grid.as_ref())
                .map(|c| moved(c.field)),
            temperature: emission
                .and_then(|e| e.temperature.as_ref())
                .map(|c| moved(c.field)),
            color: color.map(|c| AdvectedColor {
                inner: c.grid(),
                velocity,
                shift,
            }),
        }
    }

    /// The traversal: the moved density where it was the density.
    pub fn traversal(&self) -> &dyn Field {
        match &self.traversal {
            Some(t) => t,
            None => &self.density,
        }
    }

    /// `e` with its grids moved.
    pub fn emission(&'a self, e: &Emission<'a>) -> Emission<'a> {
        let companion = |f: &'a Option<Advected<'a>>| {
            f.as_ref()
                .map(|g| Companion::new(g as &dyn Field, &self.density))
        };
        Emission {
            grid: companion(&self.emission),
            temperature: companion(&self.temperature),
            ..e.clone()
        }
    }

    /// The colour tint, moved.
    pub fn color(&'a self) -> Option<ColorTint<'a>> {
        self.color
            .as_ref()
            .map(|c| ColorTint::new(c as &dyn ColorField, &self.density))
    }
}
