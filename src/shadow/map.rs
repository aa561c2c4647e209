//! The deep shadow map of one light: `∫ρ ds` toward the light (density × world length;
//! optical depth is this times σt) on a sparse, adaptive light-space lattice.
//!
//! The lattice (see [`super::chart`]) is cut into bricks of [`BRICK`]³ steps. Only bricks
//! that touch the density's active region (dilated by the trilinear stencil) exist. Each
//! brick holds its values at one *level*: level ℓ samples it every `BRICK / 2^ℓ` steps,
//! `(2^ℓ + 1)³` samples, from one per corner (ℓ = 0, an 8³ region) through one per voxel
//! ([`VOXEL_LEVEL`]) to a quarter voxel ([`MAX_LEVEL`]).
//!
//! Each sample holds `τ = ∫ρ ds`, the density `ρ` there (τ's slope along the column),
//! τ's slopes across the light `∂τ/∂x`, `∂τ/∂y` and its twist `∂²τ/∂x∂y`. A lookup is
//! cubic Hermite along the column on each of the four columns around the point, then
//! bicubic Hermite across them. Across the light is where τ is least smooth: trilinear
//! density has kinks at every voxel face, so τ's curvature across the light jumps, and
//! a bilinear blend errs by ~σ·ρ·voxel/8 in optical depth (2–5e-2 in transmittance on
//! the fixtures at one sample per voxel). With the slopes the blend is exact for cubics
//! and the error falls about tenfold at one sample per voxel and fifty-fold at two.
//!
//! That is a brick's [`BrickForm::Hermite`] (12 bytes a sample). Where the bake finds less
//! enough, a brick holds τ alone as 16-bit steps above its least τ, blended trilinearly
//! ([`BrickForm::Linear`], 2 bytes), or, where the light reaching its top is already below
//! the tolerance, one τ ([`BrickForm::Constant`], no samples).

pub use super::brick::EncodedBrick;
pub use super::brick::{
    BRICK, BrickForm, BrickSamples, LEVELS, MAX_LEVEL, PackedBrick, PackedSample, QUANTITIES,
    Samples, VOXEL_LEVEL, hermite, linear_rounding_error, reconstruct, side, spacing, trilinear,
};
use super::chart::Chart;
use crate::field::floor::floor_dvec3;
use glam::{DVec3, IVec3};

/// One brick: its lattice position (in bricks), its level and form, where its samples
/// start and how to read them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Brick {
    pub key: IVec3,
    pub level: u8,
    pub form: BrickForm,
    /// Index of its first sample in the map's store for its form.
    pub offset: u32,
    /// Hermite: the scales of the packed slopes. Linear: τ's base and step, then 0, 0.
    /// Constant: τ, then 0, 0, 0.
    pub(super) scales: [f32; QUANTITIES - 1],
}

/// A brick as a bake or a cache hands it to [`ChartMap::new`]: Hermite needs every
/// quantity at all `side(level)³` samples, Linear τ alone, Constant one τ (the first).
#[derive(Clone, Debug, PartialEq)]
pub struct BakedBrick {
    pub key: IVec3,
    pub level: u8,
    pub form: BrickForm,
    pub samples: BrickSamples,
}

/// The bricks of one chart, with a dense table from brick position to brick.
#[derive(Clone, Debug)]
pub struct ChartMap {
    pub chart: Chart,
    pub(super) lo: IVec3,
    pub(super) dims: IVec3,
    pub(super) slots: Vec<u32>,
    pub bricks: Vec<Brick>,
    /// Per Hermite brick: its samples, x fastest.
    pub(super) samples: Vec<PackedSample>,
    /// Per Linear brick: its τ steps, x fastest.
    pub(super) linear: Vec<u16>,
}

pub(super) const NO_BRICK: u32 = u32::MAX;

/// Bricks packed between two returns of freed memory.
const RELEASE_EVERY: usize = 8192;

impl ChartMap {
    /// A map from finished bricks; `None` if the table of brick positions would exceed
    /// `max_slots` entries or a brick lacks samples its form needs.
    pub fn new(chart: Chart, bricks: Vec<BakedBrick>, max_slots: usize) -> Option<Self> {
        let held = |form: BrickForm| {
            bricks
                .iter()
                .filter(|b| b.form == form)
                .map(|b| side(b.level).pow(3))
                .sum()
        };
        let mut map = ChartMap::empty(chart, bricks.iter().map(|b| b.key), max_slots)?;
        map.samples.reserve_exact(held(BrickForm::Hermite));
        map.linear.reserve_exact(held(BrickForm::Linear));
        map.bricks.reserve_exact(bricks.len());
        for (i, baked) in bricks.into_iter().enumerate() {
            if i % RELEASE_EVERY == RELEASE_EVERY - 1 {
                // The bricks packed so far are freed: give their memory back, so the
                // packed copy does not come on top of all of it.
                crate::mem::release_freed_memory();
            }
            map.push(baked.key, baked.level, baked.form, &baked.samples)?;
        }
        Some(map)
    }

