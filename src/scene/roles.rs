//! The scene's fields in their roles: which field is density, emission, temperature and
//! colour (named, or detected from the names Houdini, Blender and EmberGen use), decoded
//! only when the render needs them.

use super::SceneError;
use super::conventions::{
    TemperatureMapping, Tool, UpAxis, UpAxisChoice, detect_tool, temperature_mapping, up_from_data,
};
use super::plan::{EmissionPlan, GridChoice, RenderPlan};
use super::report::SceneReport;
use super::report::TemperatureConvention;
use super::source::{FieldKind, FieldSource, Loaded};
use crate::field::color3::ChannelColor;
use crate::field::sum::FieldSum;
use crate::field::{ColorField, Field};
use crate::integrate::blackbody::BlackbodyTable;

type Result<T, E = SceneError> = std::result::Result<T, E>;

/// Half floats round values below this to 0: half the smallest subnormal, 2⁻²⁵.
pub const HALF_ZERO: f64 = 2.980_232_238_769_531_2e-8;

/// The largest value of a scalar field (a majorant over its active bounds; for a voxel
/// grid the largest stored value), 0 for an empty field.
fn field_max(f: &dyn Field) -> f64 {
    let b = f.active_bounds();
    if b.is_empty() {
        return 0.0;
    }
    (f.range_over(&b).max as f64).max(0.0)
}

/// The world length of the field's active bounds' diagonal: no ray crosses more of it.
fn world_diagonal(f: &dyn Field) -> f64 {
    let (lo, hi) = f.world_bounds();
    (hi - lo).length()
}

/// Why a temperature field adds nothing visible (its hottest blackbody emission over
/// the longest chord rounds to 0 in a half float), or `None` when it may.
pub fn temperature_invisible(
    f: &dyn Field,
    m: &TemperatureMapping,
    blackbody_intensity: f64,
    table: &BlackbodyTable,
) -> Option<String> {
    let max = field_max(f);
    // Values are non-negative after loading and the scale is too: the hottest point is
    // the largest value's.
    let k = max * m.scale + m.offset;
    if !(k > 0.0) {
        return Some(format!("it is at most {k:.4} K: nothing glows"));
    }
    let rgb = table.rgb_normalized_clamped(k);
    let peak = rgb.iter().fold(0.0f64, |a, &b| a.max(b));
    let bound = peak * blackbody_intensity * (k / 1000.0).powi(4) * world_diagonal(f);
    (bound < HALF_ZERO).then(|| {
        format!(
            "its hottest point, {k:.4} K, emits at most {bound:.3e} along any ray, below what a half float shows ({HALF_ZERO:.3e})"
        )
    })
}

/// Names grids get from Houdini, Blender and EmberGen, by role, in order of preference.
pub const DENSITY_NAMES: &[&str] = &["density", "density_grid", "smoke", "soot"];
pub const EMISSION_NAMES: &[&str] = &["flame", "flames", "fire", "emission", "fuel"];
pub const TEMPERATURE_NAMES: &[&str] = &["temperature", "heat", "temp"];
pub const COLOR_NAMES: &[&str] = &["Cd", "color", "colour", "albedo"];
/// Colour as three float grids, one a channel (Blender's smoke colour).
pub const COLOR_CHANNEL_NAMES: &[[&str; 3]] = &[
    ["color_r", "color_g", "color_b"],
    ["Cd.r", "Cd.g", "Cd.b"],
    ["Cd.x", "Cd.y", "Cd.z"],
];

/// Where the colour role's values come from.
#[derive(Clone, Debug, PartialEq)]
enum ColorSource {
    /// A vec3 grid.
    Vector(String),
    /// Three float grids, red, green, blue.
    Channels([String; 3]),
}

