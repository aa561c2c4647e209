//! The volume integral: stable per-segment optics, phase functions, blackbody emission,
//! the ray march that puts them together, and the integrators a render chooses from
//! ([`Integrator`]: what a camera ray sees, into the passes it declares).

pub mod blackbody;
pub mod deep;
pub mod deep_aovs;
pub mod deep_pixel;
pub mod fast;
pub mod ground;
pub mod integrator;
pub mod march;
pub mod march_settings;
pub mod mattes;
pub mod medium;
pub mod motion;
pub mod ms_diffusion;
pub mod ms_lattice;
mod ms_orders;
mod ms_sampling;
pub mod ms_sweep;
pub mod optics;
pub mod pass;
pub mod path;
pub mod phase;
mod sampled_means;
pub mod scatter_passes;
pub mod scattering;
pub mod single;
mod volume;

pub use integrator::{CameraSample, Integrator, SampleRng};
pub use march::{
    Illumination, MarchSettings, RayResult, Scratch, TimedVolume, Volume, WorldRay, march,
};
pub use mattes::Mattes;
pub use medium::{ColorTint, Companion, Emission, Medium};
pub use scattering::ScatteringMode;
