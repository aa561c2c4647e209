//! The command line's flags (clap). Grouped by what they decide; the groups shared by
//! `render` and `bake-shadows` are declared once and flattened into both. They become
//! the library's [`RenderOptions`] (which a scene file also fills) in [`RenderArgs::options`].

use clap::Args;
use murk::render::RenderOptions;
use std::path::PathBuf;

/// What a deep shadow map depends on (shared by `render` and `bake-shadows`).
#[derive(Args, Clone, Debug, Default, PartialEq)]
pub struct MapArgs {
    /// Grid that holds density (default: detected — density).
    #[arg(long = "density-grid", value_name = "NAME")]
    pub density_grid: Option<String>,
    /// Absorption per world unit at density 1, r,g,b (default 0.1,0.1,0.1).
    #[arg(long = "sigma-a", allow_hyphen_values = true, value_name = "r,g,b")]
    pub sigma_a: Option<String>,
    /// Scattering per world unit at density 1, r,g,b (default 2,2,2).
    #[arg(long = "sigma-s", allow_hyphen_values = true, value_name = "r,g,b")]
    pub sigma_s: Option<String>,
    /// Multiplies density (default 1).
    #[arg(long = "density-scale", allow_hyphen_values = true, value_name = "F")]
    pub density_scale: Option<f64>,
    /// A light: sun:DX,DY,DZ[:R,G,B[:INTENSITY]] (direction toward the sun; intensity is its
    /// irradiance), point:X,Y,Z[:R,G,B[:INTENSITY]] or env:R,G,B[:INTENSITY] (a uniform
    /// dome of that radiance; --scattering path). Repeatable. Default: sun:0.6,1,0.5:1,1,1:6.
    #[arg(long = "light", value_name = "SPEC", allow_hyphen_values = true)]
    pub light: Vec<String>,
    /// Largest transmittance error the deep shadow map may make, absolute (default 1e-3).
    #[arg(long = "dsm-tolerance", allow_hyphen_values = true, value_name = "T")]
    pub dsm_tolerance: Option<f64>,
}

