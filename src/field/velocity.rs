//! Velocity fields (a constant one, a cache's velocity grid) and [`RayFlow`], the
//! displacement they cause along one ray at one time, which the advected fields of
//! [`super::advect`] share.

use super::{Field, VoxelGrid};
use glam::DVec3;

/// A velocity at every world point, world units per unit of time.
pub trait VelocityField: Send + Sync {
    fn velocity_at_world(&self, p: DVec3) -> DVec3;
    /// A bound on the speed anywhere.
    fn max_speed(&self) -> f64;
    /// The world distance over which the velocity is about linear (its voxel): a ray's
    /// displacement is looked up this far apart and interpolated between ([`RayFlow`]).
    fn knot_spacing(&self) -> f64;
}

/// The same velocity everywhere.
#[derive(Clone, Copy, Debug)]
pub struct ConstantVelocity(pub DVec3);

impl VelocityField for ConstantVelocity {
    fn velocity_at_world(&self, _: DVec3) -> DVec3 {
        self.0
    }
    fn max_speed(&self) -> f64 {
        self.0.length()
    }
    fn knot_spacing(&self) -> f64 {
        f64::INFINITY
    }
}

/// A velocity grid: a vec3 [`VoxelGrid`] (Houdini's `vel`, Blender's `velocity`), or
/// three float grids one per component (`vel.x`, `vel.y`, `vel.z`); trilinear, zero
/// outside the active voxels. A staggered grid (OpenVDB's `staggered` class, as
/// Mantaflow writes its MAC velocity) holds each component on the voxel face below it
/// along its axis, half a voxel from the centre, and is read there.
pub struct GridVelocity {
    /// One vec3 grid, or three float grids x, y, z.
    grids: Vec<VoxelGrid>,
    staggered: bool,
    max_speed: f64,
    /// Speeds above this are clamped to it.
    limit: f64,
}

impl GridVelocity {
    /// A vec3 grid (`None` where it has fewer than three channels).
    pub fn vector(grid: VoxelGrid, staggered: bool) -> Option<Self> {
        if grid.channels() < 3 {
            return None;
        }
        let s = grid.stats();
        let bound = |c: usize| {
            let lo = s.min.get(c).copied().unwrap_or(0.0).abs();
            let hi = s.max.get(c).copied().unwrap_or(0.0).abs();
            lo.max(hi)
        };
        let max_speed = DVec3::new(bound(0), bound(1), bound(2)).length();
        Some(GridVelocity {
            grids: vec![grid],
            staggered,
            max_speed,
            limit: f64::INFINITY,
        })
    }

    /// Three float grids of signed values, x, y, z.
    pub fn channels(xyz: [VoxelGrid; 3], staggered: bool) -> Self {
        let bound = |g: &VoxelGrid| {
            let s = g.stats();
            let lo = s.min.first().copied().unwrap_or(0.0).abs();
            let hi = s.max.first().copied().unwrap_or(0.0).abs();
            lo.max(hi)
        };
        let max_speed = DVec3::new(bound(&xyz[0]), bound(&xyz[1]), bound(&xyz[2])).length();
        GridVelocity {
            grids: xyz.into(),
            staggered,
            max_speed,
            limit: f64::INFINITY,
        }
    }

    /// Speeds above `limit` clamped to it.
    pub fn limited(mut self, limit: f64) -> Self {
        self.limit = limit.max(0.0);
        self
    }

    /// The speed bound before any limit: the largest the file's values allow.
    pub fn file_max_speed(&self) -> f64 {
        self.max_speed
    }
}

impl VelocityField for GridVelocity {
    fn velocity_at_world(&self, p: DVec3) -> DVec3 {
        // Component c of a staggered grid sits half a voxel below the centre along c.
        let half = if self.staggered { 0.5 } else { 0.0 };
        let at = |c: usize, i: DVec3| {
            let mut q = i;
            q[c] += half;
            q
        };
        let v = match &self.grids[..] {
            [g] => {
                let i = Field::transform(g).world_to_index(p);
                let [x, y, z] = g.sample_components([at(0, i), at(1, i), at(2, i)]);
                DVec3::new(x as f64, y as f64, z as f64)
            }
            [x, y, z] => {
                let one = |c: usize, g: &VoxelGrid| {
                    g.sample_channel(at(c, Field::transform(g).world_to_index(p)), 0) as f64
                };
                DVec3::new(one(0, x), one(1, y), one(2, z))
            }
            _ => DVec3::ZERO,
        };
        if self.limit.is_finite() {
            v.clamp_length_max(self.limit)
        } else {
            v
        }
    }
    fn max_speed(&self) -> f64 {
        self.max_speed.min(self.limit)
    }
    fn knot_spacing(&self) -> f64 {
        self.grids
            .iter()
            .map(|g| Field::transform(g).voxel_size().min_element())
            .fold(f64::INFINITY, f64::min)
    }
}

