//! Several volumes in one scene (a scene file's `[[volume]]` tables): each file is
//! opened and its grids decoded once, however often it is placed with the same grids and
//! emission; the placed copies share them. The scene's density is their weighted sum
//! ([`FieldSum`]) in the plan's medium (see `plan::volumes`), their scattering tinted per
//! point by their albedos and colour grids ([`AlbedoMix`]), and each glowing volume an
//! [`Emitter`] whose emission adds to the others'.

use super::SceneError;
use super::conventions::{TemperatureMapping, Tool, UpAxis};
use super::plan::{GridChoice, GridRoles, RenderPlan, VolumePlan, VolumesPlan};
use super::report::SceneReport;
use super::roles::{Emitter, SceneFields, VolumeParts, load_fields};
use super::volumes_keyed::{KeyedEmitter, KeyedMember, KeyedVolumes, tint};
use crate::field::advect::VelocityField;
use crate::field::advect_shared::SharedFlow;
use crate::field::albedo_mix::PlacedColor;
use crate::field::padded_cells::CellCache;
use crate::field::sum::FieldSum;
use crate::field::{ColorField, Field};
use glam::DMat4;
use std::path::PathBuf;
use std::sync::Arc;

/// What one file gives in its roles, decoded once.
struct Decoded {
    density: Arc<dyn Field>,
    emission: Option<Arc<dyn Field>>,
    temperature: Option<Arc<dyn Field>>,
    color: Option<Arc<dyn ColorField>>,
    mapping: Option<TemperatureMapping>,
    /// With a shutter: the file's velocity, and how many of its time units a frame is.
    flow: Option<(SharedFlow, f64)>,
}

/// What decides what a file gives: the file, its grids and how it glows.
fn key_of(v: &VolumePlan, scatters: bool) -> (PathBuf, GridRoles, String) {
    let mut grids = v.grids.clone();
    if !scatters {
        // The colour grid is read only when something scatters.
        grids.color = GridChoice::Off;
    }
    let glow = format!("{:?} {}", v.emission, v.temperature_explicit);
    (v.file.clone(), grids, glow)
}

/// A field placed in the world as a sum of one member of weight 1 in the local index
/// space `frame` (the summed density's, so that the march finds it on the density's
/// lattice and takes its exact integrals).
fn placed(
    field: &Option<Arc<dyn Field>>,
    placement: DMat4,
    frame: crate::field::IndexToWorld,
) -> Result<Option<Box<dyn Field>>, String> {
    field
        .as_ref()
        .map(|f| {
            FieldSum::in_frame(vec![(f.clone(), placement, 1.0)], frame)
                .map(|f| Box::new(f) as Box<dyn Field>)
                .map_err(|e| e.to_string())
        })
        .transpose()
}

/// The velocity of a volume's file (`None` without a shutter or a velocity grid; the
/// scene's note says what moves).
fn velocity_of(
    source: &dyn super::source::FieldSource,
    plan: &RenderPlan,
    density: &dyn Field,
    report: &mut SceneReport,
) -> Result<Option<(SharedFlow, f64)>, SceneError> {
    let notes = report.notes.len();
    let Some(m) = super::velocity::load(source, plan, density, report)? else {
        report.notes.truncate(notes);
        return Ok(None);
    };
    let reach = m.velocity.max_speed() * (m.per_frame * m.frames).abs();
    let flow = SharedFlow {
        velocity: Arc::new(m.velocity),
        reach,
        cells: Arc::new(CellCache::default()),
    };
    Ok(Some((flow, m.per_frame)))
}

/// An error about a volume's file, saying which volume (a grid asked for that it lacks,
/// say): `FILE: [[volume]] "NAME": problem`.
fn in_volume(e: SceneError, v: &VolumePlan) -> SceneError {
    let text = e.to_string();
    match text.strip_prefix(&format!("{}: ", v.file.display())) {
        Some(problem) => {
            SceneError::input(&v.file, format!("[[volume]] \"{}\": {problem}", v.name))
        }
        None => e,
    }
}

/// A glowing volume's fields and settings, before the summed density is made.
struct Glowing<'a> {
    volume: &'a VolumePlan,
    emission: Option<Arc<dyn Field>>,
    temperature: Option<Arc<dyn Field>>,
    plan: super::plan::EmissionPlan,
}

