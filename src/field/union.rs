//! The union of several fields' hierarchies on one lattice, for traversal: a cell is
//! empty only where every field is zero. Used so that flame and temperature grids are
//! visited where density is zero.

use super::{Cell, Field, IndexBox, IndexToWorld, ValueRange};
use glam::{DVec3, IVec3};

pub struct FieldUnion<'a> {
    primary: &'a dyn Field,
    /// Other fields and the integer offset from the primary's local index space to theirs.
    others: Vec<(&'a dyn Field, IVec3)>,
}

impl<'a> FieldUnion<'a> {
    pub fn new(primary: &'a dyn Field) -> Self {
        FieldUnion {
            primary,
            others: Vec::new(),
        }
    }

    /// Adds a field on the primary's lattice; `offset` maps primary local index → its own.
    pub fn with(mut self, field: &'a dyn Field, offset: IVec3) -> Self {
        self.others.push((field, offset));
        self
    }

    /// The primary field where it is the union's only one: its cells are the union's,
    /// and their value ranges its own.
    pub fn alone(&self) -> Option<&'a dyn Field> {
        self.others.is_empty().then_some(self.primary)
    }
}

impl Field for FieldUnion<'_> {
    fn value_at_index(&self, p: DVec3) -> f32 {
        let mut v = self.primary.value_at_index(p);
        for (f, o) in &self.others {
            v = v.max(f.value_at_index(p + o.as_dvec3()));
        }
        v
    }

    fn transform(&self) -> &IndexToWorld {
        self.primary.transform()
    }

    fn value_at_world(&self, p: DVec3) -> f32 {
        self.value_at_index(self.primary.transform().world_to_index(p))
    }

    fn active_bounds(&self) -> IndexBox {
        let mut b = self.primary.active_bounds();
        for (f, o) in &self.others {
            let ob = f.active_bounds();
            if !ob.is_empty() {
                b = b.union(&IndexBox::new(ob.min - o.as_vec3(), ob.max - o.as_vec3()));
            }
        }
        b
    }

    fn cell_at(&self, ijk: IVec3) -> Cell {
        let mut c = self.primary.cell_at(ijk);
        for (f, o) in &self.others {
            let mut d = f.cell_at(ijk + *o);
            d.origin -= *o;
            let range = c.range.union(&d.range);
            if d.size < c.size {
                c = d;
            }
            c.range = range;
        }
        c
    }

    fn range_over(&self, b: &IndexBox) -> ValueRange {
        let mut r = self.primary.range_over(b);
        for (f, o) in &self.others {
            let ob = IndexBox::new(b.min + o.as_vec3(), b.max + o.as_vec3());
            r = r.union(&f.range_over(&ob));
        }
        r
    }
}
