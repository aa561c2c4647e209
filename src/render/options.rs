//! Everything a render can be told, from flags or a scene file. Every field is optional:
//! a flag overrides the scene file, the scene file overrides the defaults.

use clap::Args;
use serde::Deserialize;
use std::path::PathBuf;

/// Render options shared by the command line (`murk render --...`) and scene files.
#[derive(Args, Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RenderOptions {
    /// Scene files only: the .vdb to render (relative to the scene file).
    #[arg(skip)]
    #[serde(default)]
    pub input: Option<PathBuf>,
    /// Scene files only: named lights, `[[lights]] name = "key"  spec = "sun:..."`.
    #[arg(skip)]
    #[serde(default)]
    pub lights: Vec<NamedLight>,
    /// Output EXR.
    #[arg(short = 'o', long = "output", value_name = "OUT.exr")]
    #[serde(default)]
    pub output: Option<PathBuf>,
    /// Image size, WxH (default 640x360).
    #[arg(long, value_name = "WxH")]
    pub res: Option<String>,
    /// persp or ortho.
    #[arg(long, value_name = "persp|ortho")]
    pub camera: Option<String>,
    /// Camera position x,y,z (default: framing the density's bounds).
    #[arg(long, value_name = "x,y,z", allow_hyphen_values = true)]
    pub eye: Option<String>,
    /// Point the camera looks at, x,y,z (default: the centre of the density's bounds).
    #[arg(long = "look-at", value_name = "x,y,z", allow_hyphen_values = true)]
    pub look_at: Option<String>,
    /// Camera up vector (default 0,1,0).
    #[arg(long, value_name = "x,y,z", allow_hyphen_values = true)]
    pub up: Option<String>,
    /// Horizontal field of view in degrees, like vdb_render (default 40).
    #[arg(long, value_name = "DEG")]
    pub fov: Option<f64>,
    /// Width of the orthographic view in world units (default: framing the bounds).
    #[arg(long = "ortho-width", value_name = "W")]
    pub ortho_width: Option<f64>,
    /// Grid that holds density (default: detected — density).
    #[arg(long = "density-grid", value_name = "NAME")]
    pub density_grid: Option<String>,
    /// Grid emitting light (default: detected — flame, flames, fire, emission; "none" to disable).
    #[arg(long = "emission-grid", value_name = "NAME")]
    pub emission_grid: Option<String>,
    /// Temperature grid for blackbody emission (default: detected — temperature, heat; "none" to disable).
    #[arg(long = "temperature-grid", value_name = "NAME")]
    pub temperature_grid: Option<String>,
    /// Vec3 grid tinting scattering (default: detected — Cd, color, colour; "none" to disable).
    #[arg(long = "color-grid", value_name = "NAME")]
    pub color_grid: Option<String>,
    /// Absorption per world unit at density 1, r,g,b (default 0.1,0.1,0.1).
    #[arg(long = "sigma-a", value_name = "r,g,b")]
    pub sigma_a: Option<String>,
    /// Scattering per world unit at density 1, r,g,b (default 2,2,2).
    #[arg(long = "sigma-s", value_name = "r,g,b")]
    pub sigma_s: Option<String>,
    /// Multiplies density (default 1).
    #[arg(long = "density-scale", value_name = "F")]
    pub density_scale: Option<f64>,
    /// Henyey–Greenstein anisotropy in (-1, 1) (default 0).
    #[arg(long, value_name = "F", allow_hyphen_values = true)]
    pub g: Option<f64>,
    /// Emission colour, r,g,b (default 1,0.45,0.12).
    #[arg(long = "emission-color", value_name = "r,g,b")]
    pub emission_color: Option<String>,
    /// Emission intensity per world unit at emission-grid value 1 (default 4).
    #[arg(long = "emission-intensity", value_name = "F")]
    pub emission_intensity: Option<f64>,
    /// Kelvin = temperature value × scale + offset (default scale 1).
    #[arg(long = "temperature-scale", value_name = "F")]
    pub temperature_scale: Option<f64>,
    /// Kelvin = temperature value × scale + offset (default offset 0).
    #[arg(
        long = "temperature-offset",
        value_name = "K",
        allow_hyphen_values = true
    )]
    pub temperature_offset: Option<f64>,
    /// Blackbody brightness: emission = colour(K) × intensity × (K/1000)^4 (default 0.05).
    #[arg(long = "blackbody-intensity", value_name = "F")]
    pub blackbody_intensity: Option<f64>,
    /// A light: sun:DX,DY,DZ[:R,G,B[:INTENSITY]] (direction toward the sun; intensity is its
    /// irradiance) or point:X,Y,Z[:R,G,B[:INTENSITY]]. Repeatable. Default: sun:0.6,1,0.5:1,1,1:6.
    #[arg(long = "light", value_name = "SPEC", allow_hyphen_values = true)]
    #[serde(default)]
    pub light: Vec<String>,
    /// Render without any light (emission only).
    #[arg(long = "no-lights")]
    #[serde(default)]
    pub no_lights: bool,
    /// Largest march step in voxels of the density grid (default 0.5, at least 1/1024).
    #[arg(long, value_name = "VOXELS")]
    pub step: Option<f64>,
    /// Shadow-ray step in voxels (default 1, at least 1/1024).
    #[arg(long = "shadow-step", value_name = "VOXELS")]
    pub shadow_step: Option<f64>,
    /// dsm (a deep shadow map of optical depth baked once per light, default), march (a
    /// shadow ray per sample: the reference) or none.
    #[arg(long, value_name = "dsm|march|none")]
    pub shadows: Option<String>,
    /// Largest transmittance error the deep shadow map may make, absolute (default 1e-3).
    #[arg(long = "dsm-tolerance", value_name = "T")]
    pub dsm_tolerance: Option<f64>,
    /// Measure the shadow map against marched shadow rays at 10,000 random points inside
    /// the density (max and mean transmittance error, in the stats).
    #[arg(long = "dsm-verify")]
    #[serde(default)]
    pub dsm_verify: bool,
    /// Reuse deep shadow maps from this file (made by `murk bake-shadows`) when the density
    /// and lights match; refuse when they do not.
    #[arg(long = "shadow-cache", value_name = "SHADOWS.vdb")]
    pub shadow_cache: Option<PathBuf>,
    /// A ground plane at height Y (world), receiving the lights through the volume: written as
    /// the shadow.R/G/B layer (the fraction of light it receives).
    #[arg(long, value_name = "Y", allow_hyphen_values = true)]
    pub ground: Option<f64>,
    /// Also show the ground plane (grey, Lambertian) in the beauty pass.
    #[arg(long = "ground-visible")]
    #[serde(default)]
    pub ground_visible: bool,
    /// Reference quality: exact optical depth (f64, per voxel) for camera and shadow rays,
    /// a 1/64-voxel source step (or --step), no early termination. Implies --shadows march;
    /// refuses --shadows dsm|none and a non-zero --termination.
    #[arg(long)]
    #[serde(default)]
    pub reference: bool,
    /// Transmittance below which a ray stops (default 1e-4).
    #[arg(long, value_name = "T")]
    pub termination: Option<f64>,
    /// Samples per pixel (default 1: the pixel centre).
    #[arg(long, value_name = "N")]
    pub spp: Option<u32>,
    /// Seed of the per-pixel step offsets and pixel jitter (default 0).
    #[arg(long, value_name = "N")]
    pub seed: Option<u64>,
    /// Worker threads (default: all cores).
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// EXR compression: none, rle, zips, zip, piz, dwaa (default zips).
    #[arg(long, value_name = "NAME")]
    pub compression: Option<String>,
    /// Store colour channels as 32-bit float instead of half.
    #[arg(long)]
    #[serde(default)]
    pub float: bool,
    /// Write render statistics as JSON.
    #[arg(long, value_name = "FILE.json")]
    pub stats: Option<PathBuf>,
    /// Write an 8-bit sRGB PNG of the beauty pass.
    #[arg(long, value_name = "FILE.png")]
    pub preview: Option<PathBuf>,
    /// Preview exposure in stops (default 0).
    #[arg(long, value_name = "STOPS", allow_hyphen_values = true)]
    pub exposure: Option<f32>,
    /// Preview background: transparent, black, checker or r,g,b (default checker).
    #[arg(long, value_name = "BG")]
    pub background: Option<String>,
    /// No progress bar.
    #[arg(long)]
    #[serde(default)]
    pub quiet: bool,
}

