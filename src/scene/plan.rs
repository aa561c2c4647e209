//! Turns [`RenderOptions`] into a validated [`RenderPlan`]: every number checked, every
//! default filled in, before anything is loaded.

use super::PlanError;
use super::camera::Projection;
use super::light::{EnvLight, Light, parse_triple};
use super::options::RenderOptions;
use super::transport::TransportPlan;
use crate::integrate::ground::Ground;
use crate::integrate::march::REFERENCE_STEP;
use crate::integrate::phase::PhaseKind;
use crate::integrate::{MarchSettings, Medium};
use crate::output::{Background, ExrCompression, ExrOptions, PreviewOptions};
use crate::shadow::ShadowQuadrature;
use glam::DVec3;
use std::path::PathBuf;

use super::flag_values::{
    colour, drop_radius, finite, non_negative, positive, resolution, step_voxels, up_axis_choice,
    z_empty,
};

/// How light transmittance is found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadowMode {
    /// A deep shadow map per light, baked before the render.
    Dsm,
    /// A shadow ray per sample and light.
    March,
    /// No shadows (lights reach every point unattenuated).
    None,
}

/// A grid role as requested: detect it, use this grid, or leave it out.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum GridChoice {
    Detect,
    Named(String),
    Off,
}

impl GridChoice {
    fn from(v: &Option<String>) -> GridChoice {
        match v.as_deref() {
            None => GridChoice::Detect,
            Some("none") | Some("") => GridChoice::Off,
            Some(n) => GridChoice::Named(n.to_string()),
        }
    }
}

/// Every default of a render, in one place: the plan fills them in, the flags' help
/// states them (a test checks that it does), the scene file's keys fall back to them.
pub mod defaults {
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
    pub const EXPOSURE: f32 = 0.0;
    /// Z written where nothing is (`--z-empty`), as Cycles does.
    pub const Z_EMPTY: f32 = 1e10;
    /// `--scattering`, and the most scattering events of a path (`--scattering path`).
    pub const SCATTERING: &str = "fast";
    pub const PATH_BOUNCES: u32 = crate::integrate::scattering::PATH_BOUNCES;
    /// The scattering orders `--scattering fast` models.
    pub const FAST_BOUNCES: u32 = crate::integrate::fast::DEFAULT_BOUNCES;
    /// Water-drop radius for `--phase water-drop`, micrometres.
    pub const DROP_RADIUS_UM: f64 = crate::integrate::phase::water_drop::DEFAULT_RADIUS_UM;
}

/// The camera as far as it can be known before the grid's bounds are.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraRequest {
    pub projection: Option<Projection>,
    pub eye: Option<DVec3>,
    pub look_at: Option<DVec3>,
    pub up: DVec3,
}

/// The image and the camera.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraPlan {
    pub width: usize,
    pub height: usize,
    pub request: CameraRequest,
}

/// Which field fills each role.
#[derive(Clone, Debug, PartialEq)]
pub struct GridRoles {
    pub density: GridChoice,
    pub emission: GridChoice,
    pub temperature: GridChoice,
    pub color: GridChoice,
}

/// Emission: an emission field's colour and intensity, and blackbody emission from a
/// temperature field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmissionPlan {
    pub color: DVec3,
    pub intensity: f64,
    /// Kelvin = value × scale + offset.
    pub temperature_scale: f64,
    pub temperature_offset: f64,
    pub blackbody_intensity: f64,
}

/// How the lights' transmittance is found.
#[derive(Clone, Debug, PartialEq)]
pub struct ShadowPlan {
    pub mode: ShadowMode,
    /// Largest transmittance error of the deep shadow map.
    pub dsm_tolerance: f64,
    pub dsm_verify: bool,
    pub cache: Option<PathBuf>,
    /// Marched shadow rays' step, voxels.
    pub step: f64,
}