/// The colour role: a vec3 grid, or three float grids — named as a list
/// (`--color-grid r,g,b`), named by one of them (`--color-grid color_r` finds `_g` and
/// `_b`), or detected from [`COLOR_NAMES`] then [`COLOR_CHANNEL_NAMES`].
fn choose_color(source: &dyn FieldSource, choice: &GridChoice) -> Result<Option<ColorSource>> {
    let scalar = |n: &str| -> Result<String> {
        let g = source.field(n)?;
        if g.kind != FieldKind::Scalar {
            return Err(SceneError::input(
                source.path(),
                format!(
                    "grid \"{}\" ({}) cannot be a colour channel: it must hold float values",
                    g.unique_name, g.type_name
                ),
            ));
        }
        Ok(g.unique_name.clone())
    };
    match choice {
        GridChoice::Named(list) if list.contains(',') => {
            let names: Vec<&str> = list.split(',').map(str::trim).collect();
            let [r, g, b] = names.as_slice() else {
                return Err(SceneError::Flag {
                    flag: "--color-grid",
                    value: list.clone(),
                    problem: "a list names three float grids, red,green,blue".into(),
                });
            };
            Ok(Some(ColorSource::Channels([
                scalar(r)?,
                scalar(g)?,
                scalar(b)?,
            ])))
        }
        GridChoice::Named(n)
            if source.field(n).is_ok_and(|g| g.kind == FieldKind::Scalar)
                && (n.ends_with("_r") || n.ends_with(".r")) =>
        {
            let stem = &n[..n.len() - 1];
            Ok(Some(ColorSource::Channels([
                scalar(n)?,
                scalar(&format!("{stem}g"))?,
                scalar(&format!("{stem}b"))?,
            ])))
        }
        GridChoice::Detect => {
            if let Some(v) = choose(source, choice, COLOR_NAMES, "color", FieldKind::Vector)? {
                return Ok(Some(ColorSource::Vector(v)));
            }
            let found = |n: &str| {
                source
                    .fields()
                    .iter()
                    .find(|g| g.name == n && g.kind == FieldKind::Scalar)
                    .map(|g| g.unique_name.clone())
            };
            Ok(COLOR_CHANNEL_NAMES.iter().find_map(|[r, g, b]| {
                Some(ColorSource::Channels([found(r)?, found(g)?, found(b)?]))
            }))
        }
        _ => Ok(
            choose(source, choice, COLOR_NAMES, "color", FieldKind::Vector)?
                .map(ColorSource::Vector),
        ),
    }
}

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
                return Err(SceneError::input(
                    source.path(),
                    format!(
                        "grid \"{}\" ({}) cannot be the {role} grid: it must hold {want} values",
                        g.unique_name, g.type_name
                    ),
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

/// Why no density was found: a grid of a density's name that holds other values (a
/// vec3 `density`) is named as the reason, else the file's fields are listed.
fn no_density(source: &dyn FieldSource, input: &std::path::Path) -> SceneError {
    let named = DENSITY_NAMES.iter().find_map(|n| {
        source
            .fields()
            .iter()
            .find(|g| g.name.eq_ignore_ascii_case(n))
    });
    let scalars: Vec<&str> = source
        .fields()
        .iter()
        .filter(|g| g.kind == FieldKind::Scalar)
        .map(|g| g.unique_name.as_str())
        .collect();
    let instead = if scalars.is_empty() {
        "the file has no float grid; write the density as one (e.g. its magnitude)".to_string()
    } else {
        format!(
            "name a float grid with --density-grid (the file's: {})",
            scalars.join(", ")
        )
    };
    match named {
        Some(g) => SceneError::input(
            input,
            format!(
                "grid \"{}\" holds {} values ({}), but a density must be a float grid; {instead}",
                g.unique_name,
                match g.kind {
                    FieldKind::Vector => "vec3",
                    _ => "non-float",
                },
                g.type_name
            ),
        ),
        None => SceneError::input(
            input,
            format!(
                "no density grid found (the file has: {}); name one with --density-grid",
                source.field_list()
            ),
        ),
    }
}

/// The world box of the non-zero cells of the density `plan` would render (decoded
/// alone), `None` when it has none or cannot be read (the render says why).
pub fn density_box_of(plan: &RenderPlan) -> Option<(glam::DVec3, glam::DVec3)> {
    let source = super::source::open(&plan.input).ok()?;
    let name = choose(
        source.as_ref(),
        &plan.grids.density,
        DENSITY_NAMES,
        "density",
        FieldKind::Scalar,
    )
    .ok()??;
    let density = source.load_scalar(&name).ok()?.field;
    super::density_box(density.as_ref())
}

/// The decoded fields of a render.
pub struct SceneFields {
    /// The tool the file is taken to come from, and how that was told.
    pub tool: Option<(Tool, String)>,
    /// Kelvin = temperature × scale + offset, as assumed (explicit flags, or the
    /// convention detected); `None` without a temperature field.
    pub temperature_mapping: Option<TemperatureMapping>,
    pub density: Box<dyn Field>,
    pub emission: Option<Box<dyn Field>>,
    pub temperature: Option<Box<dyn Field>>,
    pub color: Option<Box<dyn ColorField>>,
    /// An emission or temperature field exists, whether or not it is used.
    pub emission_found: bool,
    /// With no tool recognised and `--up-axis auto`: what the data says of the up axis.
    pub up_from_data: Option<Result<(UpAxis, String), String>>,
    /// Several volumes: each glowing one's placed fields and settings (`emission` and
    /// `temperature` above are then `None`); empty for one input.
    pub emitters: Vec<Emitter>,
    /// Several volumes: the summed density's members and their names, for the
    /// per-volume alpha layers; `None` for one input or one volume.
    pub parts: Option<VolumeParts>,
    /// Several volumes whose keyed placements move within the shutter.
    pub keyed: Option<Box<super::volumes_keyed::KeyedVolumes>>,
}

/// One glowing volume of several: its emission and temperature fields as placed, and
/// its emission settings with the Kelvin mapping resolved.
pub struct Emitter {
    pub emission: Option<Box<dyn Field>>,
    pub temperature: Option<Box<dyn Field>>,
    pub plan: EmissionPlan,
}

/// The volumes of a scene of several: the summed density (member `i` is volume `i`)
/// and each volume's name.
pub struct VolumeParts {
    pub sum: FieldSum,
    pub names: Vec<String>,
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
    .ok_or_else(|| no_density(source, &plan.input))?;
    let d = source.field(&density_name)?;
    if d.class == "level set" {
        // A level set holds a surface's signed distance, negative inside: read as
        // density it is a rounded box of sanitised values, not the shape.
        return Err(SceneError::input(
            &plan.input,
            format!(
                "grid \"{}\" is a level set (a surface's signed distance), not a fog volume; convert it first, e.g. vdb_tool -read {} -ls2fog name=density -write fog.vdb",
                d.unique_name,
                plan.input.display()
            ),
        ));
    }
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
    let color_name = choose_color(source, &plan.grids.color)?;
    let emission_found = emission_name.is_some() || temperature_name.is_some();
    let emission_wanted = emission_name.is_some()
        && plan.emission.intensity > 0.0
        && plan.emission.color.max_element() > 0.0;
    let temperature_wanted = temperature_name.is_some() && plan.emission.blackbody_intensity > 0.0;
    let flame_grid = emission_name.clone();
    let emission_name = emission_name.filter(|_| emission_wanted);
    let temperature_name = temperature_name.filter(|_| temperature_wanted);

    let tool = detect_tool(&source.metadata(), source.fields());
    report.source_tool = tool
        .as_ref()
        .map(|(t, how)| format!("{} ({how})", t.name()));

    let density = record(report, "density", source.load_scalar(&density_name)?);
    // A grid in a role that adds nothing is decoded (that is how it is known) and then
    // dropped: not traversed, not sampled.
    let mut emission = match &emission_name {
        Some(n) => Some(record(report, "emission", source.load_scalar(n)?)),
        None => None,
    };
    if let (Some(n), Some(f)) = (&emission_name, &emission)
        && field_max(f.as_ref()) <= 0.0
    {
        report
            .skipped_grids
            .insert(n.clone(), "emission: zero everywhere".into());
        emission = None;
    }
    let mut temperature = match &temperature_name {
        Some(n) => Some(record(report, "temperature", source.load_scalar(n)?)),
        None => None,
    };
    let up_from_data = (tool.is_none() && plan.production.up_axis == UpAxisChoice::Auto)
        .then(|| up_from_data(density.as_ref(), temperature.as_deref()));
    let fire = fire_of(
        plan,
        &tool,
        flame_grid.as_deref(),
        emission_name.is_some(),
        emission.is_some(),
    );
    let mut mapping = None;
    if let (Some(n), Some(f)) = (&temperature_name, &temperature) {
        let max = field_max(f.as_ref());
        let m = if plan.production.temperature_explicit {
            TemperatureMapping {
                scale: plan.emission.temperature_scale,
                offset: plan.emission.temperature_offset,
                convention: "explicit".into(),
                reason: "--temperature-scale/--temperature-offset given".into(),
            }
        } else {
            temperature_mapping(tool.clone(), max)
        };
        report.temperature_convention = Some(TemperatureConvention {
            convention: m.convention.clone(),
            scale: m.scale,
            offset: m.offset,
            reason: m.reason.clone(),
            max_value: max,
            max_kelvin: max * m.scale + m.offset,
            emission: match &fire {
                Ok(why) => format!("on: {why}"),
                Err(why) => format!("off: {why}"),
            },
        });
        let table = BlackbodyTable::new(200.0, 40000.0, 2048);
        if let Err(why) = &fire {
            report.notes.push(format!(
                "temperature grid \"{n}\" does not glow: {why}; name it (--temperature-grid {n}) to make it glow"
            ));
            report
                .skipped_grids
                .insert(n.clone(), format!("temperature: {why}"));
            temperature = None;
        } else if let Some(why) =
            temperature_invisible(f.as_ref(), &m, plan.emission.blackbody_intensity, &table)
        {
            report.notes.push(format!(
                "temperature grid \"{n}\" emits nothing visible: {why} (Kelvin = value × {} + {}; set --temperature-scale/--temperature-offset if that is wrong)",
                m.scale, m.offset
            ));
            report
                .skipped_grids
                .insert(n.clone(), format!("temperature: {why}"));
            temperature = None;
        }
        mapping = Some(m);
    }
    // The colour field only tints scattering: not decoded when nothing scatters.
    let color = match color_name.filter(|_| scatters) {
        Some(ColorSource::Vector(n)) => Some(record(report, "color", source.load_color(&n)?)),
        Some(ColorSource::Channels([r, g, b])) => {
            let r = record(report, "color_r", source.load_scalar(&r)?);
            let g = record(report, "color_g", source.load_scalar(&g)?);
            let b = record(report, "color_b", source.load_scalar(&b)?);
            let all_zero = [&r, &g, &b].iter().all(|f| field_max(f.as_ref()) <= 0.0);
            if all_zero {
                // Blender writes color_r/g/b with no active voxel for plain smoke:
                // multiplying by them would make the smoke black.
                let names = report.grids_decoded[report.grids_decoded.len() - 3..].join(", ");
                report.notes.push(format!(
                    "colour grids {names} are empty or zero everywhere: left out, so the smoke is not blackened (it scatters as --sigma-s says)"
                ));
                for role in ["color_r", "color_g", "color_b"] {
                    if let Some(n) = report.grid_roles.remove(role) {
                        report
                            .skipped_grids
                            .insert(n, "colour: empty or zero everywhere".into());
                    }
                }
                None
            } else {
                Some(Box::new(ChannelColor::new(r, g, b)) as Box<dyn ColorField>)
            }
        }
        None => None,
    };
    report.grids_not_decoded = source
        .fields()
        .iter()
        .map(|g| g.unique_name.clone())
        .filter(|n| !report.grids_decoded.contains(n))
        .collect();
    Ok(SceneFields {
        tool,
        temperature_mapping: mapping,
        density,
        emission,
        temperature,
        color,
        emission_found,
        up_from_data,
        emitters: Vec::new(),
        parts: None,
        keyed: None,
    })
}

/// Whether a temperature grid glows by default, and why: where the cache has fire. A
/// cache whose flame grid is empty or zero everywhere, or a Blender cache with none, is
/// smoke: Cycles' Principled Volume shows no blackbody unless asked, and a smoke
/// source's temperature (1 to 2 in Blender's units, 1000 to 2000 K) would glow pink.
/// Asked for — the grid named, or its Kelvin mapping given — it glows.
fn fire_of(
    plan: &RenderPlan,
    tool: &Option<(Tool, String)>,
    flame_grid: Option<&str>,
    flame_loaded: bool,
    flame_kept: bool,
) -> Result<String, String> {
    if plan.production.temperature_explicit {
        return Ok("--temperature-scale/--temperature-offset given".into());
    }
    if let GridChoice::Named(n) = &plan.grids.temperature {
        return Ok(format!("--temperature-grid {n} given"));
    }
    match flame_grid {
        Some(f) if flame_kept => Ok(format!("the cache has fire (grid \"{f}\")")),
        Some(f) if flame_loaded => Err(format!(
            "the cache has no fire (grid \"{f}\" is empty or zero everywhere): smoke only"
        )),
        // The flame grid not read (its emission turned off): as the cache says nothing.
        Some(f) => Ok(format!(
            "grid \"{f}\" not read; the temperature taken as fire"
        )),
        None if matches!(tool, Some((Tool::Blender, _))) => {
            Err("a Blender cache with no flame grid is smoke only".into())
        }
        None => Ok("no flame grid: the temperature is the fire".into()),
    }
}