/// `murk bake-shadows` flags: only what decides a shadow map (the density, the medium's
/// extinction, the lights, the tolerance), so that camera and image flags, which would
/// change nothing, are refused rather than silently ignored. A scene file may still hold
/// them: the bake reads the scene as a render would and uses what it needs.
#[derive(Args, Clone, Debug, Default, PartialEq)]
pub struct BakeOptions {
    /// The .vdb to write: each light's map as float grids of optical depth (with its
    /// slopes), for `murk render --shadow-cache`.
    #[arg(short = 'o', long = "output", value_name = "SHADOWS.vdb")]
    pub output: Option<PathBuf>,
    /// Grid that holds density (default: detected — density).
    #[arg(long = "density-grid", value_name = "NAME")]
    pub density_grid: Option<String>,
    /// Absorption per world unit at density 1, r,g,b (default 0.1,0.1,0.1).
    #[arg(long = "sigma-a", value_name = "r,g,b")]
    pub sigma_a: Option<String>,
    /// Scattering per world unit at density 1, r,g,b (default 2,2,2).
    #[arg(long = "sigma-s", value_name = "r,g,b")]
    pub sigma_s: Option<String>,
    /// Multiplies density (default 1).
    #[arg(long = "density-scale", value_name = "F")]
    pub density_scale: Option<f64>,
    /// A light: sun:DX,DY,DZ[:R,G,B[:INTENSITY]] (direction toward the sun) or
    /// point:X,Y,Z[:R,G,B[:INTENSITY]]. Repeatable. Default: sun:0.6,1,0.5:1,1,1:6.
    #[arg(long = "light", value_name = "SPEC", allow_hyphen_values = true)]
    pub light: Vec<String>,
    /// Largest transmittance error the maps may make, absolute (default 1e-3).
    #[arg(long = "dsm-tolerance", value_name = "T")]
    pub dsm_tolerance: Option<f64>,
    /// Worker threads (default: all cores).
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Write bake statistics as JSON (the render's keys: `shadow_maps`, `stages`, …).
    #[arg(long, value_name = "FILE.json")]
    pub stats: Option<PathBuf>,
    /// No progress bar and no summary.
    #[arg(long)]
    pub quiet: bool,
}

impl From<BakeOptions> for RenderOptions {
    fn from(b: BakeOptions) -> RenderOptions {
        RenderOptions {
            output: b.output,
            density_grid: b.density_grid,
            sigma_a: b.sigma_a,
            sigma_s: b.sigma_s,
            density_scale: b.density_scale,
            light: b.light,
            dsm_tolerance: b.dsm_tolerance,
            threads: b.threads,
            stats: b.stats,
            quiet: b.quiet,
            ..RenderOptions::default()
        }
    }
}

/// A light in a scene file, with the name its scatter layer gets.
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct NamedLight {
    pub name: String,
    pub spec: String,
}

impl RenderOptions {
    /// Reads a scene file; relative paths in it are made relative to its folder.
    pub fn from_scene_file(path: &std::path::Path) -> Result<RenderOptions, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let mut o: RenderOptions = toml::from_str(&text)
            .map_err(|e| format!("{}: {}", path.display(), e.to_string().replace('\n', " ")))?;
        let dir = path.parent().unwrap_or(std::path::Path::new("."));
        for p in [&mut o.input, &mut o.output, &mut o.stats, &mut o.preview]
            .into_iter()
            .flatten()
        {
            if p.is_relative() {
                *p = dir.join(&*p);
            }
        }
        Ok(o)
    }