/// The camera ray's march.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MarchPlan {
    /// Reference quality: exact shadow optical depth, a tiny source step, no termination
    /// (see [`RenderPlan::march_settings`], [`RenderPlan::shadow_quadrature`]).
    pub reference: bool,
    pub step: f64,
    pub termination: f64,
    /// `--max-error`: the relative radiance RMSE to meet; the step and termination are
    /// then chosen by a pilot render (`render::error_budget`), the map's tolerance here.
    pub max_error: Option<f64>,
}

impl MarchPlan {
    /// The part of `--max-error` each of the three independent error sources (step,
    /// termination, shadow-map tolerance) may take: their squares add up to it.
    pub fn error_share(max_error: f64) -> f64 {
        max_error / 3f64.sqrt()
    }
}

/// Samples, their random numbers and the threads that take them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SamplingPlan {
    pub spp: u32,
    /// `--antialias N`: at one sample a pixel, silhouette pixels get N×N stratified
    /// samples (1: pixel centres only).
    pub antialias: u32,
    pub seed: u64,
    pub threads: Option<usize>,
}

/// What is written.
#[derive(Clone, Debug)]
pub struct OutputPlan {
    /// The EXR (or, for `bake-shadows`, the cache).
    pub path: PathBuf,
    pub exr: ExrOptions,
    pub preview: Option<(PathBuf, PreviewOptions)>,
    pub stats: Option<PathBuf>,
    pub quiet: bool,
}

/// Production caches: which conventions are assumed, and what the user fixed.
#[derive(Clone, Debug, PartialEq)]
pub struct ProductionPlan {
    /// `--up-axis`.
    pub up_axis: super::conventions::UpAxisChoice,
    /// `--up` was given: the camera's up is not the world's.
    pub up_explicit: bool,
    /// `--temperature-scale` or `--temperature-offset` was given: no convention is
    /// detected.
    pub temperature_explicit: bool,
    /// The scene names no light: the default sun, which follows the up axis.
    pub default_light: bool,
}

/// A validated render: every number checked, every default filled in.
#[derive(Clone, Debug)]
pub struct RenderPlan {
    /// The input (a `.vdb`).
    pub input: PathBuf,
    pub camera: CameraPlan,
    pub grids: GridRoles,
    pub medium: Medium,
    /// The phase function (`--phase`; Henyey–Greenstein takes `medium.g`) and the drop
    /// radius in µm for water drops (`--drop-radius`).
    pub phase: PhaseKind,
    pub drop_radius_um: f64,
    pub emission: EmissionPlan,
    pub lights: Vec<Light>,
    pub shadows: ShadowPlan,
    /// A ground plane lit through the volume.
    pub ground: Option<Ground>,
    pub march: MarchPlan,
    pub sampling: SamplingPlan,
    pub outputs: OutputPlan,
    pub production: ProductionPlan,
    /// The scattering mode, its bounces and the environment light.
    pub transport: TransportPlan,
}

/// The shortest march or shadow step accepted, in voxels: 1/16 of the reference
/// render's. Below it a frame would take longer than anyone waits (a step of 1e-9 voxel
/// is 10⁹ segments a voxel), so it is refused rather than left to run as if hung.
pub const MIN_STEP_VOXELS: f64 = 1.0 / 1024.0;

impl RenderPlan {
    /// Validates options; `input` is the VDB file (from the command line or the scene).
    pub fn new(o: &RenderOptions, input: PathBuf) -> Result<RenderPlan, PlanError> {
        Self::validated(o, input).map_err(PlanError::Invalid)
    }

