//! What a bake is asked for (where the light is, the settings) and what it reports: the
//! types the bake's steps ([`lattice`](super::lattice), [`refine`](super::refine),
//! [`columns`](super::columns)) and the cache share.

use super::map::{MAX_LEVEL, ShadowMap, VOXEL_LEVEL};
use glam::DVec3;

/// Where a light is, as far as shadows care.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightGeometry {
    /// A sun: the unit direction its light travels.
    Sun { travel: DVec3 },
    /// A point light at a world position.
    Point { position: DVec3 },
}

impl LightGeometry {
    /// The light's placement in words, which is all a shadow map depends on:
    /// `sun:DX,DY,DZ` (the direction toward the sun) or `point:X,Y,Z`, full precision.
    pub fn placement(&self) -> String {
        let (kind, v) = match *self {
            LightGeometry::Sun { travel } => ("sun", -travel),
            LightGeometry::Point { position } => ("point", position),
        };
        format!("{kind}:{:?},{:?},{:?}", v.x, v.y, v.z)
    }

    /// Unit direction from `x` toward the light and the distance to it.
    pub fn toward(&self, x: DVec3) -> (DVec3, f64) {
        match *self {
            LightGeometry::Sun { travel } => (-travel, f64::INFINITY),
            LightGeometry::Point { position } => {
                let d = position - x;
                let r = d.length();
                (if r > 0.0 { d / r } else { DVec3::Y }, r)
            }
        }
    }
}

/// The default [`BakeSettings::max_cells`]: about 20 s of one core (slopes along a
/// column cost ~70 ns a cell). The fixtures' bakes cross 50 times fewer or less.
pub const MAX_COLUMN_CELLS: f64 = 3e8;

/// What a bake is asked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BakeSettings {
    /// Largest transmittance error allowed, absolute.
    pub tolerance: f64,
    /// Extinction per unit density for each channel (σt × density scale).
    pub sigma_t: DVec3,
    /// Finest level a brick may reach.
    pub max_level: u8,
    /// Largest number of bricks (over all charts) before the lattice is made coarser.
    pub max_bricks: usize,
    /// Largest number of samples held before refinement stops.
    pub max_values: usize,
    /// Largest number of density cells the light columns may cross, over the whole bake
    /// (a bound computed before marching: see [`column_cells`](super::lattice::column_cells)). Past it at the coarsest
    /// level the lattice is made coarser; past it later refinement stops. This bounds the
    /// bake's time whatever the voxels' shape or the grid's size.
    pub max_cells: f64,
}

impl BakeSettings {
    pub fn new(tolerance: f64, sigma_t: DVec3) -> Self {
        BakeSettings {
            tolerance,
            sigma_t,
            max_level: finest_level(tolerance),
            max_bricks: 4 << 20,
            max_values: 16 << 20,
            max_cells: MAX_COLUMN_CELLS,
        }
    }
}

/// The finest level a bake at `tolerance` may refine to. With the map's Hermite blend,
/// one sample per voxel leaves at most ~3.5e-3 of transmittance error on the fixtures
/// (where τ curves sharply across the light), half a voxel ~6e-4 and a quarter ~1e-4:
/// so one voxel from 5e-3 up, half a voxel down to 1e-3 (the default), a quarter below.
pub fn finest_level(tolerance: f64) -> u8 {
    if tolerance >= 5e-3 {
        VOXEL_LEVEL
    } else if tolerance >= 1e-3 {
        VOXEL_LEVEL + 1
    } else {
        MAX_LEVEL
    }
}

/// What a bake did.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct BakeReport {
    /// Lattice step in world units (the density's smallest voxel edge, or a multiple).
    pub lattice_step: f64,
    pub charts: usize,
    pub bricks: usize,
    /// Samples held at each level (0: one per 8³ brick corner; 3: one per voxel).
    pub points_per_level: Vec<u64>,
    /// Bricks likely over the tolerance: kept at the finest level after missing the
    /// check at the level before by more than refining gains (see `SUB_VOXEL_GAIN`), or
    /// stopped early when the sample budget ran out.
    pub bricks_over_tolerance: usize,
    /// Of those, bricks whose refinement the sample or work budget stopped.
    pub bricks_stopped_by_budget: usize,
    /// What to expect on the bricks over the tolerance: the largest transmittance error
    /// measured one level coarser than the level kept (for those kept at the finest level,
    /// divided by the gain refining is known to give). 0 when none.
    pub over_tolerance_error: f64,
    /// Times the lattice was made twice coarser than the density's voxel because the
    /// bricks or columns of the finer one did not fit the budget (0: voxel lattice).
    pub lattice_coarsenings: usize,
    /// Bricks held as τ alone in 16 bits, blended trilinearly (see [`BrickForm::Linear`](super::map::BrickForm::Linear)).
    pub linear_bricks: usize,
    /// Bricks held as one τ: the light reaching them is below the tolerance already
    /// (see [`BrickForm::Constant`](super::map::BrickForm::Constant)).
    pub dark_bricks: usize,
    /// Light columns marched.
    pub columns: u64,
    pub memory_bytes: usize,
    /// Where the bake's time went (none for a map read from a cache).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub phases: Option<BakePhases>,
}

/// Where a bake's wall time went, in seconds. The columns of one batch are marched while
/// the batch before is decided and packed, so `columns_seconds` overlaps
/// `decisions_seconds` and `packing_seconds`; the others are each their own stretch of
/// the bake.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct BakePhases {
    /// Finding the bricks: the density's blocks mapped into the light's charts.
    pub marking_seconds: f64,
    /// The density's range over each brick and over the bricks above it toward the light.
    pub bounds_seconds: f64,
    /// Marching the light columns, batch by batch (on the CPU's threads or a GPU).
    pub columns_seconds: f64,
    /// Deciding each brick's level and form and encoding it, on all threads.
    pub decisions_seconds: f64,
    /// Appending the encoded bricks to the map.
    pub packing_seconds: f64,
    /// Waiting for columns with nothing to decide: the first batch of each level, and
    /// the batches whose columns took longer than deciding and packing the batch before.
    pub waiting_seconds: f64,
    /// Between levels: dropping the bricks refined past and giving their memory back.
    pub compacting_seconds: f64,
}

impl BakeReport {
    /// Fills in what `map` holds: bricks, samples per level, memory.
    pub fn count(&mut self, map: &ShadowMap) {
        self.bricks = map.brick_count();
        self.points_per_level = map.points_per_level().to_vec();
        let [_, linear, dark] = map.bricks_per_form();
        (self.linear_bricks, self.dark_bricks) = (linear as usize, dark as usize);
        self.memory_bytes = map.memory_bytes();
    }
}