/// How a command runs and reports (shared by `render` and `bake-shadows`).
#[derive(Args, Clone, Debug, Default, PartialEq)]
pub struct RunArgs {
    /// Worker threads (default: all cores).
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Write render statistics as JSON.
    #[arg(long, value_name = "FILE.json")]
    pub stats: Option<PathBuf>,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// The image and the camera.
#[derive(Args, Clone, Debug, Default, PartialEq)]
pub struct CameraArgs {
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
    /// Camera up vector (default: the world's up axis, 0,1,0, or 0,0,1 for a Z-up cache).
    #[arg(long, value_name = "x,y,z", allow_hyphen_values = true)]
    pub up: Option<String>,
    /// Horizontal field of view in degrees, like vdb_render (default 40).
    #[arg(long, allow_hyphen_values = true, value_name = "DEG")]
    pub fov: Option<f64>,
    /// Width of the orthographic view in world units (default: framing the bounds).
    #[arg(long = "ortho-width", allow_hyphen_values = true, value_name = "W")]
    pub ortho_width: Option<f64>,
}

/// Grids in roles other than density.
#[derive(Args, Clone, Debug, Default, PartialEq)]
pub struct RoleArgs {
    /// Grid emitting light (default: detected — flame, flames, fire, emission; "none" to disable).
    #[arg(long = "emission-grid", value_name = "NAME")]
    pub emission_grid: Option<String>,
    /// Temperature grid for blackbody emission (default: detected — temperature, heat; "none" to disable).
    #[arg(long = "temperature-grid", value_name = "NAME")]
    pub temperature_grid: Option<String>,
    /// Vec3 grid tinting scattering (default: detected — Cd, color, colour; "none" to disable).
    #[arg(long = "color-grid", value_name = "NAME")]
    pub color_grid: Option<String>,
}

/// Phase function, emission and lights beyond the shared ones.
#[derive(Args, Clone, Debug, Default, PartialEq)]
pub struct LookArgs {
    /// Henyey–Greenstein anisotropy in (-1, 1) (default 0).
    #[arg(long, value_name = "F", allow_hyphen_values = true)]
    pub g: Option<f64>,
    /// Phase function: hg (Henyey–Greenstein with --g, grey) or water-drop (Lorenz–Mie
    /// for water drops of --drop-radius, in colour: rainbows). Default hg.
    #[arg(long, value_name = "hg|water-drop", hide_possible_values = true)]
    pub phase: Option<murk::integrate::phase::PhaseKind>,
    /// Water-drop radius in micrometres for --phase water-drop: fog ~10, drizzle ~100,
    /// rain 500–1000 (default 500; 0.05–1000).
    #[arg(
        long = "drop-radius",
        value_name = "MICRONS",
        allow_hyphen_values = true
    )]
    pub drop_radius: Option<f64>,
    /// Emission colour, r,g,b (default 1,0.45,0.12).
    #[arg(
        long = "emission-color",
        allow_hyphen_values = true,
        value_name = "r,g,b"
    )]
    pub emission_color: Option<String>,
    /// Emission intensity per world unit at emission-grid value 1 (default 4).
    #[arg(
        long = "emission-intensity",
        allow_hyphen_values = true,
        value_name = "F"
    )]
    pub emission_intensity: Option<f64>,
    /// Kelvin = temperature value × scale + offset (default: detected from the file —
    /// Blender ×1000, Houdini ×5000, ×1 when the values are Kelvin; see README).
    #[arg(
        long = "temperature-scale",
        allow_hyphen_values = true,
        value_name = "F"
    )]
    pub temperature_scale: Option<f64>,
    /// Kelvin = temperature value × scale + offset (default offset 0; giving either
    /// turns the detection off).
    #[arg(
        long = "temperature-offset",
        value_name = "K",
        allow_hyphen_values = true
    )]
    pub temperature_offset: Option<f64>,
    /// Blackbody brightness: emission = colour(K) × intensity × (K/1000)^4 (default 0.05).
    #[arg(
        long = "blackbody-intensity",
        allow_hyphen_values = true,
        value_name = "F"
    )]
    pub blackbody_intensity: Option<f64>,
    /// Render without any light (emission only).
    #[arg(long = "no-lights")]
    pub no_lights: bool,
}

/// Marching, shadows, sampling and the ground plane.
#[derive(Args, Clone, Debug, Default, PartialEq)]
pub struct QualityArgs {
    /// Largest march step in voxels of the density grid (default 0.5, at least 1/1024).
    #[arg(long, allow_hyphen_values = true, value_name = "VOXELS")]
    pub step: Option<f64>,
    /// Shadow-ray step in voxels (default 1, at least 1/1024).
    #[arg(
        long = "shadow-step",
        allow_hyphen_values = true,
        value_name = "VOXELS"
    )]
    pub shadow_step: Option<f64>,
    /// dsm (a deep shadow map of optical depth baked once per light, default), march (a
    /// shadow ray per sample: the reference) or none.
    #[arg(long, value_name = "dsm|march|none")]
    pub shadows: Option<String>,
    /// Measure the shadow map against marched shadow rays at 10,000 random points inside
    /// the density (max and mean transmittance error, in the stats).
    #[arg(long = "dsm-verify")]
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
    pub ground_visible: bool,
    /// Reference quality: exact optical depth (f64, per voxel) for camera and shadow rays,
    /// a 1/64-voxel source step (or --step), no early termination. Implies --shadows march;
    /// refuses --shadows dsm|none and a non-zero --termination.
    #[arg(long)]
    pub reference: bool,
    /// Transmittance below which a ray stops (default 1e-4).
    #[arg(long, allow_hyphen_values = true, value_name = "T")]
    pub termination: Option<f64>,
    /// Meet this relative radiance RMSE against --reference at least cost (e.g. 1e-2):
    /// murk chooses the step and termination from a pilot render and the shadow map's
    /// tolerance, and reports them (stats: error_budget). Not with --step, --termination,
    /// --dsm-tolerance, --reference or --scattering path.
    #[arg(long = "max-error", value_name = "E", allow_hyphen_values = true)]
    pub max_error: Option<f64>,
    /// Samples per pixel (default 1: the pixel centre).
    #[arg(long, value_name = "N")]
    pub spp: Option<u32>,
    /// At one sample a pixel, silhouette pixels (alpha differs from a neighbour's by more
    /// than 0.1) are rendered again as N×N stratified samples (default 4; 1: pixel
    /// centres only).
    #[arg(long, value_name = "N")]
    pub antialias: Option<u32>,
    /// Seed of the per-pixel step offsets and pixel jitter (default 0).
    #[arg(long, value_name = "N")]
    pub seed: Option<u64>,
}