    fn validated(o: &RenderOptions, input: PathBuf) -> Result<RenderPlan, String> {
        let output = o
            .output
            .clone()
            .ok_or("no output file: give -o OUT.exr (or `output` in the scene file)")?;
        let (width, height) = resolution(&o.res)?;
        let projection = match o.camera.as_deref() {
            None if o.ortho_width.is_some() => Some(Projection::Orthographic {
                width: positive(o.ortho_width, 1.0, "--ortho-width")?,
            }),
            None => o.fov.map(|f| Projection::Perspective { fov_deg: f }),
            Some("persp") | Some("perspective") => Some(Projection::Perspective {
                fov_deg: o.fov.unwrap_or(defaults::FOV_DEG),
            }),
            Some("ortho") | Some("orthographic") => match o.ortho_width {
                Some(w) => Some(Projection::Orthographic {
                    width: positive(Some(w), 1.0, "--ortho-width")?,
                }),
                None => Some(Projection::Orthographic { width: 0.0 }),
            },
            Some(other) => return Err(format!("--camera \"{other}\": expected persp or ortho")),
        };
        if let Some(Projection::Perspective { fov_deg }) = projection
            && !(fov_deg > 0.0 && fov_deg < 180.0)
        {
            return Err(format!("--fov {fov_deg} is outside (0, 180) degrees"));
        }
        let vec =
            |v: &Option<String>, what: &str| v.as_ref().map(|s| parse_triple(s, what)).transpose();
        let camera = CameraRequest {
            projection,
            eye: vec(&o.eye, "--eye")?,
            look_at: vec(&o.look_at, "--look-at")?,
            up: vec(&o.up, "--up")?.unwrap_or(DVec3::Y),
        };
        let g = o.g.unwrap_or(defaults::G);
        if !(g > -1.0 && g < 1.0) {
            return Err(format!("--g {g} must lie in (-1, 1)"));
        }
        let mut lights = Vec::new();
        let mut environment = Vec::new();
        if !o.no_lights {
            if !o.lights.is_empty() {
                for l in &o.lights {
                    if EnvLight::is_env_spec(&l.spec) {
                        environment.push(
                            EnvLight::parse(&l.spec, l.name.clone()).map_err(|e| e.to_string())?,
                        );
                        continue;
                    }
                    lights.push(Light::parse(&l.spec, l.name.clone()).map_err(|e| e.to_string())?);
                }
            } else {
                let specs = if o.light.is_empty() {
                    vec![defaults::LIGHT.to_string()]
                } else {
                    o.light.clone()
                };
                let (mut suns, mut points) = (0, 0);
                for s in &specs {
                    if EnvLight::is_env_spec(s) {
                        let name = format!("env{}", environment.len());
                        environment.push(EnvLight::parse(s, name).map_err(|e| e.to_string())?);
                        continue;
                    }
                    let name = if s.starts_with("point") {
                        points += 1;
                        format!("point{}", points - 1)
                    } else {
                        suns += 1;
                        format!("sun{}", suns - 1)
                    };
                    lights.push(Light::parse(s, name).map_err(|e| e.to_string())?);
                }
            }
        }
        safe_light_names(&mut lights)?;
        let transport = TransportPlan::new(o, environment)?;
        let default_shadows = if o.reference { "march" } else { "dsm" };
        let shadows = match o.shadows.as_deref().unwrap_or(default_shadows) {
            "dsm" => ShadowMode::Dsm,
            "march" => ShadowMode::March,
            "none" => ShadowMode::None,
            other => {
                return Err(format!(
                    "--shadows \"{other}\": expected march, dsm or none"
                ));
            }
        };
        let termination = o.termination.unwrap_or(if o.reference {
            0.0
        } else {
            defaults::TERMINATION
        });
        if !(0.0..1.0).contains(&termination) {
            return Err(format!("--termination {termination} must lie in [0, 1)"));
        }
        if o.reference && shadows != ShadowMode::March {
            return Err(format!(
                "--reference marches exact shadow rays: it cannot be combined with --shadows {}",
                o.shadows.as_deref().unwrap_or("")
            ));
        }
        if o.reference && termination != 0.0 {
            return Err(format!(
                "--reference never stops a ray early: it cannot be combined with --termination {termination}"
            ));
        }
        let max_error = match o.max_error {
            None => None,
            Some(e) if !(e > 0.0 && e < 1.0) => {
                return Err(format!("--max-error {e} must lie in (0, 1)"));
            }
            Some(e) => {
                for (set, flag) in [
                    (o.step.is_some(), "--step"),
                    (o.termination.is_some(), "--termination"),
                    (o.dsm_tolerance.is_some(), "--dsm-tolerance"),
                    (o.reference, "--reference"),
                ] {
                    if set {
                        return Err(format!(
                            "--max-error chooses the step, the termination and the shadow map's tolerance itself: it cannot be combined with {flag}"
                        ));
                    }
                }
                if transport.mode == crate::integrate::ScatteringMode::Path {
                    return Err("--max-error sets the march's error; --scattering path's error is its noise (set --spp instead)".into());
                }
                Some(e)
            }
        };
        let spp = o.spp.unwrap_or(defaults::SPP);
        let antialias = o.antialias.unwrap_or(defaults::ANTIALIAS);
        if antialias == 0 || antialias > 16 {
            return Err(format!("--antialias {antialias} must be from 1 to 16"));
        }
        if spp == 0 || spp > 4096 {
            return Err(format!("--spp {spp} must be from 1 to 4096"));
        }
        if o.threads == Some(0) {
            return Err("--threads must be at least 1".into());
        }
        let compression = match &o.compression {
            Some(c) => c.parse::<ExrCompression>().map_err(|e| e.to_string())?,
            None => ExrCompression::default(),
        };
        let preview = match &o.preview {
            Some(p) => {
                let background = match &o.background {
                    Some(b) => b.parse::<Background>().map_err(|e| e.to_string())?,
                    None => Background::Checker,
                };
                let exposure = o.exposure.unwrap_or(defaults::EXPOSURE);
                if !exposure.is_finite() {
                    return Err("--exposure must be a finite number".into());
                }
                Some((
                    p.clone(),
                    PreviewOptions {
                        exposure,
                        background,
                    },
                ))
            }
            None => None,
        };
        let step = step_voxels(
            o.step,
            if o.reference {
                REFERENCE_STEP
            } else {
                defaults::STEP
            },
            "--step",
        )?;
        Ok(RenderPlan {
            input: input.clone(),
            camera: CameraPlan {
                width,
                height,
                request: camera,
            },
            grids: GridRoles {
                density: GridChoice::from(&o.density_grid),
                emission: GridChoice::from(&o.emission_grid),
                temperature: GridChoice::from(&o.temperature_grid),
                color: GridChoice::from(&o.color_grid),
            },
            medium: Medium {
                sigma_a: colour(&o.sigma_a, DVec3::splat(defaults::SIGMA_A), "--sigma-a")?,
                sigma_s: colour(&o.sigma_s, DVec3::splat(defaults::SIGMA_S), "--sigma-s")?,
                density_scale: non_negative(
                    o.density_scale,
                    defaults::DENSITY_SCALE,
                    "--density-scale",
                )?,
                g,
            },
            phase: o.phase.unwrap_or_default(),
            drop_radius_um: drop_radius(o.drop_radius)?,
            emission: EmissionPlan {
                color: colour(
                    &o.emission_color,
                    DVec3::from_array(defaults::EMISSION_COLOR),
                    "--emission-color",
                )?,
                intensity: non_negative(
                    o.emission_intensity,
                    defaults::EMISSION_INTENSITY,
                    "--emission-intensity",
                )?,
                temperature_scale: non_negative(
                    o.temperature_scale,
                    defaults::TEMPERATURE_SCALE,
                    "--temperature-scale",
                )?,
                temperature_offset: finite(
                    o.temperature_offset,
                    defaults::TEMPERATURE_OFFSET,
                    "--temperature-offset",
                )?,
                blackbody_intensity: non_negative(
                    o.blackbody_intensity,
                    defaults::BLACKBODY_INTENSITY,
                    "--blackbody-intensity",
                )?,
            },
            lights,
            shadows: ShadowPlan {
                mode: shadows,
                dsm_tolerance: {
                    let t = o.dsm_tolerance.unwrap_or(match max_error {
                        // Its share of the error, but no coarser than 5 %: the map's
                        // bound is on transmittance, not on each pixel's radiance.
                        Some(e) => MarchPlan::error_share(e).min(0.05),
                        None => defaults::DSM_TOLERANCE,
                    });
                    if !(t > 0.0 && t < 1.0) {
                        return Err(format!("--dsm-tolerance {t} must lie in (0, 1)"));
                    }
                    t
                },
                dsm_verify: o.dsm_verify,
                cache: o.shadow_cache.clone(),
                step: step_voxels(o.shadow_step, defaults::SHADOW_STEP, "--shadow-step")?,
            },
            ground: match o.ground {
                Some(y) if !y.is_finite() => return Err("--ground must be a finite height".into()),
                g => g.map(|height| Ground {
                    height,
                    visible: o.ground_visible,
                }),
            },
            march: MarchPlan {
                reference: o.reference,
                step,
                termination,
                max_error,
            },
            sampling: SamplingPlan {
                spp,
                antialias,
                seed: o.seed.unwrap_or(defaults::SEED),
                threads: o.threads,
            },
            outputs: OutputPlan {
                path: output,
                exr: ExrOptions {
                    compression,
                    float: o.float,
                    input_file: Some(input.display().to_string()),
                    z_empty: z_empty(&o.z_empty)?,
                    crop_data_window: o.crop_data_window,
                    colorspace: match &o.colorspace {
                        Some(c) => c.parse()?,
                        None => crate::output::ColorSpace::default(),
                    },
                    ..ExrOptions::default()
                },
                preview,
                stats: o.stats.clone(),
                quiet: o.quiet,
            },
            production: ProductionPlan {
                up_axis: up_axis_choice(&o.up_axis)?,
                up_explicit: o.up.is_some(),
                temperature_explicit: o.temperature_scale.is_some()
                    || o.temperature_offset.is_some(),
                default_light: !o.no_lights && o.lights.is_empty() && o.light.is_empty(),
            },
            transport,
        })
    }
}

