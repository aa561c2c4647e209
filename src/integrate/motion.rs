//! Motion blur of a volume from its velocity: a camera sample taken at a time in the
//! shutter marches the volume's fields as they are then ([`crate::field::advect`]).

use super::medium::{ColorTint, Companion, Emission};
use crate::field::advect::{Advected, AdvectedColor, RayFlow, VelocityField, index_pad};
use crate::field::padded_cells::CellCache;
use crate::field::{ColorField, Field};

/// How a volume moves: its velocity field and how many of the velocity's time units a
/// frame is (`1/fps` for a velocity per second, 1 for one per frame), times
/// `--velocity-scale`.
#[derive(Clone, Copy)]
pub struct Motion<'a> {
    pub velocity: &'a dyn VelocityField,
    pub per_frame: f64,
    /// The farthest a sample's time is from the frame's (frames): the shutter's reach,
    /// which what is built once for every time (the path tracer's majorants) is padded by.
    pub frames: f64,
    /// The fields' cell ranges grown for the whole shutter, built once
    /// ([`crate::field::padded_cells`]; `None`: each ray asks cell by cell).
    pub cells: Option<&'a CellCache>,
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
    /// units from the frame; with `flow`, looked up along its ray with the displacement
    /// it shares between them.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        density: &'a dyn Field,
        traversal: &'a dyn Field,
        emission: Option<&Emission<'a>>,
        color: Option<&ColorTint<'a>>,
        motion: &Motion<'a>,
        shift: f64,
        flow: Option<&'a RayFlow<'a>>,
    ) -> Self {
        let velocity = motion.velocity;
        let reach = motion.max_displacement(motion.frames);
        let same = std::ptr::eq(
            traversal as *const _ as *const u8,
            density as *const _ as *const u8,
        );
        let moved = |f: &'a dyn Field| {
            let table = motion
                .cells
                .and_then(|c| c.table(f, index_pad(f.transform(), reach)));
            let a = Advected::new(f, velocity, shift).with_cells(table);
            match flow {
                Some(flow) => a.along(flow),
                None => a,
            }
        };
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
                flow,
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