/// How light is transported: the scattering orders and the integrator that finds them.
#[derive(Args, Clone, Debug, Default, PartialEq)]
pub struct TransportArgs {
    /// How many times light scatters: fast (every order approximated; default: single
    /// scattering plus a coarse lattice for the rest), single (once, by the ray march)
    /// or path (unbiased path tracing of every order).
    #[arg(long, value_name = "single|fast|path", hide_possible_values = true)]
    pub scattering: Option<murk::integrate::ScatteringMode>,
    /// Most scattering events a path may have (path: default 10000), or the orders the
    /// approximation models, later ones as a geometric tail (fast: default 24).
    #[arg(long, value_name = "N")]
    pub bounces: Option<u32>,
}

/// The files written besides the EXR.
#[derive(Args, Clone, Debug, Default, PartialEq)]
pub struct ImageArgs {
    /// EXR compression: none, rle, zips, zip, piz, dwaa (default zips).
    #[arg(long, value_name = "NAME")]
    pub compression: Option<String>,
    /// Store colour channels as 32-bit float instead of half.
    #[arg(long)]
    pub float: bool,
    /// Write an 8-bit sRGB PNG of the beauty pass.
    #[arg(long, value_name = "FILE.png")]
    pub preview: Option<PathBuf>,
    /// Preview exposure in stops (default 0).
    #[arg(long, value_name = "STOPS", allow_hyphen_values = true)]
    pub exposure: Option<f32>,
    /// Preview background: transparent, black, checker or r,g,b (default checker).
    #[arg(long, value_name = "BG")]
    pub background: Option<String>,
}

/// Production caches: the conventions murk assumes and how the EXR is placed.
#[derive(Args, Clone, Debug, Default, PartialEq)]
pub struct ProductionArgs {
    /// World up axis: y, z or auto (z for Blender's caches, told by metadata or grid
    /// names; else y). The default camera and sun follow it (default auto).
    #[arg(long = "up-axis", value_name = "y|z|auto")]
    pub up_axis: Option<String>,
    /// Z where nothing is: a number or inf (default 1e10, as Cycles writes: +inf turns
    /// into NaN under filtered resizes).
    #[arg(long = "z-empty", value_name = "DEPTH|inf", allow_hyphen_values = true)]
    pub z_empty: Option<String>,
    /// Crop the EXR's dataWindow to the non-empty pixels (a smaller file; Blender's
    /// compositor misplaces a cropped dataWindow). Default: dataWindow = displayWindow.
    #[arg(long = "crop-data-window")]
    pub crop_data_window: bool,
    /// Colour space of the EXR's colour channels: lin_rec709 or acescg (converted, with
    /// chromaticities to match) (default lin_rec709).
    #[arg(long, value_name = "lin_rec709|acescg")]
    pub colorspace: Option<String>,
}

/// `murk render` flags.
#[derive(Args, Clone, Debug, Default, PartialEq)]
pub struct RenderArgs {
    /// Output EXR.
    #[arg(short = 'o', long = "output", value_name = "OUT.exr")]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub map: MapArgs,
    #[command(flatten)]
    pub run: RunArgs,
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub role: RoleArgs,
    #[command(flatten)]
    pub look: LookArgs,
    #[command(flatten)]
    pub quality: QualityArgs,
    #[command(flatten)]
    pub image: ImageArgs,
    #[command(flatten)]
    pub sequence: SequenceArgs,
    #[command(flatten)]
    pub production: ProductionArgs,
    #[command(flatten)]
    pub transport: TransportArgs,
}

