//! The velocity role: which grid moves the volume within the shutter, detected by the
//! names Houdini, Blender and EmberGen give it, decoded only when a shutter is open.

use super::SceneError;
use super::plan::{GridChoice, RenderPlan};
use super::report::SceneReport;
use super::source::{FieldKind, FieldSource, VelocityNames};
use crate::field::Field;
use crate::field::advect::{GridVelocity, VelocityField};
use crate::field::padded_cells::CellCache;
use crate::integrate::motion::Motion;

/// Vector grids of velocity, by name, in order of preference: Houdini's `vel` (and
/// `v`), Blender's `velocity`.
pub const VELOCITY_NAMES: &[&str] = &["vel", "v", "velocity"];
/// Velocity as three float grids, one a component.
pub const VELOCITY_CHANNEL_NAMES: &[[&str; 3]] = &[
    ["vel.x", "vel.y", "vel.z"],
    ["velocity_x", "velocity_y", "velocity_z"],
    ["vel_x", "vel_y", "vel_z"],
    ["v.x", "v.y", "v.z"],
];

/// The scene's velocity and how much of it a frame is.
pub struct SceneMotion {
    pub velocity: GridVelocity,
    /// The velocity's time units in a frame, times `--velocity-scale`.
    pub per_frame: f64,
    /// The largest |time| in the shutter, frames.
    pub frames: f64,
    /// The moving fields' grown cell ranges, built on first use.
    pub cells: CellCache,
    /// The grid (or grids) it was read from.
    pub name: String,
}

impl SceneMotion {
    /// As the integrators take it.
    pub fn motion(&self) -> Motion<'_> {
        Motion {
            velocity: &self.velocity,
            per_frame: self.per_frame,
            frames: self.frames,
            cells: Some(&self.cells),
        }
    }
}

/// Which fields the velocity is read from: those named (one vector grid, a list
/// `x,y,z` of float grids, or the first of such a triplet), else the first of the usual
/// names; `None` where there is none (or `none`).
fn choose(
    source: &dyn FieldSource,
    choice: &GridChoice,
) -> Result<Option<VelocityNames>, SceneError> {
    let has = |n: &str, kind: FieldKind| {
        source
            .fields()
            .iter()
            .find(|f| (f.name == n || f.unique_name == n) && f.kind == kind)
            .map(|f| f.unique_name.clone())
    };
    let triplet = |[x, y, z]: [&str; 3]| -> Option<VelocityNames> {
        Some(VelocityNames::Channels([
            has(x, FieldKind::Scalar)?,
            has(y, FieldKind::Scalar)?,
            has(z, FieldKind::Scalar)?,
        ]))
    };
    let bad = |value: &str, problem: String| SceneError::Flag {
        flag: "--velocity-grid",
        value: value.to_string(),
        problem,
    };
    match choice {
        GridChoice::Off => Ok(None),
        GridChoice::Named(list) if list.contains(',') => {
            let names: Vec<&str> = list.split(',').map(str::trim).collect();
            let [x, y, z] = names[..] else {
                return Err(bad(list, "a list names three float grids, x,y,z".into()));
            };
            triplet([x, y, z]).map(Some).ok_or_else(|| {
                bad(
                    list,
                    format!("not three float grids of {}", source.field_list()),
                )
            })
        }
        GridChoice::Named(n) => {
            if let Some(v) = has(n, FieldKind::Vector) {
                return Ok(Some(VelocityNames::Vector(v)));
            }
            // The first of a triplet: `vel.x` finds `vel.y` and `vel.z`.
            let stem = n
                .strip_suffix('x')
                .filter(|s| s.ends_with('.') || s.ends_with('_'));
            if let Some(stem) = stem
                && let Some(t) = triplet([n, &format!("{stem}y"), &format!("{stem}z")])
            {
                return Ok(Some(t));
            }
            Err(bad(
                n,
                format!(
                    "not a vec3 grid or the x grid of an x/y/z triplet in {} ({})",
                    source.path().display(),
                    source.field_list()
                ),
            ))
        }
        GridChoice::Detect => Ok(VELOCITY_NAMES
            .iter()
            .find_map(|n| has(n, FieldKind::Vector))
            .map(VelocityNames::Vector)
            .or_else(|| VELOCITY_CHANNEL_NAMES.iter().find_map(|t| triplet(*t)))),
    }
}