    /// A map with no bricks yet, whose position table covers `keys` (the bricks to be
    /// [`push`](Self::push)ed); `None` past `max_slots` entries.
    pub fn empty(
        chart: Chart,
        keys: impl Iterator<Item = IVec3>,
        max_slots: usize,
    ) -> Option<Self> {
        let (mut lo, mut hi) = (IVec3::MAX, IVec3::MIN);
        for k in keys {
            lo = lo.min(k);
            hi = hi.max(k);
        }
        let dims = if lo.cmpgt(hi).any() {
            IVec3::ZERO
        } else {
            hi - lo + IVec3::ONE
        };
        let n = dims.x as usize * dims.y as usize * dims.z as usize;
        if n > max_slots {
            return None;
        }
        Some(ChartMap {
            chart,
            lo,
            dims,
            slots: vec![NO_BRICK; n],
            bricks: Vec::new(),
            samples: Vec::new(),
            linear: Vec::new(),
        })
    }

    /// Packs one finished brick into the map: Hermite needs every quantity at all
    /// `side(level)³` samples, Linear τ alone, Constant one τ (the first). `None` if the
    /// brick lies outside the position table or lacks samples its form needs. The packing
    /// depends on the brick alone, so the order bricks come in changes no lookup.
    pub fn push(
        &mut self,
        key: IVec3,
        level: u8,
        form: BrickForm,
        samples: &BrickSamples,
    ) -> Option<()> {
        self.slot_index(key)?;
        self.push_encoded(key, &EncodedBrick::new(level, form, samples)?)
    }

    /// Appends a brick [`EncodedBrick::new`] packed: what [`push`](Self::push) does, with
    /// the packing (the costly part) done before, anywhere (the bake packs a batch's
    /// bricks in parallel and appends them in key order).
    pub fn push_encoded(&mut self, key: IVec3, brick: &EncodedBrick) -> Option<()> {
        self.push_encoded_all(&[(key, brick)])
    }

    /// Appends `bricks` in order, as [`push_encoded`](Self::push_encoded) would one by
    /// one, with their samples copied into the stores on all threads: a bake's batch
    /// brings up to a hundred MB of them, and copied on one thread (with the stores'
    /// fresh pages faulted in on first touch) they held every other thread up.
    pub fn push_encoded_all(&mut self, bricks: &[(IVec3, &EncodedBrick)]) -> Option<()> {
        let (mut hermite, mut linear) = (Vec::new(), Vec::new());
        let (mut h, mut l) = (self.samples.len(), self.linear.len());
        for &(key, brick) in bricks {
            let slot = self.slot_index(key)?;
            let offset = match brick.form {
                BrickForm::Hermite => {
                    let offset = u32::try_from(h).ok()?;
                    h += brick.hermite.len();
                    hermite.push(&brick.hermite[..]);
                    offset
                }
                BrickForm::Linear => {
                    let offset = u32::try_from(l).ok()?;
                    l += brick.linear.len();
                    linear.push(&brick.linear[..]);
                    offset
                }
                BrickForm::Constant => 0,
            };
            self.slots[slot] = self.bricks.len() as u32;
            self.bricks.push(Brick {
                key,
                level: brick.level,
                form: brick.form,
                offset,
                scales: brick.scales,
            });
        }
        crate::mem::extend_on_all_threads(&mut self.samples, &hermite);
        crate::mem::extend_on_all_threads(&mut self.linear, &linear);
        Some(())
    }

    /// Room for `bricks` more bricks of up to `samples` samples in all, in either form:
    /// an upper bound costs address space only, and the stores then never grow by
    /// copying, which would leave the old copies' pages behind on the heap.
    pub fn reserve(&mut self, bricks: usize, samples: usize) {
        self.bricks.reserve_exact(bricks);
        self.samples.reserve_exact(samples);
        self.linear.reserve_exact(samples);
    }

