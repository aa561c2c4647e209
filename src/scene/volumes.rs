//! Several volumes in one scene (a scene file's `[[volume]]` tables): each file is
//! opened and its density decoded once, however often it is placed; the placed copies
//! share it, and the scene's density is their weighted sum ([`FieldSum`]), the medium
//! the plan's (see `plan::volumes`).

use super::SceneError;
use super::plan::{GridChoice, GridRoles, RenderPlan, VolumesPlan};
use super::report::SceneReport;
use super::roles::{SceneFields, load_fields};
use crate::field::Field;
use crate::field::albedo_mix::AlbedoMix;
use crate::field::sum::FieldSum;
use std::path::PathBuf;
use std::sync::Arc;

/// The fields of a scene of several volumes: the summed density, and the albedo tint
/// where the volumes' albedos differ. Other roles (emission, temperature, colour) are
/// not read from the volumes' files; the report says so when one is found.
pub fn load_volumes(
    plan: &RenderPlan,
    volumes: &VolumesPlan,
    report: &mut SceneReport,
) -> Result<SceneFields, SceneError> {
    let mut loaded: Vec<((PathBuf, GridChoice), Arc<dyn Field>)> = Vec::new();
    type Found = (
        Option<(super::conventions::Tool, String)>,
        Option<Result<(super::conventions::UpAxis, String), String>>,
    );
    let mut first: Option<Found> = None;
    let mut members = Vec::with_capacity(volumes.list.len());
    for v in &volumes.list {
        let key = (v.file.clone(), v.density.clone());
        let field = match loaded.iter().find(|(k, _)| *k == key) {
            Some((_, f)) => f.clone(),
            None => {
                let source = super::source::open(&v.file)?;
                let mut one = plan.clone();
                one.input = v.file.clone();
                one.volumes = None;
                one.grids = GridRoles {
                    density: v.density.clone(),
                    emission: GridChoice::Off,
                    temperature: GridChoice::Off,
                    color: GridChoice::Off,
                };
                let fields = load_fields(source.as_ref(), &one, false, report)?;
                let density: Arc<dyn Field> = Arc::from(fields.density);
                if first.is_none() {
                    first = Some((fields.tool, fields.up_from_data));
                }
                loaded.push((key, density.clone()));
                density
            }
        };
        members.push((field, v.placement, v.weight));
    }
    let sum = FieldSum::new(members).map_err(|e| {
        let v = &volumes.list[0];
        SceneError::input(&v.file, format!("[[volume]] \"{}\": {e}", v.name))
    })?;
    report.density_memory_bytes = sum.memory_bytes();
    report.notes.push(format!(
        "{} volumes placed from {} decoded density grid{}",
        volumes.list.len(),
        loaded.len(),
        if loaded.len() == 1 { "" } else { "s" }
    ));
    let color = if volumes.tinted {
        let albedo = volumes.list.iter().map(|v| v.albedo).collect();
        AlbedoMix::new(sum.clone(), albedo)
            .map(|m| Box::new(m) as Box<dyn crate::field::ColorField>)
    } else {
        None
    };
    let (tool, up_from_data) =
        first.ok_or_else(|| SceneError::input(&plan.input, "no [[volume]] to render"))?;
    Ok(SceneFields {
        tool,
        temperature_mapping: None,
        density: Box::new(sum),
        emission: None,
        temperature: None,
        color,
        emission_found: false,
        up_from_data,
    })
}