/// Knots a [`RayFlow`] keeps at once: a window that slides along the ray.
const FLOW_KNOTS: usize = 64;

/// The world displacement along one world ray at one time offset, shared by every field
/// marched on the ray (density, emission, temperature, colour): two-step backward
/// advection at knots [`VelocityField::knot_spacing`] apart along the ray, each looked
/// up once, linear between them. Exact for a uniform flow, and for one linear along the
/// ray between knots; elsewhere the error is second order in the velocity's voxel.
pub struct RayFlow<'a> {
    velocity: &'a dyn VelocityField,
    shift: f64,
    origin: DVec3,
    /// Unit length.
    dir: DVec3,
    spacing: f64,
    knots: std::sync::Mutex<FlowKnots>,
}

/// The knots looked up so far: `first`, and the displacement at each of the next
/// [`FLOW_KNOTS`] where known.
struct FlowKnots {
    first: i64,
    at: [Option<DVec3>; FLOW_KNOTS],
}

impl<'a> RayFlow<'a> {
    /// The flow along the ray `origin + t·dir` (`dir` of unit length) `shift` time units
    /// from the frame.
    pub fn new(velocity: &'a dyn VelocityField, shift: f64, origin: DVec3, dir: DVec3) -> Self {
        RayFlow {
            velocity,
            shift,
            origin,
            dir,
            spacing: velocity.knot_spacing(),
            knots: std::sync::Mutex::new(FlowKnots {
                first: i64::MIN,
                at: [None; FLOW_KNOTS],
            }),
        }
    }

    /// The knots' spacing (world units along the ray; infinite for a uniform flow).
    pub fn spacing(&self) -> f64 {
        self.spacing
    }

    /// The displacement at knot `k` (`k·spacing` along the ray; the ray's origin for a
    /// uniform flow).
    pub fn knot_displacement(&self, k: i64) -> DVec3 {
        if !(self.spacing.is_finite() && self.spacing > 0.0) {
            return self.knot(0, 0.0);
        }
        self.knot(k, self.spacing)
    }

    /// How far along the ray world point `x` is, where it lies on the ray.
    pub fn param_of(&self, x: DVec3) -> Option<f64> {
        let t = (x - self.origin).dot(self.dir);
        let off = x - (self.origin + self.dir * t);
        let scale = 1.0 + x.abs().max_element() + self.origin.abs().max_element();
        (off.length() <= 1e-9 * scale).then_some(t)
    }

    /// The world displacement at world point `x` where it lies on the ray (`None`
    /// elsewhere, and where the knots are not usable).
    pub fn displacement_at(&self, x: DVec3) -> Option<DVec3> {
        if self.shift == 0.0 {
            return Some(DVec3::ZERO);
        }
        let t = self.param_of(x)?;
        if !(self.spacing.is_finite() && self.spacing > 0.0) {
            // A uniform flow: the displacement anywhere is the one at the origin.
            return Some(self.knot(0, 0.0));
        }
        let s = t / self.spacing;
        if !(s.abs() < 1e15) {
            return None;
        }
        let k = s.floor();
        let f = s - k;
        let k = k as i64;
        let d0 = self.knot(k, self.spacing);
        if f == 0.0 {
            return Some(d0);
        }
        Some(d0.lerp(self.knot(k + 1, self.spacing), f))
    }

    /// The displacement at knot `k` (at `k·spacing` along the ray), looked up once.
    fn knot(&self, k: i64, spacing: f64) -> DVec3 {
        let mut knots = match self.knots.lock() {
            Ok(g) => g,
            Err(poisoned) => poisoned.into_inner(),
        };
        let n = FLOW_KNOTS as i64;
        if k < knots.first || k >= knots.first.saturating_add(n) {
            // Slide the window to start a little before `k`: the march goes forward.
            knots.first = k - 2;
            knots.at = [None; FLOW_KNOTS];
        }
        let slot = (k - knots.first) as usize;
        if let Some(d) = knots.at[slot] {
            return d;
        }
        let x = self.origin + self.dir * (k as f64 * spacing);
        let v0 = self.velocity.velocity_at_world(x);
        let v1 = self.velocity.velocity_at_world(x - v0 * self.shift);
        let d = v1 * self.shift;
        let d = if d.is_finite() { d } else { DVec3::ZERO };
        knots.at[slot] = Some(d);
        d
    }
}