    /// Takes the brick at `key` out of the position table (a lookup there then finds
    /// none); [`drop_replaced`](Self::drop_replaced) reclaims its room.
    pub fn forget(&mut self, key: IVec3) {
        if let Some(slot) = self.slot_index(key) {
            self.slots[slot] = NO_BRICK;
        }
    }

    /// Drops the bricks a later [`push`](Self::push) at the same position replaced or
    /// [`forget`](Self::forget) took out, and their samples, then gives back the room the stores grew beyond what they hold.
    /// Bricks keep their order; samples move down in place.
    pub fn drop_replaced(&mut self) {
        let mut kept = 0usize;
        let (mut to_samples, mut to_linear) = (0usize, 0usize);
        for i in 0..self.bricks.len() {
            let b = self.bricks[i];
            // `push` refuses a brick without a slot, so every brick has one.
            let Some(slot) = self.slot_index(b.key) else {
                continue;
            };
            if self.slots[slot] as usize != i {
                continue;
            }
            let n = side(b.level).pow(3);
            let offset = b.offset as usize;
            let moved = match b.form {
                BrickForm::Hermite => {
                    self.samples.copy_within(offset..offset + n, to_samples);
                    to_samples += n;
                    to_samples - n
                }
                BrickForm::Linear => {
                    self.linear.copy_within(offset..offset + n, to_linear);
                    to_linear += n;
                    to_linear - n
                }
                BrickForm::Constant => offset,
            };
            self.slots[slot] = kept as u32;
            self.bricks[kept] = Brick {
                offset: moved as u32,
                ..b
            };
            kept += 1;
        }
        self.bricks.truncate(kept);
        self.samples.truncate(to_samples);
        self.linear.truncate(to_linear);
        self.bricks.shrink_to_fit();
        self.samples.shrink_to_fit();
        self.linear.shrink_to_fit();
    }

    fn slot_index(&self, key: IVec3) -> Option<usize> {
        let r = key - self.lo;
        if r.cmplt(IVec3::ZERO).any() || r.cmpge(self.dims).any() {
            return None;
        }
        Some(
            r.x as usize
                + self.dims.x as usize * (r.y as usize + self.dims.y as usize * r.z as usize),
        )
    }

    /// The brick holding lattice point `q`, if the map has one. Bricks are closed boxes:
    /// a point on a face shared with a missing brick belongs to the one that exists, so
    /// the lookup is continuous across the edge of the map.
    pub fn brick_at(&self, q: DVec3) -> Option<&Brick> {
        let s = q / BRICK as f64;
        let b = floor_dvec3(s);
        if let Some(brick) = self.brick_with_key(b) {
            return Some(brick);
        }
        // On a face (or edge, or corner) the lower neighbours hold the point too.
        let on_face = s.cmpeq(b);
        if !on_face.any() {
            return None;
        }
        (1..8u32)
            .map(|m| {
                let d = DVec3::new(
                    f64::from(m & 1),
                    f64::from((m >> 1) & 1),
                    f64::from((m >> 2) & 1),
                );
                (m, b - d)
            })
            .filter(|(m, _)| {
                (m & 1 == 0 || on_face.test(0))
                    && (m & 2 == 0 || on_face.test(1))
                    && (m & 4 == 0 || on_face.test(2))
            })
            .find_map(|(_, k)| self.brick_with_key(k))
    }

    fn brick_with_key(&self, b: DVec3) -> Option<&Brick> {
        let lo = self.lo.as_dvec3();
        if !(b.cmpge(lo).all() && b.cmplt(lo + self.dims.as_dvec3()).all()) {
            return None;
        }
        let slot = self.slots[self.slot_index(b.as_ivec3())?];
        (slot != NO_BRICK).then(|| &self.bricks[slot as usize])
    }

    /// `∫ρ ds` toward the light at lattice point `q`. Inside a brick, the trilinear blend
    /// of its values. Elsewhere there is no density, so the integral is the one at the
    /// bottom face of the nearest brick above `q` in its column stack, or 0 if none is.
    #[inline]
    pub fn density_integral_at(&self, q: DVec3) -> f64 {
        if let Some(b) = self.brick_at(q) {
            return self.blend(b, q);
        }
        let b = floor_dvec3(q / BRICK as f64);
        let lo = self.lo.as_dvec3();
        let hi = lo + self.dims.as_dvec3();
        if !(b.x >= lo.x && b.x < hi.x && b.y >= lo.y && b.y < hi.y && b.z >= lo.z) {
            return 0.0;
        }
        let (bx, by) = (b.x as i32, b.y as i32);
        let top = (b.z.min(hi.z) as i32) - 1;
        for bz in (self.lo.z..=top).rev() {
            if let Some(slot) = self.slot_index(IVec3::new(bx, by, bz))
                && self.slots[slot] != NO_BRICK
            {
                let brick = &self.bricks[self.slots[slot] as usize];
                return self.blend(brick, DVec3::new(q.x, q.y, (bz + 1) as f64 * BRICK as f64));
            }
        }
        0.0
    }

