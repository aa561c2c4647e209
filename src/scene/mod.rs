//! What is rendered: the camera, the lights with their shadows, a ground plane, and the
//! input's fields in their roles (density, emission, temperature, colour) over any
//! [`source::FieldSource`]. [`Scene::build`] does everything a render does before its
//! pixel loop: open the input, decode the fields it needs, frame the camera, bake the
//! shadow maps — and reports each stage (ran, or skipped and why).

pub mod camera;
pub mod camera_motion;
pub mod conventions;
pub mod density_level;
mod error;
pub mod film;
pub mod frames;
pub mod holdout;
pub mod holdout_deep;
pub mod light;
pub mod lights;
mod marched;
pub mod options;
pub mod pilot;
pub mod plan;
pub mod progress;
pub mod report;
pub mod reuse;
pub mod roles;
mod scene_file;
pub mod shot;
pub mod source;
pub mod transport;
pub mod velocity;
pub mod volumes;
pub mod volumes_keyed;

pub use options::RenderOptions;
pub use plan::RenderPlan;

/// Why a render cannot be planned, before anything is loaded.
#[derive(Clone, Debug, PartialEq)]
pub enum PlanError {
    /// Options' values are malformed or out of range, or contradict each other. The
    /// message names each option as `{key}` (a key of [`options::FLAGS`]), which
    /// [`PlanError::named`] fills in as a flag (`--sigma-a`) or a scene file's key.
    Invalid(String),
    /// A scene file cannot be read or parsed.
    SceneFile {
        path: std::path::PathBuf,
        problem: String,
    },
}

impl PlanError {
    /// The message with every option named by `name` (given its key, e.g. `sigma_a`).
    pub fn named(&self, name: &dyn Fn(&str) -> String) -> String {
        match self {
            PlanError::Invalid(message) => fill_option_names(message, name),
            PlanError::SceneFile { path, problem } => format!("{}: {problem}", path.display()),
        }
    }
}

/// `message` with each `{key}` of a render option replaced by `name(key)`; other braces
/// are left as they are.
fn fill_option_names(message: &str, name: &dyn Fn(&str) -> String) -> String {
    let mut out = String::with_capacity(message.len());
    let mut rest = message;
    while let Some(open) = rest.find('{') {
        out.push_str(&rest[..open]);
        let tail = &rest[open..];
        let key = tail[1..]
            .find('}')
            .map(|close| &tail[1..close + 1])
            .filter(|k| options::FLAGS.iter().any(|f| f.key == *k));
        match key {
            Some(k) => {
                out.push_str(&name(k));
                rest = &tail[k.len() + 2..];
            }
            None => {
                out.push('{');
                rest = &tail[1..];
            }
        }
    }
    out.push_str(rest);
    out
}

/// A render option as a flag: `--sigma-a` for `sigma_a`.
pub fn flag_name(key: &str) -> String {
    format!("--{}", key.replace('_', "-"))
}

impl std::fmt::Display for PlanError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.named(&flag_name))
    }
}

impl std::error::Error for PlanError {}

use crate::field::Field;
use crate::integrate::blackbody::BlackbodyTable;
use crate::integrate::ground::Ground;
use crate::integrate::phase::PhaseFunction;
use crate::integrate::{Companion, Medium};
use crate::shadow::ShadowMap;
use camera::{Camera, Projection};
pub use error::SceneError;
use glam::DVec3;
use lights::{SceneLights, bake_maps, light_shadows};
use plan::{EmissionPlan, GridChoice, MarchPlan, ShadowMode};
use progress::Progress;
use report::{SceneReport, Stage};
use roles::{SceneFields, load_fields};
use std::sync::Arc;
use std::time::Instant;

type Result<T, E = SceneError> = std::result::Result<T, E>;

