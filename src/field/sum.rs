//! Several fields placed in one world and added: the density of a scene of several
//! volumes. Each member is a shared field (one decoded grid may be placed many times)
//! with its own index→world map and a weight; the sum's value at a point is
//! `Σ wᵢ·ρᵢ(x)`, each member sampled on its own lattice, so its exact ray integral is the
//! sum of the members' exact integrals, and its hierarchy is the union of theirs (a cell
//! is empty only where every member is).
//!
//! The sum's local index space is its first member's: the march's step is in that
//! member's voxels, and a member on the same lattice (an integer shift away) is walked
//! cell for cell; any other is mapped point by point and bounded box by box.

use super::{Cell, Field, IndexBox, IndexRay, IndexToWorld, Quadrature, ValueRange};
use glam::{DMat3, DVec3, IVec3, Vec3};
use std::sync::Arc;

/// One placed field of a [`FieldSum`].
#[derive(Clone)]
pub struct Member {
    field: Arc<dyn Field>,
    /// The member's index→world map as placed (its file's map, then the placement).
    transform: IndexToWorld,
    weight: f64,
    /// The sum's local index point → the member's: `linear · p + shift`.
    linear: DMat3,
    shift: DVec3,
    /// `Some(offset)` when the member is on the sum's lattice (`linear` is the identity).
    aligned: Option<IVec3>,
    /// The box (the sum's local index space) outside which the member is zero.
    bounds: IndexBox,
}

impl Member {
    #[inline]
    fn map(&self, p: DVec3) -> DVec3 {
        match self.aligned {
            Some(o) => p + o.as_dvec3(),
            None => self.linear * p + self.shift,
        }
    }

    fn map_ray(&self, ray: &IndexRay) -> IndexRay {
        IndexRay {
            origin: self.map(ray.origin),
            dir: match self.aligned {
                Some(_) => ray.dir,
                None => self.linear * ray.dir,
            },
        }
    }

    /// The box (member's local index space) holding the sum's index box `b`.
    fn map_box(&self, b: &IndexBox) -> IndexBox {
        if b.is_empty() {
            return *b;
        }
        if let Some(o) = self.aligned {
            let o = o.as_vec3();
            return IndexBox::new(b.min + o, b.max + o);
        }
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for c in 0..8 {
            let p = DVec3::new(
                if c & 1 == 0 { b.min.x } else { b.max.x } as f64,
                if c & 2 == 0 { b.min.y } else { b.max.y } as f64,
                if c & 4 == 0 { b.min.z } else { b.max.z } as f64,
            );
            let q = self.map(p).as_vec3();
            lo = lo.min(q);
            hi = hi.max(q);
        }
        // One voxel of slack for the rounding of the map.
        IndexBox::new(lo - Vec3::ONE, hi + Vec3::ONE)
    }

    /// The member's active bounds in the local index space of `sum` (the sum's map).
    fn bounds_in(&self, sum: &IndexToWorld) -> IndexBox {
        let own = self.field.active_bounds();
        if own.is_empty() {
            return IndexBox::EMPTY;
        }
        if let Some(o) = self.aligned {
            return IndexBox::new(own.min - o.as_vec3(), own.max - o.as_vec3());
        }
        let (lo, hi) = self.transform.index_box_to_world(&own);
        let (mut a, mut z) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for c in 0..8 {
            let w = DVec3::new(
                if c & 1 == 0 { lo.x } else { hi.x },
                if c & 2 == 0 { lo.y } else { hi.y },
                if c & 4 == 0 { lo.z } else { hi.z },
            );
            let q = sum.world_to_index(w).as_vec3();
            a = a.min(q);
            z = z.max(q);
        }
        IndexBox::new(a - Vec3::ONE, z + Vec3::ONE)
    }

    /// Whether the member can be non-zero in the sum's index box `b`.
    #[inline]
    fn touches(&self, b: &IndexBox) -> bool {
        !b.is_empty()
            && !self.bounds.is_empty()
            && b.min.cmple(self.bounds.max).all()
            && b.max.cmpge(self.bounds.min).all()
    }

    /// Whether the member can be non-zero at the sum's index point `p` (half a voxel of
    /// slack for rounding).
    #[inline]
    fn holds(&self, p: DVec3) -> bool {
        let (lo, hi) = (self.bounds.min.as_dvec3(), self.bounds.max.as_dvec3());
        p.cmpge(lo - 0.5).all() && p.cmple(hi + 0.5).all()
    }

