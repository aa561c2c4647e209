//! The scene's fields in their roles: which field is density, emission, temperature and
//! colour (named, or detected from the names Houdini, Blender and EmberGen use), decoded
//! only when the render needs them.

use super::plan::{GridChoice, RenderPlan};
use super::report::SceneReport;
use super::source::{FieldKind, FieldSource, Loaded};
use crate::field::{ColorField, Field};
use anyhow::{Result, anyhow};

/// Names grids get from Houdini, Blender and EmberGen, by role, in order of preference.
pub const DENSITY_NAMES: &[&str] = &["density", "density_grid", "smoke", "soot"];
pub const EMISSION_NAMES: &[&str] = &["flame", "flames", "fire", "emission", "fuel"];
pub const TEMPERATURE_NAMES: &[&str] = &["temperature", "heat", "temp"];
pub const COLOR_NAMES: &[&str] = &["Cd", "color", "colour"];

/// Picks the field for a role: the one named, else the first usual name that exists.
fn choose(
    source: &dyn FieldSource,
    choice: &GridChoice,
    usual: &[&str],
    role: &str,
    kind: FieldKind,
) -> Result<Option<String>> {
    match choice {
        GridChoice::Off => Ok(None),
        GridChoice::Named(n) => {
            let g = source.field(n)?;
            if g.kind != kind {
                let want = if kind == FieldKind::Vector {
                    "vec3"
                } else {
                    "float"
                };
                return Err(anyhow!(
                    "{}: grid \"{}\" ({}) cannot be the {role} grid: it must hold {want} values",
                    source.path().display(),
                    g.unique_name,
                    g.type_name
                ));
            }
            Ok(Some(g.unique_name.clone()))
        }
        GridChoice::Detect => Ok(usual
            .iter()
            .find_map(|n| {
                source
                    .fields()
                    .iter()
                    .find(|g| g.name.eq_ignore_ascii_case(n) && g.kind == kind)
            })
            .map(|g| g.unique_name.clone())),
    }
}

/// The decoded fields of a render.
pub struct SceneFields {
    pub density: Box<dyn Field>,
    pub emission: Option<Box<dyn Field>>,
    pub temperature: Option<Box<dyn Field>>,
    pub color: Option<Box<dyn ColorField>>,
    /// An emission or temperature field exists, whether or not it is used.
    pub emission_found: bool,
}

/// Notes a decoded field in the report under its role, and hands the field on.
fn record<T>(report: &mut SceneReport, role: &str, l: Loaded<T>) -> T {
    report.grid_roles.insert(role.into(), l.name.clone());
    report.grids_decoded.push(l.name.clone());
    report.sanitised_total += l.sanitised.nan + l.sanitised.inf + l.sanitised.negative;
    report.sanitised.insert(l.name, l.sanitised);
    report.grid_memory_bytes += l.memory_bytes;
    l.field
}

/// Picks the fields for every role and decodes those the render needs (`scatters`: the
/// colour field is needed only then), recording roles, decoded and skipped fields and
/// sanitised voxels in `report`.
pub fn load_fields(
    source: &dyn FieldSource,
    plan: &RenderPlan,
    scatters: bool,
    report: &mut SceneReport,
) -> Result<SceneFields> {
    let density_name = choose(
        source,
        &plan.grids.density,
        DENSITY_NAMES,
        "density",
        FieldKind::Scalar,
    )?
    .ok_or_else(|| {
        anyhow!(
            "{}: no density grid found (the file has: {}); name one with --density-grid",
            plan.input.display(),
            source.field_list()
        )
    })?;
    let emission_name = choose(
        source,
        &plan.grids.emission,
        EMISSION_NAMES,
        "emission",
        FieldKind::Scalar,
    )?;
    let temperature_name = choose(
        source,
        &plan.grids.temperature,
        TEMPERATURE_NAMES,
        "temperature",
        FieldKind::Scalar,
    )?;
    let color_name = choose(
        source,
        &plan.grids.color,
        COLOR_NAMES,
        "color",
        FieldKind::Vector,
    )?;
    let emission_found = emission_name.is_some() || temperature_name.is_some();
    let emission_wanted = emission_name.is_some()
        && plan.emission.intensity > 0.0
        && plan.emission.color.max_element() > 0.0;
    let temperature_wanted = temperature_name.is_some() && plan.emission.blackbody_intensity > 0.0;
    let emission_name = emission_name.filter(|_| emission_wanted);
    let temperature_name = temperature_name.filter(|_| temperature_wanted);

    let density = record(report, "density", source.load_scalar(&density_name)?);
    let emission = match &emission_name {
        Some(n) => Some(record(report, "emission", source.load_scalar(n)?)),
        None => None,
    };
    let temperature = match &temperature_name {
        Some(n) => Some(record(report, "temperature", source.load_scalar(n)?)),
        None => None,
    };
    // The colour field only tints scattering: not decoded when nothing scatters.
    let color = match color_name.filter(|_| scatters) {
        Some(n) => Some(record(report, "color", source.load_color(&n)?)),
        None => None,
    };
    report.grids_not_decoded = source
        .fields()
        .iter()
        .map(|g| g.unique_name.clone())
        .filter(|n| !report.grids_decoded.contains(n))
        .collect();
    Ok(SceneFields {
        density,
        emission,
        temperature,
        color,
        emission_found,
    })
}