/// A scene ready to render.
pub struct Scene {
    /// The camera rays are shot through: the frame, overscan included.
    pub camera: Camera,
    /// The camera of the image without its overscan (`res`): the one the EXR header
    /// describes.
    pub plate_camera: Camera,
    pub fields: SceneFields,
    pub medium: Medium,
    pub phase: Arc<dyn PhaseFunction>,
    /// Emission settings and the blackbody colours (the fields are in `fields`); `None`
    /// without an emission or temperature field.
    emission: Option<(EmissionPlan, BlackbodyTable)>,
    pub lights: Vec<light::Light>,
    /// A uniform dome light (`--light env:…`), lighting by path tracing only.
    pub environment: Option<light::EnvLight>,
    /// Per light, its transmittance source.
    shadows: Vec<lights::LightShadow>,
    plan_shadows: (crate::shadow::ShadowQuadrature, f64),
    pub ground: Option<Ground>,
    /// With `--max-error`: the density's level the pilot chose (the density in `fields`
    /// is that level), and what it measured.
    pub density_level: Option<density_level::DensityLevelReport>,
    /// Something scatters light toward the camera (lights and σs > 0).
    pub scatters: bool,
    /// Something emits (an emission or temperature field with a non-zero intensity).
    pub emits: bool,
    /// The velocity that blurs the volume within the shutter.
    pub motion: Option<velocity::SceneMotion>,
    /// The camera's motion while the shutter is open (a shot camera that moves).
    pub camera_motion: Option<camera_motion::CameraMotion>,
    pub report: SceneReport,
}

/// A shadow map's transmittance error past which a miss of murk's own tolerance is a
/// warning rather than a note: 5 % of the light, a visible step in a lit gradient. Below
/// it (real caches' maps measure under 1 % against marched shadows) the image does not
/// show it.
pub const VISIBLE_SHADOW_ERROR: f64 = 5e-2;

/// The plan with its default sun turned for the world's up axis: it shines from the same
/// side of the default camera in a Z-up world as in a Y-up one (from the front, above
/// and to the right). Shading and the shadow maps take their lights from this plan.
pub fn turned_for_up(
    plan: &RenderPlan,
    up: conventions::UpAxis,
) -> std::borrow::Cow<'_, RenderPlan> {
    if !plan.production.default_light || up == conventions::UpAxis::Y {
        return std::borrow::Cow::Borrowed(plan);
    }
    let mut p = plan.clone();
    for l in &mut p.lights {
        l.rotate(|v| up.from_y_up(v));
    }
    std::borrow::Cow::Owned(p)
}

impl Scene {
    /// Opens the plan's input, decodes the fields in their roles, frames the camera and
    /// bakes (or reads) the shadow maps the render needs.
    pub fn build(plan: &RenderPlan, progress: &dyn Progress) -> Result<Scene> {
        Scene::build_reusing(plan, progress, &mut reuse::FrameReuse::default())
    }