    /// Whether the ray (the sum's index space) can meet the member over `[t0, t1]`.
    fn crossed(&self, ray: &IndexRay, t0: f64, t1: f64) -> bool {
        if self.bounds.is_empty() {
            return false;
        }
        let (mut a, mut b) = (t0.min(t1), t0.max(t1));
        for k in 0..3 {
            let (o, d) = (ray.origin[k], ray.dir[k]);
            let (lo, hi) = (
                self.bounds.min[k] as f64 - 0.5,
                self.bounds.max[k] as f64 + 0.5,
            );
            if d == 0.0 {
                if o < lo || o > hi {
                    return false;
                }
                continue;
            }
            let (mut ta, mut tb) = ((lo - o) / d, (hi - o) / d);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            a = a.max(ta);
            b = b.min(tb);
            if a > b {
                return false;
            }
        }
        true
    }

    /// The coarsest cell of the sum's lattice around `ijk` (sizes 4096 down to 1, aligned)
    /// over which this member, not on the sum's lattice, is bounded by one of its own
    /// cells: the member's cell holding the voxel's centre, if the sum's cell maps inside
    /// it; else the member's range over the voxel.
    fn foreign_cell(&self, ijk: IVec3) -> (IVec3, i32, ValueRange) {
        const SIZES: [i32; 6] = [4096, 128, 8, 4, 2, 1];
        let (origin, b) = FieldSum::aligned(ijk, SIZES[0]);
        if !self.touches(&b) {
            return (origin, SIZES[0], ValueRange::ZERO);
        }
        let q = self.map(ijk.as_dvec3() + 0.5);
        let lim = (1i64 << 30) as f64;
        let c = self.field.cell_at(
            q.floor()
                .clamp(DVec3::splat(-lim), DVec3::splat(lim))
                .as_ivec3(),
        );
        let (lo, hi) = (c.origin.as_dvec3(), c.origin.as_dvec3() + c.size as f64);
        for s in SIZES {
            let (origin, _) = FieldSum::aligned(ijk, s);
            let o = origin.as_dvec3();
            let fits = (0..8).all(|k| {
                let corner =
                    o + DVec3::new((k & 1) as f64, ((k >> 1) & 1) as f64, ((k >> 2) & 1) as f64)
                        * s as f64;
                let p = self.map(corner);
                p.cmpge(lo).all() && p.cmple(hi).all()
            });
            if fits {
                return (origin, s, c.range);
            }
        }
        let (origin, b) = FieldSum::aligned(ijk, 1);
        (origin, 1, self.field.range_over(&self.map_box(&b)))
    }

    fn weighted(&self, r: ValueRange) -> ValueRange {
        if r.min > r.max {
            return ValueRange::ZERO;
        }
        let w = self.weight as f32;
        ValueRange {
            min: r.min * w,
            max: r.max * w,
        }
    }

    /// The member's placed index→world map.
    pub fn transform(&self) -> &IndexToWorld {
        &self.transform
    }

    pub fn field(&self) -> &Arc<dyn Field> {
        &self.field
    }

    pub fn weight(&self) -> f64 {
        self.weight
    }

    /// The member's weighted integrals over the pieces of a ray of the sum's local index
    /// space, as [`Field::piece_integrals`] (zeros where the ray misses it).
    pub fn piece_integrals(&self, ray: &IndexRay, t0: f64, ends: &[f64], out: &mut [f64]) {
        out.iter_mut().for_each(|o| *o = 0.0);
        if self.crossed(ray, t0, ends.last().copied().unwrap_or(t0)) {
            self.field
                .piece_integrals(&self.map_ray(ray), t0, ends, out);
            out.iter_mut().for_each(|o| *o *= self.weight);
        }
    }

    /// The member's value (unweighted) at the sum's local index point `p`.
    #[inline]
    pub fn value_at_sum_index(&self, p: DVec3) -> f32 {
        self.field.value_at_index(self.map(p))
    }
}

/// `Σ wᵢ·ρᵢ` over placed fields; see the module's documentation.
#[derive(Clone)]
pub struct FieldSum {
    members: Vec<Member>,
    transform: IndexToWorld,
}

/// Why a [`FieldSum`] cannot be made.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SumError {
    #[error("no volume to place")]
    Empty,
    #[error("the placement is singular or not finite")]
    Singular,
    #[error("the weight {0} is negative or not finite")]
    Weight(f64),
}

impl FieldSum {
    /// The sum of `members`: each a shared field, the world map to place it by
    /// (`placement · its own index→world`) and its weight.
    pub fn new(members: Vec<(Arc<dyn Field>, glam::DMat4, f64)>) -> Result<Self, SumError> {
        Self::framed(members, None)
    }

