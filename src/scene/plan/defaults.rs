//! Every default of a render, in one place: the plan fills them in, the flags' docs state
//! them (a test checks that giving each documented default changes no plan), the scene
//! file's keys fall back to them. Also the limits on what a render may ask for.

/// Image size.
pub const RES: (usize, usize) = (640, 360);
/// Horizontal field of view of a perspective camera, degrees.
pub const FOV_DEG: f64 = 40.0;
/// Absorption and scattering per world unit at density 1.
pub const SIGMA_A: f64 = 0.1;
pub const SIGMA_S: f64 = 2.0;
pub const DENSITY_SCALE: f64 = 1.0;
/// Henyey–Greenstein anisotropy.
pub const G: f64 = 0.0;
pub const EMISSION_COLOR: [f64; 3] = [1.0, 0.45, 0.12];
pub const EMISSION_INTENSITY: f64 = 4.0;
pub const TEMPERATURE_SCALE: f64 = 1.0;
pub const TEMPERATURE_OFFSET: f64 = 0.0;
pub const BLACKBODY_INTENSITY: f64 = 0.05;
/// The sun used when a scene names no light.
pub const LIGHT: &str = "sun:0.6,1,0.5:1,1,1:6";
/// Largest transmittance error of the deep shadow map.
pub const DSM_TOLERANCE: f64 = 1e-3;
/// March step and shadow-ray step, voxels (the march's own default, which the
/// integrators use when called as a library).
pub const STEP: f64 = crate::integrate::march::DEFAULT_STEP;
pub const SHADOW_STEP: f64 = 1.0;
/// Transmittance below which a ray stops.
pub const TERMINATION: f64 = crate::integrate::march::DEFAULT_TERMINATION;
pub const SPP: u32 = 1;
/// Silhouette pixels' stratified grid: 4×4 samples (at 80×45, the edge of a dense
/// cloud lit from behind was 6–7 % of the scattered light's RMSE against a
/// many-sample path-traced render at pixel centres, ~2 % with 4×4).
pub const ANTIALIAS: u32 = 4;
pub const SEED: u64 = 0;
/// Frames per second, and the velocity grid's scale and time unit.
pub const FPS: f64 = 24.0;
pub const VELOCITY_SCALE: f64 = 1.0;
pub const VELOCITY_UNIT: &str = "second";
pub const EXPOSURE: f32 = 0.0;
/// `--deep-tolerance`: the opacity error merged deep samples may make.
pub const DEEP_TOLERANCE: f64 = 0.01;
/// Z written where nothing is (`--z-empty`), as Cycles does.
pub const Z_EMPTY: f32 = 1e10;
/// `--scattering`, and the most scattering events of a path (`--scattering path`).
pub const SCATTERING: &str = "fast";
pub const PATH_BOUNCES: u32 = crate::integrate::scattering::PATH_BOUNCES;
/// The scattering orders `--scattering fast` models.
pub const FAST_BOUNCES: u32 = crate::integrate::fast::DEFAULT_BOUNCES;
/// Water-drop radius for `--phase water-drop`, micrometres.
pub const DROP_RADIUS_UM: f64 = crate::integrate::phase::water_drop::DEFAULT_RADIUS_UM;

/// The shortest march or shadow step accepted, in voxels: 1/16 of the reference
/// render's. Below it a frame would take longer than anyone waits (a step of 1e-9 voxel
/// is 10⁹ segments a voxel), so it is refused rather than left to run as if hung.
pub const MIN_STEP_VOXELS: f64 = 1.0 / 1024.0;

/// The most worker threads murk starts: more than any machine it runs on has cores, and
/// few enough that starting them is instant (4294967296 took 13 s before failing).
pub const MAX_THREADS: usize = 1024;

/// The most lights a render or bake takes. Each light costs a shadow map (up to the
/// bake's budget) and three float channels of the frame, so 1,000 lights took 1 GB.
pub const MAX_LIGHTS: usize = 32;

/// The most memory the frame's channels may take: width × height × channels × 4 bytes.
/// 16384 × 16384 with the default channels would be 8.6 GB, allocated before the first
/// pixel; past this murk refuses at once rather than fail an allocation later.
pub const MAX_FRAME_BYTES: f64 = 4.0 * 1024.0 * 1024.0 * 1024.0;