/// The fields of a scene of several volumes: the summed density, the scattering tint
/// where the volumes' albedos differ or they have colour grids (read only when
/// `scatters`), and each glowing volume's emission.
pub fn load_volumes(
    plan: &RenderPlan,
    volumes: &VolumesPlan,
    scatters: bool,
    report: &mut SceneReport,
) -> Result<SceneFields, SceneError> {
    let mut loaded: Vec<((PathBuf, GridRoles, String), Decoded)> = Vec::new();
    type Found = (
        Option<(Tool, String)>,
        Option<Result<(UpAxis, String), String>>,
    );
    let mut first: Option<Found> = None;
    let mut emission_found = false;
    let mut members = Vec::with_capacity(volumes.list.len());
    let mut colors: Vec<Option<Arc<dyn ColorField>>> = Vec::with_capacity(volumes.list.len());
    let mut glowing = Vec::new();
    // Which decoded file each volume is, and each glowing one's fields unplaced.
    let mut chosen = Vec::with_capacity(volumes.list.len());
    let mut keyed_emitters = Vec::new();
    for v in &volumes.list {
        let at = |e: String| SceneError::input(&v.file, format!("[[volume]] \"{}\": {e}", v.name));
        let key = key_of(v, scatters);
        let i = match loaded.iter().position(|(k, _)| *k == key) {
            Some(i) => i,
            None => {
                let source = super::source::open(&v.file)?;
                let mut one = plan.clone();
                one.input = v.file.clone();
                one.volumes = None;
                one.grids = key.1.clone();
                one.emission = v.emission;
                one.production.temperature_explicit = v.temperature_explicit;
                let fields = load_fields(source.as_ref(), &one, scatters, report)
                    .map_err(|e| in_volume(e, v))?;
                let flow = velocity_of(source.as_ref(), &one, fields.density.as_ref(), report)
                    .map_err(|e| in_volume(e, v))?;
                emission_found |= fields.emission_found;
                if first.is_none() {
                    first = Some((fields.tool, fields.up_from_data));
                }
                loaded.push((
                    key,
                    Decoded {
                        density: Arc::from(fields.density),
                        emission: fields.emission.map(Arc::from),
                        temperature: fields.temperature.map(Arc::from),
                        color: fields.color.map(Arc::from),
                        mapping: fields.temperature_mapping,
                        flow,
                    },
                ));
                loaded.len() - 1
            }
        };
        chosen.push(i);
        let d = &loaded[i].1;
        members.push((d.density.clone(), v.placement, v.weight));
        colors.push(match &d.color {
            Some(c) => Some(Arc::new(
                PlacedColor::new(c.clone(), v.placement)
                    .ok_or_else(|| at("the placement is singular or not finite".into()))?,
            ) as Arc<dyn ColorField>),
            None => None,
        });
        if d.emission.is_some() || d.temperature.is_some() {
            let mut plan = v.emission;
            if let Some(m) = &d.mapping {
                plan.temperature_scale = m.scale;
                plan.temperature_offset = m.offset;
            }
            keyed_emitters.push(KeyedEmitter {
                member: chosen.len() - 1,
                emission: d.emission.clone(),
                temperature: d.temperature.clone(),
            });
            glowing.push(Glowing {
                volume: v,
                emission: d.emission.clone(),
                temperature: d.temperature.clone(),
                plan,
            });
        }
    }
    let sum = FieldSum::new(members).map_err(|e| {
        let v = &volumes.list[0];
        SceneError::input(&v.file, format!("[[volume]] \"{}\": {e}", v.name))
    })?;
    let frame = *sum.transform();
    let mut emitters = Vec::with_capacity(glowing.len());
    for g in glowing {
        let v = g.volume;
        let at = |e: String| SceneError::input(&v.file, format!("[[volume]] \"{}\": {e}", v.name));
        emitters.push(Emitter {
            emission: placed(&g.emission, v.placement, frame).map_err(at)?,
            temperature: placed(&g.temperature, v.placement, frame).map_err(at)?,
            plan: g.plan,
        });
    }
    report.density_memory_bytes = sum.memory_bytes();
    report.notes.push(format!(
        "{} volumes placed from {} decoded density grid{}",
        volumes.list.len(),
        loaded.len(),
        if loaded.len() == 1 { "" } else { "s" }
    ));
    let keyed = match plan.motion.shutter {
        Some(shutter) => {
            let members = volumes
                .list
                .iter()
                .zip(&chosen)
                .map(|(v, &i)| {
                    let d = &loaded[i].1;
                    KeyedMember {
                        density: d.density.clone(),
                        weight: v.weight,
                        placement: v.placement,
                        keys: v.keys.clone(),
                        color: d.color.clone(),
                        albedo: v.albedo,
                        flow: d.flow.clone(),
                    }
                })
                .collect();
            KeyedVolumes::new(volumes, shutter, members, keyed_emitters, frame).map(Box::new)
        }
        _ => None,
    };
    if let Some((open, close)) = plan.motion.shutter {
        report.notes.push(match &keyed {
            Some(_) => format!("--shutter {open},{close}: the volumes that move while it is open (by their keys or velocity grids) blur; the shadow maps are those of the frame"),
            None => format!("--shutter {open},{close}: no volume moves while it is open (no velocity grid, no keys that move then): they render sharp"),
        });
    }
    let albedo = volumes.list.iter().map(|v| v.albedo).collect();
    let color = tint(&sum, volumes.tinted, albedo, colors);
    let (tool, up_from_data) =
        first.ok_or_else(|| SceneError::input(&plan.input, "no [[volume]] to render"))?;
    let parts = (volumes.list.len() > 1).then(|| VolumeParts {
        sum: sum.clone(),
        names: volumes.list.iter().map(|v| v.name.clone()).collect(),
    });
    Ok(SceneFields {
        tool,
        temperature_mapping: None,
        density: Box::new(sum),
        emission: None,
        temperature: None,
        color,
        emission_found,
        up_from_data,
        emitters,
        parts,
        keyed,
    })
}