    /// As [`FieldSum::new`], with the local index space of `frame` (another sum's, so
    /// that a field placed as one of its members is on its lattice) for the sum's own.
    pub fn in_frame(
        members: Vec<(Arc<dyn Field>, glam::DMat4, f64)>,
        frame: IndexToWorld,
    ) -> Result<Self, SumError> {
        Self::framed(members, Some(frame))
    }

    fn framed(
        members: Vec<(Arc<dyn Field>, glam::DMat4, f64)>,
        frame: Option<IndexToWorld>,
    ) -> Result<Self, SumError> {
        let mut placed = Vec::with_capacity(members.len());
        for (field, placement, weight) in members {
            if !(weight >= 0.0 && weight.is_finite()) {
                return Err(SumError::Weight(weight));
            }
            let own = field.transform();
            let transform = IndexToWorld::new(placement * own.matrix(), own.origin)
                .ok_or(SumError::Singular)?;
            placed.push((field, transform, weight));
        }
        let first = frame.unwrap_or(placed.first().ok_or(SumError::Empty)?.1);
        let members = placed
            .into_iter()
            .map(|(field, transform, weight)| {
                let aligned = super::lattice_offset(&transform, &first).map(|o| o.as_ivec3());
                // member index = inv_i · (lin_0 · p + t_0 − t_i)
                let linear = transform.inverse_linear() * first.linear();
                let shift = transform.world_to_index(first.index_to_world(DVec3::ZERO));
                let mut m = Member {
                    field,
                    transform,
                    weight,
                    linear,
                    shift,
                    aligned,
                    bounds: IndexBox::EMPTY,
                };
                m.bounds = m.bounds_in(&first);
                m
            })
            .collect();
        Ok(FieldSum {
            members,
            transform: first,
        })
    }

    pub fn members(&self) -> &[Member] {
        &self.members
    }

    /// The distinct fields placed (each counted once however often it is placed).
    pub fn distinct_fields(&self) -> usize {
        let mut seen: Vec<*const ()> = Vec::new();
        for m in &self.members {
            let p = Arc::as_ptr(&m.field) as *const ();
            if !seen.contains(&p) {
                seen.push(p);
            }
        }
        seen.len()
    }

    /// The cell of the `size`-aligned lattice containing `ijk`, as a points box.
    fn aligned(ijk: IVec3, size: i32) -> (IVec3, IndexBox) {
        let shift = size.trailing_zeros() as i32;
        let origin = (ijk >> shift) << shift;
        let lo = origin.as_vec3();
        (origin, IndexBox::new(lo, lo + Vec3::splat(size as f32)))
    }
}

/// Is the cell `(o, s)` inside the cell `(outer_o, outer_s)`?
fn inside(o: IVec3, s: i32, outer_o: IVec3, outer_s: i32) -> bool {
    let (a, b) = (o.as_i64vec3(), outer_o.as_i64vec3());
    a.cmpge(b).all() && (a + s as i64).cmple(b + outer_s as i64).all()
}

impl Field for FieldSum {
    fn value_at_index(&self, p: DVec3) -> f32 {
        let mut v = 0.0f64;
        for m in self.members.iter().filter(|m| m.holds(p)) {
            v += m.weight * m.field.value_at_index(m.map(p)) as f64;
        }
        v as f32
    }

    fn transform(&self) -> &IndexToWorld {
        &self.transform
    }

    fn active_bounds(&self) -> IndexBox {
        self.members
            .iter()
            .fold(IndexBox::EMPTY, |b, m| b.union(&m.bounds))
    }

    fn cell_at(&self, ijk: IVec3) -> Cell {
        // Each member's own cell around ijk (the sum's index space): aligned members
        // give theirs; any other the coarsest aligned virtual cell it is empty over.
        let mut own: Vec<(IVec3, i32, ValueRange)> = Vec::with_capacity(self.members.len());
        for m in &self.members {
            let c = match m.aligned {
                Some(o) => {
                    let c = m.field.cell_at(ijk + o);
                    (c.origin - o, c.size, c.range)
                }
                None => m.foreign_cell(ijk),
            };
            own.push(c);
        }
        let (origin, size) = own
            .iter()
            .min_by_key(|c| c.1)
            .map(|c| (c.0, c.1))
            .unwrap_or((ijk, 1));
        let mut range = ValueRange::ZERO;
        for (m, c) in self.members.iter().zip(&own) {
            let lo = origin.as_vec3();
            let b = IndexBox::new(lo, lo + Vec3::splat(size as f32));
            let r = if inside(origin, size, c.0, c.1) {
                c.2
            } else if !m.touches(&b) {
                ValueRange::ZERO
            } else {
                m.field.range_over(&m.map_box(&b))
            };
            let r = m.weighted(r);
            range = ValueRange {
                min: range.min + r.min,
                max: range.max + r.max,
            };
        }
        Cell {
            origin,
            size,
            range,
        }
    }

