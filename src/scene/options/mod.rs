//! Everything a render can be told, from flags or a scene file, declared once: the table
//! below gives each option's field, doc, value name, default, help group and commands.
//! From it come [`RenderOptions`] (which a scene file deserialises into), [`FLAGS`]
//! (from which `cli` builds the flags and `--help`) and the scene file's key docs
//! ([`scene_keys_markdown`]). Every field is optional: a flag overrides the scene file,
//! the scene file overrides the defaults, which [`RenderPlan::new`](super::RenderPlan::new)
//! fills in while it checks each value.

mod flag;
pub mod volume;

pub use flag::{Commands, DefaultValue, FlagDef, FlagValue, Group, Kind, Slot};
use serde::Deserialize;
use std::path::PathBuf;

/// Declares the render options: one entry each, `doc; field: type = (group, value name,
/// default, commands);`.
macro_rules! render_options {
    ($(
        $(#[doc = $doc:literal])+
        $field:ident : $ty:ty = ($group:ident, $value_name:literal, $default:expr, $cmds:ident);
    )*) => {
        /// Render options as given: from the command line (`murk render --...`) or a scene
        /// file. Every field is optional; [`RenderPlan::new`](super::RenderPlan::new) fills
        /// in the defaults and validates.
        #[derive(Clone, Debug, Default, Deserialize, PartialEq)]
        #[serde(deny_unknown_fields)]
        pub struct RenderOptions {
            /// Scene files only: the input to render (relative to the scene file).
            #[serde(default)]
            pub input: Option<PathBuf>,
            /// Scene files only: named lights, `[[lights]] name = "key"  spec = "sun:..."`.
            #[serde(default)]
            pub lights: Vec<NamedLight>,
            /// Scene files only: volumes placed in the world, `[[volume]] file = "..."`.
            #[serde(default)]
            pub volume: Vec<volume::VolumeTable>,
            $(
                $(#[doc = $doc])+
                #[serde(default)]
                pub $field: $ty,
            )*
        }

        /// Every render option, in the order `--help` lists them within a group.
        pub const FLAGS: &[FlagDef] = &[$(
            FlagDef {
                key: stringify!($field),
                doc: concat!($($doc, "\n"),+),
                value_name: $value_name,
                default: $default,
                group: Group::$group,
                commands: Commands::$cmds,
                kind: <$ty as Slot>::KIND,
            },
        )*];

        impl RenderOptions {
            /// Sets the option `key` (a [`FLAGS`] key) from its text on the command line;
            /// the error says why the text is not a value of it.
            pub fn set_flag(&mut self, key: &str, raw: &str) -> Result<(), String> {
                match key {
                    $(stringify!($field) => Slot::set(&mut self.$field, raw),)*
                    _ => Err(format!("murk has no option `{key}`")),
                }
            }

            /// Whether the option `key` is set (a switch: on).
            pub fn is_given(&self, key: &str) -> bool {
                match key {
                    $(stringify!($field) => Slot::is_given(&self.$field),)*
                    _ => false,
                }
            }

            /// `self` where set, else `base`. Lights given as flags replace the scene's
            /// named lights.
            pub fn over(self, base: RenderOptions) -> RenderOptions {
                let lights = if !self.light.is_empty() {
                    Vec::new()
                } else if self.lights.is_empty() {
                    base.lights
                } else {
                    self.lights
                };
                let volume = if self.volume.is_empty() {
                    base.volume
                } else {
                    self.volume
                };
                RenderOptions {
                    input: self.input.or(base.input),
                    lights,
                    volume,
                    $($field: Slot::over(self.$field, base.$field),)*
                }
            }
        }
    };
}

use DefaultValue::{Described, None as NoDefault, Value};

render_options! {
    /// The file to write: the EXR (`render`), or the shadow maps' .vdb (`bake-shadows`).
    output: Option<PathBuf> = (Output, "FILE", NoDefault, RenderAndBake);

    /// Image size, WxH.
    res: Option<String> = (Camera, "WxH", Value("640x360"), Render);
    /// persp or ortho. In a scene file, also a [camera] table: a film back and where
    /// the camera is, keyable per frame (docs/guide.md).
    camera: Option<CameraSetting> = (Camera, "persp|ortho", Value("persp"), Render);
    /// The shot's camera from a file: USD (.usd, .usda, .usdc, .usdz) or a Nuke .chan;
    /// each frame of --frames is the camera's time.
    camera_file: Option<PathBuf> = (Camera, "FILE", NoDefault, Render);
    /// The USD camera prim to render through.
    camera_prim: Option<String> = (Camera, "/PATH", Described("the stage's only camera"), Render);
    /// Euler order of a .chan's (and the [camera] table's) rotations, first axis first:
    /// xyz, xzy, yxz, yzx, zxy or zyx.
    camera_rotation_order: Option<String> = (Camera, "ORDER", Described("zxy, Nuke's"), Render);
    /// How a camera file's film gate fits the image: horizontal, vertical, fill or
    /// overscan.
    film_fit: Option<String> = (Camera, "FIT", Described("horizontal; vertical for a .chan"), Render);
    /// Camera position x,y,z.
    eye: Option<String> = (Camera, "x,y,z", Described("framing the density's bounds"), Render);
    /// Point the camera looks at, x,y,z.
    look_at: Option<String> = (Camera, "x,y,z", Described("the centre of the density's bounds"), Render);
    /// Camera up vector.
    up: Option<String> = (Camera, "x,y,z", Described("the world's up axis: 0,1,0, or 0,0,1 for a Z-up cache"), Render);
    /// Horizontal field of view in degrees, like vdb_render.
    fov: Option<f64> = (Camera, "DEG", Value("40"), Render);
    /// Width of the orthographic view in world units.
    ortho_width: Option<f64> = (Camera, "W", Described("framing the bounds"), Render);
    /// Shutter interval OPEN,CLOSE in frames from the frame's time (-0.25,0.25: a
    /// centred 180° shutter): each camera sample is taken at a time in it, and a volume
    /// with a velocity grid blurs.
    shutter: Option<String> = (Camera, "OPEN,CLOSE", Described("off"), Render);
    /// Frames per second: how a velocity per second becomes a displacement per frame.
    fps: Option<f64> = (Camera, "FPS", Value("24"), Render);
    /// Pixels rendered beyond each edge of the image, for lens distortion: the EXR's
    /// data window grows by X left and right and Y above and below, its display window
    /// stays the image of --res through the same camera.
    overscan: Option<String> = (Camera, "X[,Y]", Value("0"), Render);
    /// The volumes' world unit in metres: a USD camera from a stage of another
    /// metersPerUnit is scaled into it (1 for Houdini's metres; by default the stage's
    /// units are taken to be the volumes').
    scene_meters_per_unit: Option<f64> = (Camera, "M", Described("the camera stage's units"), Render);

    /// Grid that holds density.
    density_grid: Option<String> = (Grids, "NAME", Described("detected: density"), RenderAndBake);
    /// Grid emitting light ("none" to disable).
    emission_grid: Option<String> = (Grids, "NAME", Described("detected: flame, flames, fire, emission"), Render);
    /// Temperature grid for blackbody emission ("none" to disable).
    temperature_grid: Option<String> = (Grids, "NAME", Described("detected: temperature, heat"), Render);
    /// Vec3 grid tinting scattering ("none" to disable).
    color_grid: Option<String> = (Grids, "NAME", Described("detected: Cd, color, colour"), Render);
    /// Vec3 velocity grid that blurs the volume within --shutter ("none" to disable).
    velocity_grid: Option<String> = (Grids, "NAME", Described("detected: vel, v, velocity, or a vel.x/y/z or velocity_x/y/z triplet"), Render);

    /// Absorption per world unit at density 1, r,g,b.
    sigma_a: Option<String> = (Look, "r,g,b", Value("0.1,0.1,0.1"), RenderAndBake);
    /// Scattering per world unit at density 1, r,g,b.
    sigma_s: Option<String> = (Look, "r,g,b", Value("2,2,2"), RenderAndBake);
    /// Multiplies density.
    density_scale: Option<f64> = (Look, "F", Value("1"), RenderAndBake);
    /// Henyey–Greenstein anisotropy in (-1, 1).
    g: Option<f64> = (Look, "F", Value("0"), Render);
    /// Phase function: hg (Henyey–Greenstein with --g, grey) or water-drop (Lorenz–Mie
    /// for water drops of --drop-radius, in colour: rainbows).
    phase: Option<crate::integrate::phase::PhaseKind> = (Look, "hg|water-drop", Value("hg"), Render);
    /// Water-drop radius in micrometres for --phase water-drop: fog ~10, drizzle ~100,
    /// rain 500–1000 (0.05–1000).
    drop_radius: Option<f64> = (Look, "MICRONS", Value("500"), Render);
    /// Emission colour, r,g,b.
    emission_color: Option<String> = (Look, "r,g,b", Value("1,0.45,0.12"), Render);
    /// Emission intensity per world unit at emission-grid value 1.
    emission_intensity: Option<f64> = (Look, "F", Value("4"), Render);
    /// Kelvin = temperature value × scale + offset (giving it or the offset turns the
    /// detection off).
    temperature_scale: Option<f64> = (Look, "F", Described("detected from the file: Blender ×1000, Houdini ×5000, ×1 when the values are Kelvin"), Render);
    /// Kelvin = temperature value × scale + offset (giving it or the scale turns the
    /// detection off).
    temperature_offset: Option<f64> = (Look, "K", Described("0, detected with the scale"), Render);
    /// Multiplies the velocity grid's vectors.
    velocity_scale: Option<f64> = (Look, "F", Value("1"), Render);
    /// Time unit of the velocity grid: second (world units per second, as Houdini and
    /// Blender write) or frame.
    velocity_unit: Option<String> = (Look, "second|frame", Value("second"), Render);
    /// Blackbody brightness: emission = colour(K) × intensity × (K/1000)^4.
    blackbody_intensity: Option<f64> = (Look, "F", Value("0.05"), Render);

    /// A light: sun:DX,DY,DZ[:R,G,B[:INTENSITY]] (direction toward the sun; intensity is its
    /// irradiance), point:X,Y,Z[:R,G,B[:INTENSITY]] or env:R,G,B[:INTENSITY] (a uniform
    /// dome of that radiance; --scattering path). Repeatable.
    light: Vec<String> = (Lights, "SPEC", Described("sun:0.6,1,0.5:1,1,1:6, turned for a Z-up cache"), RenderAndBake);
    /// Render without any light (emission only).
    no_lights: bool = (Lights, "", NoDefault, Render);
    /// dsm (a deep shadow map of optical depth baked once per light), march (a shadow ray
    /// per sample: the reference) or none.
    shadows: Option<String> = (Lights, "dsm|march|none", Described("dsm; march with --reference"), Render);
    /// Largest transmittance error the deep shadow map may make, absolute.
    dsm_tolerance: Option<f64> = (Lights, "T", Value("1e-3"), RenderAndBake);
    /// Measure the shadow map against marched shadow rays at 10,000 random points inside
    /// the density (max and mean transmittance error, in the stats).
    dsm_verify: bool = (Lights, "", NoDefault, Render);
    /// Reuse deep shadow maps from this file (made by `murk bake-shadows`) when the density
    /// and lights match; refuse when they do not.
    shadow_cache: Option<PathBuf> = (Lights, "SHADOWS.vdb", NoDefault, Render);
    /// Shadow-ray step in voxels for --shadows march (at least 1/1024).
    shadow_step: Option<f64> = (Lights, "VOXELS", Value("1"), Render);
    /// A ground plane at height Y (world), receiving the lights through the volume: written as
    /// the shadow.R/G/B layer (the fraction of light it receives).
    ground: Option<f64> = (Lights, "Y", NoDefault, Render);
    /// Also show the ground plane (grey, Lambertian) in the beauty pass.
    ground_visible: bool = (Lights, "", NoDefault, Render);

    /// Largest march step in voxels of the density grid (at least 1/1024).
    step: Option<f64> = (Quality, "VOXELS", Described("0.5; 1/64 with --reference"), Render);
    /// Transmittance below which a ray stops.
    termination: Option<f64> = (Quality, "T", Described("1e-4; 0 with --reference"), Render);
    /// Meet this relative radiance RMSE against --reference at least cost (e.g. 1e-2):
    /// murk chooses the step and termination from a pilot render and the shadow map's
    /// tolerance, and reports them (stats: error_budget); where something moves while
    /// --shutter is open, the samples a pixel too, at the pixel's centre (an explicit
    /// --spp wins). Not with --step, --termination, --dsm-tolerance, --reference or
    /// --scattering path.
    max_error: Option<f64> = (Quality, "E", NoDefault, Render);
    /// Reference quality: exact optical depth (f64, per voxel) for camera and shadow rays,
    /// a 1/64-voxel source step (or --step), no early termination. Implies --shadows march;
    /// refuses --shadows dsm|none and a non-zero --termination.
    reference: bool = (Quality, "", NoDefault, Render);
    /// Samples per pixel (1: the pixel centre).
    spp: Option<u32> = (Quality, "N", Described("1; chosen by --max-error where something moves while --shutter is open"), Render);
    /// At one sample a pixel, silhouette pixels (alpha differs from a neighbour's by more
    /// than 0.1) are rendered again as N×N stratified samples (1: pixel centres only).
    antialias: Option<u32> = (Quality, "N", Value("4"), Render);
    /// Seed of the per-pixel step offsets and pixel jitter.
    seed: Option<u64> = (Quality, "N", Value("0"), Render);

    /// How many times light scatters: fast (every order approximated: single scattering
    /// plus a coarse lattice for the rest), single (once, by the ray march) or path
    /// (unbiased path tracing of every order).
    scattering: Option<crate::integrate::ScatteringMode> = (Transport, "single|fast|path", Value("fast"), Render);
    /// Most scattering events a path may have (path), or the orders the approximation
    /// models, later ones as a geometric tail (fast).
    bounces: Option<u32> = (Transport, "N", Described("24 with fast, 10000 with path"), Render);

    /// EXR compression: none, rle, zips, zip, piz, dwaa.
    compression: Option<String> = (Image, "NAME", Value("zips"), Render);
    /// Store colour channels as 32-bit float instead of half.
    float: bool = (Image, "", NoDefault, Render);
    /// Write an 8-bit sRGB PNG of the beauty pass.
    preview: Option<PathBuf> = (Image, "FILE.png", NoDefault, Render);
    /// Also write a deep scanline EXR: the volume as samples in depth (Z..ZBack,
    /// premultiplied R,G,B,A), for deep compositing. Not with --scattering path.
    deep: Option<PathBuf> = (Image, "FILE.exr", NoDefault, Render);
    /// Largest error in opacity (and in colour, relative to the pixel's) that merging
    /// deep samples may make at any depth inside a merged sample: larger, fewer samples.
    deep_tolerance: Option<f64> = (Image, "T", Value("0.01"), Render);
    /// Layers each deep sample carries too, comma-separated, as channels named as in
    /// the flat file: emission, scatter, indirect, lights (each light's scatter_<light>)
    /// or all. Premultiplied like R,G,B: flattened, each is its flat layer.
    deep_aovs: Option<String> = (Image, "LIST", NoDefault, Render);
    /// Preview exposure in stops.
    exposure: Option<f32> = (Image, "STOPS", Value("0"), Render);
    /// Preview background: transparent, black, checker or r,g,b.
    background: Option<String> = (Image, "BG", Value("checker"), Render);

    /// World up axis: y, z or auto (z for Blender's caches, told by metadata or grid
    /// names; else y). The default camera and sun follow it.
    up_axis: Option<String> = (Production, "y|z|auto", Value("auto"), Render);
    /// Z where nothing is: a number or inf (1e10 as Cycles writes: +inf turns into NaN
    /// under filtered resizes).
    z_empty: Option<String> = (Production, "DEPTH|inf", Value("1e10"), Render);
    /// Crop the EXR's dataWindow to the non-empty pixels (a smaller file; Blender's
    /// compositor misplaces a cropped dataWindow). Off: dataWindow = displayWindow.
    crop_data_window: bool = (Production, "", NoDefault, Render);
    /// Cut the volume where a depth image from the same camera says (the CG render's Z):
    /// FILE.exr[:CHANNEL], channel Z, depth.Z or Depth.Z when not named. Rays stop at its
    /// depth, so alpha, light and every layer are cut; the lights' shadows are not.
    holdout_depth: Option<String> = (Production, "FILE[:CHANNEL]", NoDefault, Render);
    /// Cut the volume where a deep image from the same camera (the CG render's deep
    /// output) turns opaque: each pixel at the front of the sample that takes its
    /// accumulated alpha to 0.999, as --holdout-depth cuts.
    holdout_deep: Option<String> = (Production, "FILE", NoDefault, Render);
    /// Colour space of the EXR's colour channels: lin_rec709 or acescg (converted, with
    /// chromaticities to match).
    colorspace: Option<String> = (Production, "lin_rec709|acescg", Value("lin_rec709"), Render);

    /// Frames to render, e.g. 1-10,20,30-40x2. INPUT, -o, --preview, --stats, --deep and
    /// --shadow-cache may hold a frame pattern: #### (one # per digit), %04d, $F4 or $F.
    frames: Option<String> = (Sequence, "LIST", Described("every frame the input pattern finds"), Render);

    /// Worker threads.
    threads: Option<usize> = (Run, "N", Described("all cores"), RenderAndBake);
    /// Where the pixels are computed: cpu, gpu (through Vulkan, Metal or DX12; fails on a
    /// scene the GPU cannot render yet) or auto (the GPU when one is found and runs every
    /// feature of the scene, else the CPU with a note saying why).
    device: Option<crate::scene::plan::device::Device> = (Run, "cpu|gpu|auto", Value("cpu"), Render);
    /// Write render statistics as JSON.
    stats: Option<PathBuf> = (Run, "FILE.json", NoDefault, RenderAndBake);
    /// No progress bar.
    quiet: bool = (Run, "", NoDefault, RenderAndBake);
}

/// The `camera` key: `persp` or `ortho` (a flag or a scene file's string), or a scene
/// file's `[camera]` table.
#[derive(Clone, Debug, PartialEq)]
pub enum CameraSetting {
    Kind(String),
    Table(Box<crate::scene::shot::table::CameraTable>),
}

impl From<&str> for CameraSetting {
    fn from(kind: &str) -> Self {
        CameraSetting::Kind(kind.to_string())
    }
}

impl FlagValue for CameraSetting {
    fn parse_flag(raw: &str) -> Result<Self, String> {
        Ok(CameraSetting::Kind(raw.to_string()))
    }
}

impl<'de> Deserialize<'de> for CameraSetting {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Either;
        impl<'de> serde::de::Visitor<'de> for Either {
            type Value = CameraSetting;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("\"persp\", \"ortho\" or a [camera] table")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<CameraSetting, E> {
                Ok(CameraSetting::Kind(v.to_string()))
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                map: A,
            ) -> Result<CameraSetting, A::Error> {
                let table =
                    Deserialize::deserialize(serde::de::value::MapAccessDeserializer::new(map))?;
                Ok(CameraSetting::Table(Box::new(table)))
            }
        }
        d.deserialize_any(Either)
    }
}

/// A light in a scene file, with the name its scatter layer gets.
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct NamedLight {
    pub name: String,
    pub spec: String,
}

/// The scene file's keys as a Markdown table, from the same text as `--help`:
/// docs/scene-file.md holds it (a test keeps it current).
pub fn scene_keys_markdown() -> String {
    let mut out = String::from(
        "| key | value | what it sets |\n|---|---|---|\n| `input` | path | the input to render, relative to the scene file (scene files only) |\n| `[[lights]]` | `name`, `spec` | a named light: `spec` as `light` takes it; its layer is `scatter_<name>` (scene files only) |\n| `[camera]` | `focal_length`, `horizontal_aperture`, `vertical_aperture`, `horizontal_aperture_offset`, `vertical_aperture_offset`, `clipping_range`, `pixel_aspect`, `projection`, `translate`, `rotate`, `[[camera.keys]]` with `frame` | the shot camera's film back and placement, keyable per frame (docs/guide.md, scene files only) |\n",
    );
    out.push_str(volume::VOLUME_ROW);
    for f in FLAGS {
        let value = match f.kind {
            Kind::Switch => "true/false".to_string(),
            Kind::Repeated => format!("[\"{}\", …]", f.value_name),
            Kind::Value => f.value_name.to_string(),
        };
        out.push_str(&format!(
            "| `{}` | `{}` | {} |\n",
            f.key,
            value.replace('|', "\\|"),
            f.help().replace('|', "\\|")
        ));
    }
    out
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
        for h in [&mut o.holdout_depth, &mut o.holdout_deep]
            .into_iter()
            .flatten()
        {
            if std::path::Path::new(h.as_str()).is_relative() {
                *h = dir.join(h.as_str()).display().to_string();
            }
        }
        for p in [
            &mut o.input,
            &mut o.output,
            &mut o.stats,
            &mut o.preview,
            &mut o.deep,
            &mut o.shadow_cache,
            &mut o.camera_file,
        ]
        .into_iter()
        .flatten()
        {
            if p.is_relative() {
                *p = dir.join(&*p);
            }
        }
        for v in &mut o.volume {
            if v.file.is_relative() {
                v.file = dir.join(&v.file);
            }
        }
        Ok(o)
    }
}