/// [`load`] from the scene's one input (`None`: a scene of `[[volume]]` tables, whose
/// volumes are moved each by its own velocity).
pub fn load_for(
    plan: &RenderPlan,
    source: Option<&dyn FieldSource>,
    density: &dyn Field,
    report: &mut SceneReport,
) -> Result<Option<SceneMotion>, SceneError> {
    let Some(source) = source else {
        // Each volume's own velocity moves it (`scene::volumes_keyed`).
        return Ok(None);
    };
    load(source, plan, density, report)
}

/// The velocity that blurs the volume within the shutter, decoded and recorded in the
/// report; `None` without a shutter (nothing decoded) or without a velocity (a note says
/// the volume renders sharp). A velocity that would carry anything farther than the
/// density's whole box within the shutter is clamped to that speed, with a note.
pub fn load(
    source: &dyn FieldSource,
    plan: &RenderPlan,
    density: &dyn Field,
    report: &mut SceneReport,
) -> Result<Option<SceneMotion>, SceneError> {
    let Some((open, close)) = plan.motion.shutter else {
        return Ok(None);
    };
    let Some(names) = choose(source, &plan.motion.velocity_grid)? else {
        if plan.motion.velocity_grid == GridChoice::Detect {
            report.notes.push(format!(
                "--shutter {open},{close}: no velocity grid found (vel, v, velocity or a vel.x/y/z triplet): the volume renders sharp"
            ));
        }
        return Ok(None);
    };
    let Some(loaded) = source.load_velocity(&names)? else {
        return Ok(None);
    };
    report
        .grid_roles
        .insert("velocity".into(), loaded.name.clone());
    report.grids_decoded.push(loaded.name.clone());
    let decoded: Vec<String> = match &names {
        VelocityNames::Vector(n) => vec![n.clone()],
        VelocityNames::Channels(xyz) => xyz.to_vec(),
    };
    report.grids_not_decoded.retain(|n| !decoded.contains(n));
    report.sanitised_total += loaded.sanitised.nan + loaded.sanitised.inf;
    report
        .sanitised
        .insert(loaded.name.clone(), loaded.sanitised);
    report.grid_memory_bytes += loaded.memory_bytes;
    if let Some(note) = mantaflow_note(report, &names, plan, density) {
        report.notes.push(note);
    }
    let per_frame = plan.motion.velocity_per_frame();
    let mut velocity = loaded.field;
    let frames = open.abs().max(close.abs());
    let (lo, hi) = density.world_bounds();
    let reach = (hi - lo).length();
    let farthest = velocity.max_speed() * (per_frame * frames).abs();
    if reach.is_finite() && reach > 0.0 && farthest > reach {
        let limit = reach / (per_frame * frames).abs();
        velocity = velocity.limited(limit);
        report.notes.push(format!(
            "velocity \"{}\" would move the volume up to {farthest:.3} world units within the shutter, farther than its whole box ({reach:.3}): speeds clamped to {limit:.4} (check --velocity-unit and --velocity-scale)",
            loaded.name
        ));
    }
    Ok(Some(SceneMotion {
        velocity,
        per_frame,
        frames,
        cells: CellCache::default(),
        name: loaded.name,
    }))
}

/// Mantaflow writes its `velocity` in voxels per its own time unit, of which a frame is
/// 0.1 × 25/fps (Blender's step at a Time Scale of 1): murk reads it as units a second,
/// as Cycles does, which blurs 1/(2.5 × voxel) times the fluid's motion. With the
/// default unit and scale, a note gives the scale that moves the volume as the fluid
/// moved (measured on a bake: docs/guide.md, Motion blur).
fn mantaflow_note(
    report: &SceneReport,
    names: &VelocityNames,
    plan: &RenderPlan,
    density: &dyn Field,
) -> Option<String> {
    let blender = report
        .source_tool
        .as_deref()
        .is_some_and(|t| t.starts_with("blender"));
    let mantaflow = matches!(names, VelocityNames::Vector(n) if n == "velocity");
    let defaults = plan.motion.per_second && plan.motion.velocity_scale == 1.0;
    let voxel = density.transform().voxel_size().x;
    (blender && mantaflow && defaults && voxel.is_finite() && voxel > 0.0).then(|| {
        format!(
            "velocity \"velocity\" is Mantaflow's, in voxels per its time unit (0.1 × 25/fps a frame): read as units a second, as Cycles reads it; --velocity-scale {:.4} (2.5 × the voxel size) moves the volume as the fluid moved",
            2.5 * voxel
        )
    })
}
