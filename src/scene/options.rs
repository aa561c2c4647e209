//! Everything a render can be told, from flags or a scene file. Every field is optional:
//! a flag overrides the scene file, the scene file overrides the defaults.

use serde::Deserialize;
use std::path::PathBuf;

/// Render options as given: from the command line (`murk render --...`, parsed in
/// `cli`) or a scene file. Every field is optional; [`RenderPlan::new`](super::RenderPlan::new)
/// fills in the defaults and validates.
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RenderOptions {
    /// Scene files only: the .vdb to render (relative to the scene file).
    #[serde(default)]
    pub input: Option<PathBuf>,
    /// Scene files only: named lights, `[[lights]] name = "key"  spec = "sun:..."`.
    #[serde(default)]
    pub lights: Vec<NamedLight>,
    /// Output EXR.
    #[serde(default)]
    pub output: Option<PathBuf>,
    /// Image size, WxH (default 640x360).
    pub res: Option<String>,
    /// persp or ortho.
    pub camera: Option<String>,
    /// Camera position x,y,z (default: framing the density's bounds).
    pub eye: Option<String>,
    /// Point the camera looks at, x,y,z (default: the centre of the density's bounds).
    pub look_at: Option<String>,
    /// Camera up vector (default 0,1,0).
    pub up: Option<String>,
    /// Horizontal field of view in degrees, like vdb_render (default 40).
    pub fov: Option<f64>,
    /// Width of the orthographic view in world units (default: framing the bounds).
    pub ortho_width: Option<f64>,
    /// Grid that holds density (default: detected — density).
    pub density_grid: Option<String>,
    /// Grid emitting light (default: detected — flame, flames, fire, emission; "none" to disable).
    pub emission_grid: Option<String>,
    /// Temperature grid for blackbody emission (default: detected — temperature, heat; "none" to disable).
    pub temperature_grid: Option<String>,
    /// Vec3 grid tinting scattering (default: detected — Cd, color, colour; "none" to disable).
    pub color_grid: Option<String>,
    /// Absorption per world unit at density 1, r,g,b (default 0.1,0.1,0.1).
    pub sigma_a: Option<String>,
    /// Scattering per world unit at density 1, r,g,b (default 2,2,2).
    pub sigma_s: Option<String>,
    /// Multiplies density (default 1).
    pub density_scale: Option<f64>,
    /// Henyey–Greenstein anisotropy in (-1, 1) (default 0).
    pub g: Option<f64>,
    /// Phase function: hg (Henyey–Greenstein with --g, grey) or water-drop (Lorenz–Mie
    /// for water drops of --drop-radius, in colour: rainbows). Default hg.
    pub phase: Option<crate::integrate::phase::PhaseKind>,
    /// Water-drop radius in micrometres for --phase water-drop: fog ~10, drizzle ~100,
    /// rain 500–1000 (default 500; 0.05–1000).
    pub drop_radius: Option<f64>,
    /// Emission colour, r,g,b (default 1,0.45,0.12).
    pub emission_color: Option<String>,
    /// Emission intensity per world unit at emission-grid value 1 (default 4).
    pub emission_intensity: Option<f64>,
    /// Kelvin = temperature value × scale + offset (default: detected from the file —
    /// Blender ×1000, Houdini ×5000, ×1 when the values are Kelvin; see README).
    pub temperature_scale: Option<f64>,
    /// Kelvin = temperature value × scale + offset (default offset 0; giving either
    /// turns the detection off).
    pub temperature_offset: Option<f64>,
    /// Blackbody brightness: emission = colour(K) × intensity × (K/1000)^4 (default 0.05).
    pub blackbody_intensity: Option<f64>,
    /// A light: sun:DX,DY,DZ[:R,G,B[:INTENSITY]] (direction toward the sun; intensity is its
    /// irradiance), point:X,Y,Z[:R,G,B[:INTENSITY]] or env:R,G,B[:INTENSITY] (a uniform
    /// dome of that radiance; --scattering path). Repeatable. Default: sun:0.6,1,0.5:1,1,1:6.
    #[serde(default)]
    pub light: Vec<String>,
    /// Render without any light (emission only).
    #[serde(default)]
    pub no_lights: bool,
    /// Largest march step in voxels of the density grid (default 0.5, at least 1/1024).
    pub step: Option<f64>,
    /// Shadow-ray step in voxels (default 1, at least 1/1024).
    pub shadow_step: Option<f64>,
    /// dsm (a deep shadow map of optical depth baked once per light, default), march (a
    /// shadow ray per sample: the reference) or none.
    pub shadows: Option<String>,
    /// Largest transmittance error the deep shadow map may make, absolute (default 1e-3).
    pub dsm_tolerance: Option<f64>,
    /// Measure the shadow map against marched shadow rays at 10,000 random points inside
    /// the density (max and mean transmittance error, in the stats).
    #[serde(default)]
    pub dsm_verify: bool,
    /// Reuse deep shadow maps from this file (made by `murk bake-shadows`) when the density
    /// and lights match; refuse when they do not.
    pub shadow_cache: Option<PathBuf>,
    /// A ground plane at height Y (world), receiving the lights through the volume: written as
    /// the shadow.R/G/B layer (the fraction of light it receives).
    pub ground: Option<f64>,
    /// Also show the ground plane (grey, Lambertian) in the beauty pass.
    #[serde(default)]
    pub ground_visible: bool,
    /// Reference quality: exact optical depth (f64, per voxel) for camera and shadow rays,
    /// a 1/64-voxel source step (or --step), no early termination. Implies --shadows march;
    /// refuses --shadows dsm|none and a non-zero --termination.
    #[serde(default)]
    pub reference: bool,
    /// Transmittance below which a ray stops (default 1e-4).
    pub termination: Option<f64>,
    /// Samples per pixel (default 1: the pixel centre).
    pub spp: Option<u32>,
    /// Silhouette pixels' stratified grid at one sample a pixel (default 4; 1: off).
    pub antialias: Option<u32>,
    /// Seed of the per-pixel step offsets and pixel jitter (default 0).
    pub seed: Option<u64>,
    /// Worker threads (default: all cores).
    pub threads: Option<usize>,
    /// EXR compression: none, rle, zips, zip, piz, dwaa (default zips).
    pub compression: Option<String>,
    /// Store colour channels as 32-bit float instead of half.
    #[serde(default)]
    pub float: bool,
    /// Write render statistics as JSON.
    pub stats: Option<PathBuf>,
    /// Write an 8-bit sRGB PNG of the beauty pass.
    pub preview: Option<PathBuf>,
    /// Preview exposure in stops (default 0).
    pub exposure: Option<f32>,
    /// Preview background: transparent, black, checker or r,g,b (default checker).
    pub background: Option<String>,
    /// No progress bar.
    #[serde(default)]
    pub quiet: bool,
    // --- frame sequences (scene/frames.rs) ---
    /// The frames of a sequence: `1-10,20,30-40x2` (the paths hold `####`, `%04d` or `$F4`).
    pub frames: Option<String>,

    // Production caches: conventions and how the EXR is placed.
    /// World up axis: y, z or auto (z for Blender's caches, else y). The default camera
    /// and sun follow it.
    pub up_axis: Option<String>,
    /// Z where nothing is: a number (default 1e10, as Cycles writes) or inf.
    pub z_empty: Option<String>,
    /// Crop the EXR's dataWindow to the non-empty pixels (smaller file; Blender's
    /// compositor misplaces it).
    #[serde(default)]
    pub crop_data_window: bool,
    /// Colour space written: lin_rec709 (default) or acescg.
    pub colorspace: Option<String>,
    // --- scattering (scene/transport.rs) ---
    /// How many times light scatters: single (once, by the ray march; default), fast (an
    /// approximation of every order) or path (unbiased path tracing of every order).
    pub scattering: Option<crate::integrate::ScatteringMode>,
    /// Most scattering events a path may have (path: default 10000).
    pub bounces: Option<u32>,
    // --- error budget (render/error_budget.rs) ---
    /// Relative radiance RMSE against `--reference` to meet at least cost: murk chooses
    /// the step, the termination and the shadow map's tolerance.
    pub max_error: Option<f64>,
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
    pub fn from_scene_file(path: &std::path::Path) -> Result<RenderOptions, super::PlanError> {
        let bad = |problem: String| super::PlanError::SceneFile {
            path: path.to_path_buf(),
            problem,
        };
        let text = std::fs::read_to_string(path).map_err(|e| bad(e.to_string()))?;
        let mut o: RenderOptions =
            toml::from_str(&text).map_err(|e| bad(super::scene_file::describe(&e, &text)))?;
        let dir = path.parent().unwrap_or(std::path::Path::new("."));
        for p in [
            &mut o.input,
            &mut o.output,
            &mut o.stats,
            &mut o.preview,
            &mut o.shadow_cache,
        ]
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
                crop_data_window: self.crop_data_window || base.crop_data_window,
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
            phase,
            drop_radius,
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
            antialias,
            seed,
            threads,
            compression,
            stats,
            preview,
            exposure,
            background,
            frames,
            up_axis,
            z_empty,
            colorspace,
            scattering,
            bounces,
            max_error
        )
    }
}