    /// [`Scene::build`] for one frame of a sequence: what `reuse` kept from the previous
    /// frame is taken when it still holds (shadow maps of an unchanged density).
    pub fn build_reusing(
        plan: &RenderPlan,
        progress: &dyn Progress,
        reuse: &mut reuse::FrameReuse,
    ) -> Result<Scene> {
        let mut report = SceneReport::default();
        // Load: descriptors and metadata only.
        let t = Instant::now();
        let source = match plan.volumes {
            Some(_) => None,
            None => Some(source::open(&plan.input)?),
        };
        report
            .stages
            .insert("load".into(), Stage::ran(t.elapsed().as_secs_f64()));
        let medium = plan.medium;
        let lit = !plan.lights.is_empty() || plan.transport.environment.is_some();
        let scatters = lit && medium.scatters();
        // Build: decode only the fields in a role.
        let t = Instant::now();
        let fields = match (&plan.volumes, &source) {
            (Some(v), _) => volumes::load_volumes(plan, v, scatters, &mut report)?,
            (None, Some(source)) => load_fields(source.as_ref(), plan, scatters, &mut report)?,
            (None, None) => return Err(SceneError::input(&plan.input, "nothing to render")),
        };
        let motion = velocity::load_for(
            plan,
            source.as_deref(),
            fields.density.as_ref(),
            &mut report,
        )?;
        report
            .stages
            .insert("build".into(), Stage::ran(t.elapsed().as_secs_f64()));
        let (plate_w, plate_h) = plan.camera.plate();
        let shot = match &plan.camera.request.shot {
            Some(s) => Some(s.camera(plate_w, plate_h).map_err(PlanError::Invalid)?),
            None => None,
        };
        let (mut up_axis, mut up_why) = conventions::resolve_up_axis(
            plan.production.up_axis,
            &fields.tool,
            fields.up_from_data.as_ref(),
        );
        // A USD camera's stage says the world's up axis (the default sun follows it).
        if let Some(z) = shot.as_ref().and_then(|s| s.up_z)
            && plan.production.up_axis == conventions::UpAxisChoice::Auto
        {
            up_axis = if z {
                conventions::UpAxis::Z
            } else {
                conventions::UpAxis::Y
            };
            up_why = format!("{} (auto: the camera's USD stage)", up_axis.name());
        }
        if fields.tool.is_none() && plan.production.up_axis == conventions::UpAxisChoice::Auto {
            report.notes.push(format!(
                "no tool recognised (no creator metadata, no grid set of Blender, Mantaflow, Houdini or EmberGen): up axis {up_why}; --up-axis y or z to say"
            ));
        }
        report.up_axis = up_why;
        let plan = &*turned_for_up(plan, up_axis);
        let plate_camera = match shot {
            Some(s) => {
                report.notes.extend(s.notes);
                s.camera
            }
            None => resolve_camera(plan, fields.density.as_ref(), up_axis, reuse.frame_box)?,
        };
        let camera_motion = camera_motion::CameraMotion::of_plan(plan)?;
        let (ox, oy) = plan.camera.overscan;
        let camera = plate_camera.overscanned(ox, oy);
        let mut emission_plan = plan.emission;
        if let Some(m) = &fields.temperature_mapping {
            emission_plan.temperature_scale = m.scale;
            emission_plan.temperature_offset = m.offset;
        }
        let emission = (fields.emission.is_some()
            || fields.temperature.is_some()
            || !fields.emitters.is_empty())
        .then(|| (emission_plan, BlackbodyTable::new(200.0, 40000.0, 2048)));
        let lights = plan.lights.clone();
        // The phase function: water-drop tables are built (or read from the disk
        // cache) here, once per process and radius.
        let t = Instant::now();
        let phase =
            crate::integrate::phase::choice::build(plan.phase, plan.medium.g, plan.drop_radius_um)?;
        report
            .stages
            .insert("phase".into(), Stage::ran(t.elapsed().as_secs_f64()));
        let mut scene = Scene {
            camera,
            plate_camera,
            medium,
            phase,
            emission,
            lights,
            environment: plan.transport.environment.clone(),
            shadows: Vec::new(),
            plan_shadows: (
                plan.shadow_quadrature(),
                // Past T = termination the light's contribution is dropped, as the
                // camera ray's is.
                (1.0 / plan.march.termination).ln().max(1.0)
                    / medium.sigma_t().min_element().max(1e-30),
            ),
            ground: plan.ground,
            density_level: None,
            scatters,
            emits: false,
            motion,
            camera_motion,
            report,
            fields,
        };
        let glows = |e: &plan::EmissionPlan, emission: bool, temperature: bool| {
            (emission && e.intensity > 0.0 && e.color.max_element() > 0.0)
                || (temperature && e.blackbody_intensity > 0.0)
        };
        scene.emits = scene.emission.as_ref().is_some_and(|(e, _)| {
            glows(
                e,
                scene.fields.emission.is_some(),
                scene.fields.temperature.is_some(),
            )
        }) || scene
            .fields
            .emitters
            .iter()
            .any(|e| glows(&e.plan, e.emission.is_some(), e.temperature.is_some()));
        scene.report_emission_and_scatter(plan);
        // With --max-error, the density's level first: the map is baked at that level.
        // Where something moves, the shutter's noise takes a share and the map the
        // rest's (`MarchPlan::march_error`); a moving density has no level.
        let leveled = plan.march.max_error.and_then(|e| {
            density_level::apply(&mut scene, plan, e).or_else(|| {
                scene.moves().then(|| {
                    let mut p = plan.clone();
                    p.shadows.dsm_tolerance =
                        MarchPlan::tolerance_of(MarchPlan::march_error(e, 0.0, true));
                    p
                })
            })
        });
        let plan = leveled.as_ref().unwrap_or(plan);
        scene.prepare_shadows(plan, progress, reuse)?;
        Ok(scene)
    }