    fn range_over(&self, b: &IndexBox) -> ValueRange {
        let mut range = ValueRange::ZERO;
        for m in self.members.iter().filter(|m| m.touches(b)) {
            let r = m.weighted(m.field.range_over(&m.map_box(b)));
            range = ValueRange {
                min: range.min + r.min,
                max: range.max + r.max,
            };
        }
        range
    }

    fn tight_range_over(&self, b: &IndexBox) -> ValueRange {
        let mut range = ValueRange::ZERO;
        for m in self.members.iter().filter(|m| m.touches(b)) {
            let r = m.weighted(m.field.tight_range_over(&m.map_box(b)));
            range = ValueRange {
                min: range.min + r.min,
                max: range.max + r.max,
            };
        }
        range
    }

    fn integral(&self, ray: &IndexRay, t0: f64, t1: f64) -> f64 {
        self.members
            .iter()
            .filter(|m| m.crossed(ray, t0, t1))
            .map(|m| m.weight * m.field.integral(&m.map_ray(ray), t0, t1))
            .sum()
    }

    fn piece_integrals(&self, ray: &IndexRay, t0: f64, ends: &[f64], out: &mut [f64]) {
        out.iter_mut().for_each(|o| *o = 0.0);
        let mut each = vec![0.0; out.len()];
        let t1 = ends.last().copied().unwrap_or(t0);
        for m in self.members.iter().filter(|m| m.crossed(ray, t0, t1)) {
            m.field
                .piece_integrals(&m.map_ray(ray), t0, ends, &mut each);
            for (o, v) in out.iter_mut().zip(&each) {
                *o += m.weight * v;
            }
        }
    }

    fn slopes_along(
        &self,
        ray: &IndexRay,
        t0: f64,
        targets: &[f64],
        side: &super::Sideways,
        out: &mut Vec<[f64; 4]>,
    ) -> bool {
        let start = out.len();
        let mut total = vec![[0.0f64; 4]; targets.len()];
        let mut each = Vec::with_capacity(targets.len());
        for m in &self.members {
            each.clear();
            let side = match m.aligned {
                Some(_) => *side,
                None => {
                    let map =
                        |a: super::Affine| super::Affine::new(m.linear * a.base, m.linear * a.rate);
                    super::Sideways {
                        a: map(side.a),
                        b: map(side.b),
                        c: map(side.c),
                    }
                }
            };
            if !m
                .field
                .slopes_along(&m.map_ray(ray), t0, targets, &side, &mut each)
                || each.len() != targets.len()
            {
                out.truncate(start);
                return false;
            }
            for (t, e) in total.iter_mut().zip(&each) {
                for k in 0..4 {
                    t[k] += m.weight * e[k];
                }
            }
        }
        out.extend(total);
        true
    }

    fn quadrature(&self) -> Quadrature {
        let q: Vec<Quadrature> = self.members.iter().map(|m| m.field.quadrature()).collect();
        if q.contains(&Quadrature::Approximate) {
            Quadrature::Approximate
        } else if q.contains(&Quadrature::ExactPerVoxel) {
            Quadrature::ExactPerVoxel
        } else {
            Quadrature::ClosedForm
        }
    }

    fn content_hash(&self) -> Option<u64> {
        use super::random::mix64;
        let mut h: u64 = 0x6d75_726b_7375_6d00;
        let mut eat = |v: u64| h = mix64(h ^ v).wrapping_add(0x9E37_79B9_7F4A_7C15);
        eat(self.members.len() as u64);
        for m in &self.members {
            eat(m.field.content_hash()?);
            for c in m.transform.matrix().to_cols_array() {
                eat(c.to_bits());
            }
            eat(m.weight.to_bits());
        }
        Some(h)
    }

    /// Each distinct field once, however often it is placed, and the placements.
    fn memory_bytes(&self) -> usize {
        let mut seen: Vec<*const ()> = Vec::new();
        let mut bytes =
            std::mem::size_of::<Self>() + self.members.len() * std::mem::size_of::<Member>();
        for m in &self.members {
            let p = Arc::as_ptr(&m.field) as *const ();
            if !seen.contains(&p) {
                seen.push(p);
                bytes += m.field.memory_bytes();
            }
        }
        bytes
    }
}

#[cfg(test)]
mod tests;