    /// τ at `q` (clamped into the brick) from `brick`'s values: [`reconstruct`] for a
    /// Hermite brick, trilinear for a Linear one, its one τ for a Constant one.
    #[inline]
    fn blend(&self, brick: &Brick, q: DVec3) -> f64 {
        if brick.form == BrickForm::Constant {
            return brick.scales[0] as f64;
        }
        let n = (1i32 << brick.level) as f64;
        let h = spacing(brick.level);
        // × 1/h rather than ÷ h: both are powers of two, so this is exact and cheaper.
        let local = ((q - brick.key.as_dvec3() * BRICK as f64) * (n / BRICK as f64))
            .clamp(DVec3::ZERO, DVec3::splat(n));
        let i = floor_dvec3(local).min(DVec3::splat(n - 1.0));
        let f = local - i;
        let i = i.as_uvec3();
        let m = side(brick.level);
        if brick.form == BrickForm::Linear {
            let v = &self.linear[brick.offset as usize..][..m * m * m];
            let base = i.x as usize + m * (i.y as usize + m * i.z as usize);
            return brick.scales[0] as f64
                + brick.scales[1] as f64 * trilinear(|k| v[base + k] as f64, m, f);
        }
        reconstruct(
            &self.packed_brick(brick),
            m,
            [i.x as usize, i.y as usize, i.z as usize],
            f,
            h,
            self.chart.unit,
            self.chart.lateral,
        )
    }

    /// Bytes held: values, bricks and the position table.
    pub fn memory_bytes(&self) -> usize {
        self.samples.len() * std::mem::size_of::<PackedSample>()
            + self.linear.len() * 2
            + self.bricks.len() * std::mem::size_of::<Brick>()
            + self.slots.len() * 4
    }

    /// Values held at each level (a Constant brick holds none).
    pub fn points_per_level(&self) -> [u64; LEVELS] {
        let mut n = [0u64; LEVELS];
        for b in self.bricks.iter().filter(|b| b.form != BrickForm::Constant) {
            n[b.level as usize] += side(b.level).pow(3) as u64;
        }
        n
    }

    /// Bricks of each form, in [`BrickForm::code`] order.
    pub fn bricks_per_form(&self) -> [u64; 3] {
        let mut n = [0u64; 3];
        for b in &self.bricks {
            n[b.form.code() as usize] += 1;
        }
        n
    }

    #[inline]
    fn packed_brick(&self, b: &Brick) -> PackedBrick<'_> {
        PackedBrick {
            samples: &self.samples[b.offset as usize..][..side(b.level).pow(3)],
            scales: b.scales,
        }
    }

    /// Quantity `q` ([`BrickSamples::planes`] order) of brick `b`'s samples, as the map
    /// holds them: `side(level)³` values, x fastest (a Linear or Constant brick holds τ
    /// alone: its other quantities read 0).
    pub fn brick_quantity(&self, b: &Brick, q: usize) -> Vec<f32> {
        let n = side(b.level).pow(3);
        match b.form {
            BrickForm::Hermite => {
                let packed = self.packed_brick(b);
                (0..n).map(|k| packed.get(q, k) as f32).collect()
            }
            _ if q != 0 => vec![0.0; n],
            BrickForm::Linear => self.linear[b.offset as usize..][..n]
                .iter()
                .map(|&u| b.scales[0] + b.scales[1] * u as f32)
                .collect(),
            BrickForm::Constant => vec![b.scales[0]; n],
        }
    }
}

/// How a world point picks its chart.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ChartSelect {
    /// The map has one chart.
    Single,
    /// Six cube faces around a point light, in [`Chart::cube_faces`] order.
    CubeFaces { light: DVec3 },
}

/// The cube face (in [`Chart::cube_faces`] order) that serves direction `d`.
#[inline]
pub fn cube_face(d: DVec3) -> usize {
    let a = d.abs();
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    2 * axis + usize::from(d[axis] < 0.0)
}

/// One light's deep shadow map.
#[derive(Clone, Debug)]
pub struct ShadowMap {
    pub charts: Vec<ChartMap>,
    pub select: ChartSelect,
}