    fn report_emission_and_scatter(&mut self, plan: &RenderPlan) {
        let density = self.fields.density.as_ref();
        let off_lattice = self
            .emission_fields()
            .filter(|f| Companion::new(*f, density).offset().is_none())
            .count();
        for _ in 0..off_lattice {
            self.report.notes.push("an emission grid is not on the density's lattice: it is sampled only where density is non-zero".into());
        }
        let turned_off =
            plan.grids.emission == GridChoice::Off && plan.grids.temperature == GridChoice::Off;
        let added_nothing = (!self.report.skipped_grids.is_empty()).then(|| {
            let why: Vec<String> = self
                .report
                .skipped_grids
                .iter()
                .map(|(g, r)| format!("grid {g} adds nothing ({r})"))
                .collect();
            why.join("; ")
        });
        let emission_skip_reason = if turned_off {
            "emission and temperature grids turned off".to_string()
        } else if let Some(why) = added_nothing {
            why
        } else if self.fields.emission_found {
            "emission and blackbody intensities are 0".to_string()
        } else {
            "no emission or temperature grid in the scene".to_string()
        };
        let emission = if self.emits {
            Stage::ran(0.0)
        } else {
            Stage::skipped(&emission_skip_reason)
        };
        let scatter = if self.scatters {
            Stage::ran(0.0)
        } else {
            Stage::skipped(self.scatter_skip_reason())
        };
        self.report.stages.insert("emission".into(), emission);
        self.report.stages.insert("scatter".into(), scatter);
    }

    fn scatter_skip_reason(&self) -> &'static str {
        if self.lights.is_empty() && self.environment.is_none() {
            "no lights"
        } else {
            "sigma_s is 0"
        }
    }

    /// Shadows: a map per light, baked once here (or read from a cache) and looked up by
    /// every sample; or marched per sample.
    fn prepare_shadows(
        &mut self,
        plan: &RenderPlan,
        progress: &dyn Progress,
        reuse: &mut reuse::FrameReuse,
    ) -> Result<()> {
        let sigma_t = self.medium.sigma_t();
        // The ground plane needs the lights' shadows even when the medium does not scatter.
        let lit = !plan.lights.is_empty() && sigma_t.max_element() > 0.0;
        let shadows_needed = (self.scatters || (plan.ground.is_some() && lit))
            && plan.shadows.mode != ShadowMode::None;
        let mut maps: Vec<ShadowMap> = Vec::new();
        if shadows_needed && plan.shadows.mode == ShadowMode::Dsm {
            let t = Instant::now();
            let density = self.fields.density.as_ref();
            let hash = density.content_hash();
            if hash.is_none() && plan.shadows.cache.is_some() {
                return Err(SceneError::input(
                    &plan.input,
                    "this input cannot be fingerprinted, so a shadow cache cannot be checked against it",
                ));
            }
            let kept = hash.and_then(|h| reuse.shadow_maps(plan, h, sigma_t));
            let (m, map_stats) = match kept {
                Some(k) => k,
                None => {
                    let columns = reuse.columns.as_deref();
                    let (m, s) =
                        bake_maps(plan, density, hash.unwrap_or(0), sigma_t, progress, columns)?;
                    if let Some(h) = hash {
                        reuse.keep_shadow_maps(plan, h, sigma_t, &m, &s);
                    }
                    (m, s)
                }
            };
            maps = m;
            let report = &mut self.report;
            report.shadow_map_memory_bytes = map_stats.iter().map(|s| s.bake.memory_bytes).sum();
            report.density_memory_bytes = density.memory_bytes();
            // A tolerance the user chose that a map misses is a warning; murk's own
            // (the default, or --max-error's share) a note in the stats, unless the
            // miss is plainly visible. Each says what holds the tolerance.
            let chosen = plan.march.max_error.is_none()
                && plan.shadows.dsm_tolerance != plan::defaults::DSM_TOLERANCE;
            for m in &map_stats {
                let Some(line) = m.shortfall(plan.shadows.dsm_tolerance) else {
                    continue;
                };
                let line = format!(
                    "{line}; --shadows march traces these shadows exactly instead (slower)"
                );
                if chosen || m.bake.over_tolerance_error > VISIBLE_SHADOW_ERROR {
                    report.warnings.push(line);
                } else {
                    report.notes.push(line);
                }
            }
            report.shadow_maps = map_stats;
            report
                .stages
                .insert("shadows".into(), Stage::ran(t.elapsed().as_secs_f64()));
        } else {
            let scatter_reason = self.scatter_skip_reason();
            let report = &mut self.report;
            report.stages.insert(
                "shadows".into(),
                if !self.scatters {
                    Stage::skipped(scatter_reason)
                } else if plan.shadows.mode == ShadowMode::None {
                    Stage::skipped("--shadows none")
                } else {
                    Stage {
                        status: "ran: marched per sample (inside render)".into(),
                        seconds: 0.0,
                    }
                },
            );
        }
        let skipped = format!("skipped: {}", self.scatter_skip_reason());
        let report = &mut self.report;
        report.shadows = match (self.scatters, plan.shadows.mode) {
            (false, _) => skipped,
            (true, ShadowMode::None) => "none".into(),
            (true, ShadowMode::March) => "march".into(),
            (true, ShadowMode::Dsm) => "dsm".into(),
        };
        self.report.lights = self.light_names();
        self.shadows = light_shadows(plan.shadows.mode, maps, plan.lights.len());
        Ok(())
    }

    /// The names of the lights, the environment's last: the per-light layers' order.
    pub fn light_names(&self) -> Vec<String> {
        let mut names: Vec<String> = self.lights.iter().map(|l| l.name.clone()).collect();
        names.extend(self.environment.iter().map(|e| e.name.clone()));
        names
    }

    /// The lights as the integrators see them, with their shadows.
    pub fn illumination(&self) -> SceneLights<'_> {
        SceneLights {
            lights: &self.lights,
            density: self.fields.density.as_ref(),
            shadows: (&self.shadows[..]).into(),
            quadrature: self.plan_shadows.0,
            enough: self.plan_shadows.1,
        }
    }

    /// Near and far planes that bracket the density (for the worldToNDC attribute).
    pub fn depth_range(&self) -> (f64, f64) {
        let (lo, hi) = self.fields.density.world_bounds();
        let w2c = self.camera.world_to_camera();
        let mut far: f64 = 1e-3;
        for c in 0..8 {
            let p = DVec3::new(
                if c & 1 == 0 { lo.x } else { hi.x },
                if c & 2 == 0 { lo.y } else { hi.y },
                if c & 4 == 0 { lo.z } else { hi.z },
            );
            far = far.max(-w2c.transform_point3(p).z);
        }
        ((far * 1e-4).max(1e-4), far * 1.01 + 1e-3)
    }
}

