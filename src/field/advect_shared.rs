//! [`Advected`] owning what it looks through: a shared field moved by a shared velocity,
//! for a member of a sum of volumes that each move by their own velocity grid (the sum
//! holds its members by `Arc`).

use super::advect::{Advected, AdvectedColor, VelocityField, index_pad};
use super::padded_cells::CellCache;
use super::{Cell, ColorField, Field, IndexBox, IndexRay, IndexToWorld, ValueRange};
use glam::{DVec3, IVec3, Vec3};
use std::sync::Arc;

/// How a shared field moves: its velocity, and the farthest (world units) it carries
/// anything within the shutter with the table of cell ranges grown that far.
#[derive(Clone)]
pub struct SharedFlow {
    pub velocity: Arc<dyn VelocityField>,
    pub reach: f64,
    pub cells: Arc<CellCache>,
}

/// `inner` seen `shift` time units from its own time, moved by `flow`'s velocity.
pub struct AdvectedShared {
    inner: Arc<dyn Field>,
    flow: SharedFlow,
    shift: f64,
}

impl AdvectedShared {
    pub fn new(inner: Arc<dyn Field>, flow: SharedFlow, shift: f64) -> Self {
        AdvectedShared { inner, flow, shift }
    }

    /// The field as [`Advected`] sees it, with the shutter's table of grown cells.
    fn view(&self) -> Advected<'_> {
        let pad = index_pad(self.inner.transform(), self.flow.reach);
        let table = self.flow.cells.table(self.inner.as_ref(), pad);
        Advected::new(self.inner.as_ref(), self.flow.velocity.as_ref(), self.shift)
            .with_cells(table)
    }
}

impl Field for AdvectedShared {
    fn value_at_index(&self, p: DVec3) -> f32 {
        self.view().value_at_index(p)
    }

    fn integral(&self, ray: &IndexRay, t0: f64, t1: f64) -> f64 {
        self.view().integral(ray, t0, t1)
    }

    fn piece_integrals(&self, ray: &IndexRay, t0: f64, ends: &[f64], out: &mut [f64]) {
        self.view().piece_integrals(ray, t0, ends, out)
    }

    fn transform(&self) -> &IndexToWorld {
        self.inner.transform()
    }

    fn active_bounds(&self) -> IndexBox {
        self.view().active_bounds()
    }

    fn cell_at(&self, ijk: IVec3) -> Cell {
        self.view().cell_at(ijk)
    }

    fn range_over(&self, b: &IndexBox) -> ValueRange {
        self.view().range_over(b)
    }

    fn tight_range_over(&self, b: &IndexBox) -> ValueRange {
        self.view().tight_range_over(b)
    }

    fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(self)
    }
}

/// A shared colour field seen at another time, as [`AdvectedShared`] sees a scalar one.
pub struct AdvectedSharedColor {
    pub inner: Arc<dyn ColorField>,
    pub velocity: Arc<dyn VelocityField>,
    pub shift: f64,
}

impl ColorField for AdvectedSharedColor {
    fn transform(&self) -> &IndexToWorld {
        self.inner.transform()
    }
    fn color_at_index(&self, p: DVec3) -> Vec3 {
        AdvectedColor {
            inner: self.inner.as_ref(),
            velocity: self.velocity.as_ref(),
            shift: self.shift,
            flow: None,
        }
        .color_at_index(p)
    }
}