impl ShadowMap {
    /// `∫ρ ds` from world point `p` toward the light, anywhere: 0 where no density lies
    /// between (upstream of the volume, or behind a point light that faces away from it).
    #[inline]
    pub fn density_integral(&self, p: DVec3) -> f64 {
        let chart = match self.select {
            ChartSelect::Single => self.charts.first(),
            ChartSelect::CubeFaces { light } => self.charts.get(cube_face(p - light)),
        };
        chart
            .and_then(|c| Some(c.density_integral_at(c.chart.to_lattice(p)?)))
            .unwrap_or(0.0)
    }

    pub fn memory_bytes(&self) -> usize {
        self.charts.iter().map(ChartMap::memory_bytes).sum()
    }

    pub fn points_per_level(&self) -> [u64; LEVELS] {
        let mut n = [0u64; LEVELS];
        for c in &self.charts {
            for (a, b) in n.iter_mut().zip(c.points_per_level()) {
                *a += b;
            }
        }
        n
    }

    /// Bricks of each form, in [`BrickForm::code`] order.
    pub fn bricks_per_form(&self) -> [u64; 3] {
        let mut n = [0u64; 3];
        for c in &self.charts {
            for (a, b) in n.iter_mut().zip(c.bricks_per_form()) {
                *a += b;
            }
        }
        n
    }

    pub fn brick_count(&self) -> usize {
        self.charts.iter().map(|c| c.bricks.len()).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lookup_is_exact_for_cubics_and_exact_at_its_samples() {
        let chart = Chart::parallel(DVec3::Z, DVec3::ZERO, 1.0);
        // Level 1 brick at (0,0,0), spacing 4 (lattice units = world units here):
        // τ = x³/64 + 2y + xy/8 + z³/64, so ρ = dτ/dz = 3z²/64, ∂τ/∂x = 3x²/64 + y/8,
        // ∂τ/∂y = 2 + x/8, ∂²τ/∂x∂y = 1/8. Hermite in each direction reproduces it.
        let f = |q: DVec3| q.x.powi(3) / 64.0 + 2.0 * q.y + q.x * q.y / 8.0 + q.z.powi(3) / 64.0;
        let mut samples = BrickSamples::default();
        for k in 0..3 {
            for j in 0..3 {
                for i in 0..3 {
                    let q = DVec3::new(i as f64, j as f64, k as f64) * 4.0;
                    samples.tau.push(f(q) as f32);
                    samples.rho.push((3.0 * q.z * q.z / 64.0) as f32);
                    samples
                        .tau_x
                        .push((3.0 * q.x * q.x / 64.0 + q.y / 8.0) as f32);
                    samples.tau_y.push((2.0 + q.x / 8.0) as f32);
                    samples.tau_xy.push(0.125);
                }
            }
        }
        let brick = BakedBrick {
            key: IVec3::ZERO,
            level: 1,
            form: BrickForm::Hermite,
            samples,
        };
        let map = ChartMap::new(chart, vec![brick], 1 << 20).unwrap();
        for q in [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(8.0, 8.0, 8.0),
            DVec3::new(3.5, 5.25, 7.0),
            DVec3::new(1.1, 6.9, 2.3),
        ] {
            let v = map.density_integral_at(q);
            assert!(
                (v - f(q)).abs() < 1e-5 * f(q).max(1.0),
                "{q}: {v} vs {}",
                f(q)
            );
        }
        // Beside the stack and upstream of it: nothing in between.
        assert_eq!(map.density_integral_at(DVec3::new(-0.5, 1.0, 1.0)), 0.0);
        assert_eq!(map.density_integral_at(DVec3::new(1.0, 1.0, -0.5)), 0.0);
        // Downstream: the value at the stack's bottom face.
        let below = map.density_integral_at(DVec3::new(1.0, 2.0, 40.0));
        assert!(
            (below - f(DVec3::new(1.0, 2.0, 8.0))).abs() < 1e-5,
            "{below}"
        );
        assert_eq!(map.points_per_level()[1], 27);
    }

    #[test]
    fn cube_faces_match_their_charts() {
        let faces = Chart::cube_faces(DVec3::ZERO, 1.0, 0.1);
        for d in [
            DVec3::X,
            -DVec3::X,
            DVec3::Y,
            -DVec3::Y,
            DVec3::Z,
            -DVec3::Z,
        ] {
            let f = cube_face(d + DVec3::splat(0.1));
            assert!(faces[f].e3.dot(d) > 0.99, "{d} → face {f}");
        }
    }
}