/// The camera the plan asks for, framing the bounds of the density's non-zero values
/// where it does not say, from the front with `up` up.
/// The world box of the density's non-zero cells, `None` when it has none.
pub fn density_box(density: &dyn Field) -> Option<(DVec3, DVec3)> {
    let nonzero = crate::field::nonzero::nonzero_bounds(density);
    (!nonzero.is_empty()).then(|| density.transform().index_box_to_world(&nonzero))
}

fn resolve_camera(
    plan: &RenderPlan,
    density: &dyn Field,
    up: conventions::UpAxis,
    frame_box: Option<(DVec3, DVec3)>,
) -> Result<Camera> {
    let (lo, hi) = match frame_box.or_else(|| density_box(density)) {
        Some(b) => b,
        None => (DVec3::splat(-1.0), DVec3::splat(1.0)),
    };
    let req = &plan.camera.request;
    // Framed in murk's Y-up frame, then turned into the world's: the box's corners
    // map to a box (the turn permutes axes).
    let (a, b) = (up.to_y_up(lo), up.to_y_up(hi));
    let (width, height) = plan.camera.plate();
    let mut framed = Camera::framing(a.min(b), a.max(b), width, height, req.projection);
    framed.eye = up.from_y_up(framed.eye);
    framed.look_at = up.from_y_up(framed.look_at);
    framed.up = up.from_y_up(framed.up);
    let mut cam = framed;
    cam.up = if plan.production.up_explicit {
        req.up
    } else {
        up.vector()
    };
    if let Some(look) = req.look_at {
        cam.look_at = look;
    }
    if let Some(eye) = req.eye {
        cam.eye = eye;
    } else if req.look_at.is_some() {
        cam.eye = cam.look_at + (framed.eye - framed.look_at);
    }
    if let Some(Projection::Orthographic { width }) = req.projection
        && width > 0.0
    {
        cam.projection = Projection::Orthographic { width };
    }
    cam.validate()?;
    Ok(cam)
}