    /// `self` where set, else `base`.
    pub fn over(self, base: RenderOptions) -> RenderOptions {
        macro_rules! pick {
            ($($f:ident),*) => { RenderOptions { input: self.input.or(base.input), $($f: self.$f.or(base.$f),)*
                lights: if !self.light.is_empty() {
                    Vec::new()
                } else if self.lights.is_empty() {
                    base.lights
                } else {
                    self.lights
                },
                light: if self.light.is_empty() { base.light } else { self.light },
                no_lights: self.no_lights || base.no_lights,
                float: self.float || base.float,
                dsm_verify: self.dsm_verify || base.dsm_verify,
                ground_visible: self.ground_visible || base.ground_visible,
                reference: self.reference || base.reference,
                quiet: self.quiet || base.quiet,
            } };
        }
        pick!(
            output,
            res,
            camera,
            eye,
            look_at,
            up,
            fov,
            ortho_width,
            density_grid,
            emission_grid,
            temperature_grid,
            color_grid,
            sigma_a,
            sigma_s,
            density_scale,
            g,
            emission_color,
            emission_intensity,
            temperature_scale,
            temperature_offset,
            blackbody_intensity,
            step,
            shadow_step,
            shadows,
            dsm_tolerance,
            shadow_cache,
            ground,
            termination,
            spp,
            seed,
            threads,
            compression,
            stats,
            preview,
            exposure,
            background
        )
    }
}