/// Frame sequences and pieces of frames (for a farm).
#[derive(Args, Clone, Debug, Default, PartialEq)]
pub struct SequenceArgs {
    /// Frames to render, e.g. 1-10,20,30-40x2 (default: every frame the input pattern
    /// finds). INPUT, -o, --preview, --stats and --shadow-cache may hold a frame pattern:
    /// #### (one # per digit), %04d, $F4 or $F.
    #[arg(long, value_name = "LIST")]
    pub frames: Option<String>,
    /// Leave frames whose output is already a complete EXR (resume a killed run).
    #[arg(long = "skip-existing")]
    pub skip_existing: bool,
    /// Render only the I-th of N bands of rows into a partial EXR, for `murk stitch`.
    #[arg(long, value_name = "I/N")]
    pub tile: Option<String>,
}

/// `murk bake-shadows` flags: only what decides a shadow map, so that camera and image
/// flags, which would change nothing, are refused rather than silently ignored. A scene
/// file may still hold them: the bake reads the scene as a render would.
#[derive(Args, Clone, Debug, Default, PartialEq)]
pub struct BakeArgs {
    /// The .vdb to write: each light's map as float grids of optical depth (with its
    /// slopes), for `murk render --shadow-cache`.
    #[arg(short = 'o', long = "output", value_name = "SHADOWS.vdb")]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub map: MapArgs,
    #[command(flatten)]
    pub run: RunArgs,
}

impl MapArgs {
    /// These flags over `o`.
    fn set(self, o: &mut RenderOptions) {
        o.density_grid = self.density_grid;
        o.sigma_a = self.sigma_a;
        o.sigma_s = self.sigma_s;
        o.density_scale = self.density_scale;
        o.light = self.light;
        o.dsm_tolerance = self.dsm_tolerance;
    }
}

impl RunArgs {
    /// These flags over `o`.
    fn set(self, o: &mut RenderOptions) {
        o.threads = self.threads;
        o.stats = self.stats;
        o.quiet = self.quiet;
    }
}

impl RenderArgs {
    /// The options these flags give (unset ones stay unset, for a scene file to fill).
    pub fn options(self) -> RenderOptions {
        let a = self;
        let mut o = RenderOptions {
            output: a.output,
            res: a.camera.res,
            camera: a.camera.camera,
            eye: a.camera.eye,
            look_at: a.camera.look_at,
            up: a.camera.up,
            fov: a.camera.fov,
            ortho_width: a.camera.ortho_width,
            emission_grid: a.role.emission_grid,
            temperature_grid: a.role.temperature_grid,
            color_grid: a.role.color_grid,
            g: a.look.g,
            phase: a.look.phase,
            drop_radius: a.look.drop_radius,
            emission_color: a.look.emission_color,
            emission_intensity: a.look.emission_intensity,
            temperature_scale: a.look.temperature_scale,
            temperature_offset: a.look.temperature_offset,
            blackbody_intensity: a.look.blackbody_intensity,
            no_lights: a.look.no_lights,
            step: a.quality.step,
            shadow_step: a.quality.shadow_step,
            shadows: a.quality.shadows,
            dsm_verify: a.quality.dsm_verify,
            shadow_cache: a.quality.shadow_cache,
            ground: a.quality.ground,
            ground_visible: a.quality.ground_visible,
            reference: a.quality.reference,
            termination: a.quality.termination,
            max_error: a.quality.max_error,
            spp: a.quality.spp,
            antialias: a.quality.antialias,
            seed: a.quality.seed,
            compression: a.image.compression,
            float: a.image.float,
            preview: a.image.preview,
            exposure: a.image.exposure,
            background: a.image.background,
            frames: a.sequence.frames,
            up_axis: a.production.up_axis,
            z_empty: a.production.z_empty,
            crop_data_window: a.production.crop_data_window,
            colorspace: a.production.colorspace,
            scattering: a.transport.scattering,
            bounces: a.transport.bounces,
            ..RenderOptions::default()
        };
        a.map.set(&mut o);
        a.run.set(&mut o);
        o
    }
}

impl BakeArgs {
    /// The options these flags give.
    pub fn options(self) -> RenderOptions {
        let mut o = RenderOptions {
            output: self.output,
            ..RenderOptions::default()
        };
        self.map.set(&mut o);
        self.run.set(&mut o);
        o
    }
}