impl RenderPlan {
    /// The camera ray's march: `--step` and `--termination` (the reference's when
    /// `--reference`).
    pub fn march_settings(&self) -> MarchSettings {
        MarchSettings {
            step_voxels: self.march.step,
            termination: self.march.termination,
        }
    }

    /// How marched shadow rays integrate density: exactly (per voxel, two-point
    /// Gauss–Legendre) for `--reference`, else the midpoint rule at `--shadow-step`.
    pub fn shadow_quadrature(&self) -> ShadowQuadrature {
        if self.march.reference {
            ShadowQuadrature::Exact
        } else {
            ShadowQuadrature::Step(self.shadows.step)
        }
    }
}

/// A light's name as a layer name compositors read as one layer: ASCII letters, digits
/// and `_` kept, every other character (`.`, which Blender and Nuke read as a layer
/// separator, spaces, `-`, anything not ASCII) becomes `_`; an empty name is `light`.
pub fn safe_layer_name(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() { "light".into() } else { s }
}

/// Gives every light its safe layer name; two lights that map to one name are refused.
fn safe_light_names(lights: &mut [Light]) -> Result<(), String> {
    let mut seen: Vec<(String, String)> = Vec::new();
    for l in lights.iter_mut() {
        let safe = safe_layer_name(&l.name);
        if let Some((first, _)) = seen.iter().find(|(_, s)| *s == safe) {
            if *first == l.name {
                return Err(format!(
                    "two lights named \"{first}\": each light's scatter layer is named after it"
                ));
            }
            return Err(format!(
                "lights \"{first}\" and \"{}\" would both be the layer scatter_{safe}: name them apart",
                l.name
            ));
        }
        seen.push((l.name.clone(), safe.clone()));
        l.name = safe;
    }
    Ok(())
}
