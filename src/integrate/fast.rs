//! The fast multiple-scattering approximation (`--scattering fast`, the default).
//!
//! Single scattering stays exact, as [`SingleScattering`] computes it (ray march, deep
//! shadow map). The light scattered two or more times comes from a coarse lattice solved
//! once per light before the render ([`MsLattice`]: discrete-ordinates source iteration
//! seeded by the shadow map), which keeps per node the once-scattered light's mean
//! radiance and the later orders' mean and flux; the same march reads them and adds, per
//! segment, `σs·ρ` times what they scatter toward the camera ([`MsLattice::toward`])
//! beside its single-scattered term. The march's cost grows by one trilinear lookup per
//! segment and light; the lattice costs `orders × directions × nodes` stencil updates.
//!
//! It assumes the multiply scattered radiance is smooth on the lattice's scale (a few
//! voxels), that light scattered twice or more is broad in angle (its flux carries what
//! a phase function does with it), and that an anisotropic phase function's effect on
//! transport past the first scattering is its mean cosine (similarity). A colour grid
//! tints every scattering event, so the lattice then solves the three channels.

use super::ground::Ground;
use super::integrator::{CameraSample, Integrator, SampleRng};
use super::march::{Illumination, MarchSettings, Scratch, Volume};
use super::ms_lattice::{LatticeSettings, MsLattice};
use super::pass::PassLayout;
use super::single::SingleScattering;
use glam::DVec3;

/// Scattering orders `fast` models by default (`--bounces`): the first exactly, orders
/// 2…N on the lattice, the rest as a geometric tail. Measured on the demo cloud and on
/// denser, brighter ones (scripts/calibrate_fast.py): past ~16 the swept orders change
/// the image by less than 0.1 % with the tail in place.
pub const DEFAULT_BOUNCES: u32 = 24;
/// Most lattice nodes (about 40³): at this size the lattice's error against path
/// tracing on the calibration clouds has stopped falling faster than its cost grows
/// (scripts/calibrate_fast.py).
pub const DEFAULT_LATTICE_NODES: usize = 64_000;
/// Directions per order (turned every order).
pub const DEFAULT_DIRECTIONS: usize = 32;
/// Cells sized in mean free paths: where a cell at the medium's dense part (its 90th
/// percentile of density) is optically thicker than this, the lattice takes more nodes,
/// up to [`NODE_CAP`] times its budget, sweeps fewer orders over fewer directions and
/// solves the rest by diffusion. Measured with scripts/check_fast.py against the path
/// tracer: dense white clouds (×4 and ×10 the demo's density, albedo 0.99) were 7–9 %
/// too bright with cells of 1.2–3 mean free paths; both ~3–4 % once grown.
pub const CELL_DEPTH: f64 = 1.0;
/// Most times its node budget a lattice grows for [`CELL_DEPTH`] (64,000 → 216,000).
pub const NODE_CAP: f64 = 3.4;

/// The fast mode's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FastSettings {
    /// Scattering orders modelled (1: single scattering only).
    pub bounces: u32,
    pub lattice_nodes: usize,
    pub directions: usize,
}

impl Default for FastSettings {
    fn default() -> Self {
        FastSettings {
            bounces: DEFAULT_BOUNCES,
            lattice_nodes: DEFAULT_LATTICE_NODES,
            directions: DEFAULT_DIRECTIONS,
        }
    }
}

impl FastSettings {
    pub fn lattice(&self) -> LatticeSettings {
        LatticeSettings {
            orders: self.bounces.saturating_sub(1),
            max_nodes: self.lattice_nodes,
            directions: self.directions,
            cell_depth: Some(CELL_DEPTH),
            node_cap: NODE_CAP,
            diffusion_tail: true,
        }
    }
}

/// A scene's lights with their multiply scattered in-radiance from a solved lattice.
pub struct WithMultiple<'a> {
    pub direct: &'a dyn Illumination,
    pub lattice: &'a MsLattice,
}

impl Illumination for WithMultiple<'_> {
    fn light_count(&self) -> usize {
        self.direct.light_count()
    }
    fn incident(&self, light: usize, x: DVec3) -> (DVec3, DVec3) {
        self.direct.incident(light, x)
    }
    #[inline]
    fn density_to_light(&self, light: usize, x: DVec3) -> f64 {
        self.direct.density_to_light(light, x)
    }
    fn distance_to_light(&self, light: usize, x: DVec3) -> f64 {
        self.direct.distance_to_light(light, x)
    }
    fn scatters_multiply(&self) -> bool {
        true
    }
    #[inline]
    fn multiple_scattered(&self, light: usize, x: DVec3, omega: DVec3) -> DVec3 {
        let (_, travel) = self.direct.incident(light, x);
        self.lattice.toward(light, x, omega, travel)
    }
}

/// Single scattering plus the lattice's multiple scattering: the march of
/// [`SingleScattering`] through [`WithMultiple`] lights, which also writes `indirect`.
pub struct FastScattering<'a> {
    single: SingleScattering<'a>,
}

impl<'a> FastScattering<'a> {
    /// As [`SingleScattering::new`], with the lights' multiple scattering in `lights`.
    pub fn new(
        volume: &'a Volume<'a>,
        emits: bool,
        lights: Option<(&'a WithMultiple<'a>, Vec<String>)>,
        ground: Option<(Ground, &'a dyn Illumination)>,
        settings: MarchSettings,
    ) -> Self {
        let single = SingleScattering::new(
            volume,
            emits,
            lights.map(|(l, n)| (l as &dyn Illumination, n)),
            ground,
            settings,
        );
        FastScattering { single }
    }

    /// The single-scattering march it runs (its passes include `indirect`): what a
    /// backend that gathers the lattice itself (the GPU's) records its samples with.
    pub fn single(&self) -> &SingleScattering<'a> {
        &self.single
    }

    /// As [`SingleScattering::with_deep`].
    pub fn with_deep(self, on: bool) -> Self {
        FastScattering {
            single: self.single.with_deep(on),
        }
    }

    /// As [`SingleScattering::with_deep_aovs`].
    pub fn with_deep_aovs(self, on: bool) -> Self {
        FastScattering {
            single: self.single.with_deep_aovs(on),
        }
    }
}

impl Integrator for FastScattering<'_> {
    type Scratch = Scratch;

    fn passes(&self) -> &PassLayout {
        self.single.passes()
    }

    fn scratch(&self) -> Scratch {
        self.single.scratch()
    }

    fn sample(
        &self,
        camera: &CameraSample,
        rng: &mut SampleRng,
        scratch: &mut Scratch,
        acc: &mut [f64],
    ) -> u64 {
        self.single.sample(camera, rng, scratch, acc)
    }

    fn deep_trace<'s>(&self, scratch: &'s Scratch) -> Option<&'s super::deep::DeepTrace> {
        self.single.deep_trace(scratch)
    }

    fn deep_aovs(&self) -> Vec<super::deep::DeepAov> {
        self.single.deep_aovs()
    }
}
