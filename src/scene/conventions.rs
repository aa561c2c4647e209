//! The conventions of the tools production caches come from — Blender (Mantaflow),
//! Houdini (pyro) and EmberGen — told apart from a file's metadata and grid names, and
//! what murk assumes for each: temperature units and the up axis.
//!
//! Temperature. Blender and Houdini store temperature normalised, not in Kelvin; each
//! tool's own default fire shader maps it to Kelvin, and murk maps it the same way:
//! - **Blender**: Cycles' Principled Volume multiplies the temperature attribute by its
//!   *Temperature* socket, 1000 K by default (Blender manual, "Principled Volume":
//!   "Temperature: temperature in kelvin for blackbody emission"; Cycles
//!   `svm_node_principled_volume`: `T = temperature × max(attribute, 0)`), so Kelvin =
//!   value × 1000.
//! - **Houdini**: the Pyro Blackbody VOP behind the Pyro Shader reads the field as a
//!   scale between *Temperature at 0 (K)* (0) and *Temperature at 1 (K)* (5000 by
//!   default; SideFX, "Pyro Blackbody VOP node"), so Kelvin = value × 5000.
//! - **EmberGen**, and any file whose temperature already reads as Kelvin (a maximum
//!   above [`KELVIN_FLOOR`]): Kelvin = value.
//!
//! Up axis. Blender is Z-up; Houdini and EmberGen are Y-up, as is murk's default.

use super::source::{FieldKind, SourceField};
use crate::field::Field;
use glam::DVec3;

/// The tool a cache comes from, as far as murk can tell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tool {
    Blender,
    Houdini,
    EmberGen,
}

impl Tool {
    pub fn name(self) -> &'static str {
        match self {
            Tool::Blender => "blender",
            Tool::Houdini => "houdini",
            Tool::EmberGen => "embergen",
        }
    }
}

/// A temperature maximum above this (in file units) is taken to be Kelvin already:
/// no normalised convention reaches it (Houdini's pyro stays near 2, Blender's at 1),
/// and nothing visible glows below it in Kelvin.
pub const KELVIN_FLOOR: f64 = 100.0;

/// Kelvin per unit of normalised temperature: Cycles' Principled Volume default.
pub const BLENDER_KELVIN_PER_UNIT: f64 = 1000.0;
/// Kelvin per unit of normalised temperature: Houdini's Pyro Blackbody default.
pub const HOUDINI_KELVIN_PER_UNIT: f64 = 5000.0;

/// The tool a file comes from: from the file's `creator` metadata first, then from the
/// grids only one tool writes: Blender's `color_r/g/b`, Mantaflow's `shadow` grid and
/// staggered `velocity` (a MAC grid, which Mantaflow alone writes as `staggered`),
/// Houdini's `Cd`/`vel`, EmberGen's `flames`. `None` when nothing tells. The second value
/// says how it was told (for the stats).
pub fn detect_tool(metadata: &[(String, String)], grids: &[SourceField]) -> Option<(Tool, String)> {
    for (k, v) in metadata {
        if !k.eq_ignore_ascii_case("creator") {
            continue;
        }
        let l = v.to_ascii_lowercase();
        let tool = if l.contains("blender") || l.contains("mantaflow") {
            Tool::Blender
        } else if l.contains("houdini") {
            Tool::Houdini
        } else if l.contains("embergen") || l.contains("jangafx") {
            Tool::EmberGen
        } else {
            continue;
        };
        return Some((tool, format!("file metadata creator = \"{v}\"")));
    }
    let has = |n: &str| grids.iter().any(|g| g.name == n);
    if has("color_r") && has("color_g") && has("color_b") {
        return Some((Tool::Blender, "Blender's grid set (color_r/g/b)".into()));
    }
    let staggered = grids
        .iter()
        .any(|g| g.name == "velocity" && g.kind == FieldKind::Vector && g.class == "staggered");
    if staggered || (has("shadow") && has("density")) {
        let what = if staggered {
            "staggered velocity"
        } else {
            "shadow grid"
        };
        return Some((Tool::Blender, format!("Mantaflow's grid set ({what})")));
    }
    if has("flame") && (has("heat") || has("fuel") || has("react")) && !has("Cd") {
        return Some((
            Tool::Blender,
            "Blender's grid set (flame with heat/fuel/react)".into(),
        ));
    }
    if has("Cd") || has("vel") || has("burn") {
        return Some((
            Tool::Houdini,
            "Houdini's grid names (Cd, vel or burn)".into(),
        ));
    }
    if has("flames") {
        return Some((Tool::EmberGen, "EmberGen's grid names (flames)".into()));
    }
    None
}

/// How a temperature grid's values become Kelvin, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct TemperatureMapping {
    pub scale: f64,
    pub offset: f64,
    /// `kelvin`, `blender-normalised`, `houdini-normalised`, `explicit` …
    pub convention: String,
    pub reason: String,
}

/// The mapping for a temperature grid whose largest value is `max` (file units), from a
/// file made by `tool`.
pub fn temperature_mapping(tool: Option<(Tool, String)>, max: f64) -> TemperatureMapping {
    if max > KELVIN_FLOOR {
        return TemperatureMapping {
            scale: 1.0,
            offset: 0.0,
            convention: "kelvin".into(),
            reason: format!("the grid's maximum {max:.4} is above {KELVIN_FLOOR}: already Kelvin"),
        };
    }
    let (per_unit, convention, why) = match &tool {
        Some((Tool::Houdini, how)) => (
            HOUDINI_KELVIN_PER_UNIT,
            "houdini-normalised",
            format!("Houdini ({how}); its Pyro Blackbody maps 1 to 5000 K"),
        ),
        Some((Tool::Blender, how)) => (
            BLENDER_KELVIN_PER_UNIT,
            "blender-normalised",
            format!("Blender ({how}); Cycles' Principled Volume maps 1 to 1000 K"),
        ),
        Some((Tool::EmberGen, how)) => (
            BLENDER_KELVIN_PER_UNIT,
            "normalised",
            format!("EmberGen ({how}) with values up to {max:.4}, not Kelvin: 1 taken as 1000 K"),
        ),
        None => (
            BLENDER_KELVIN_PER_UNIT,
            "normalised",
            format!(
                "no tool recognised; values up to {max:.4} are not Kelvin: 1 taken as 1000 K (Blender's mapping)"
            ),
        ),
    };
    TemperatureMapping {
        scale: per_unit,
        offset: 0.0,
        convention: convention.into(),
        reason: why,
    }
}

/// The world's up axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum UpAxis {
    #[default]
    Y,
    Z,
}

impl UpAxis {
    pub fn vector(self) -> DVec3 {
        match self {
            UpAxis::Y => DVec3::Y,
            UpAxis::Z => DVec3::Z,
        }
    }

    /// A direction given in murk's Y-up frame (x right, y up, z toward the default
    /// camera) in this world: for Z-up, y → z and z → −y (x right, z up, the default
    /// camera on −y looking along +y, as Blender's front view).
    pub fn from_y_up(self, v: DVec3) -> DVec3 {
        match self {
            UpAxis::Y => v,
            UpAxis::Z => DVec3::new(v.x, -v.z, v.y),
        }
    }

    /// The inverse of [`UpAxis::from_y_up`].
    pub fn to_y_up(self, v: DVec3) -> DVec3 {
        match self {
            UpAxis::Y => v,
            UpAxis::Z => DVec3::new(v.x, v.z, -v.y),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            UpAxis::Y => "y",
            UpAxis::Z => "z",
        }
    }
}

/// `--up-axis` as given.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum UpAxisChoice {
    #[default]
    Auto,
    Fixed(UpAxis),
}

/// What a cache's own data says of its up axis when no tool tells it: hot gas rises, so
/// the density's centre lies above the temperature's (a plume's smoke over its source).
/// The up axis is y or z, whichever that offset points along, when it points up, is at
/// least 5 % of the extent and twice the offset along the other; else why not.
pub fn up_from_data(
    density: &dyn Field,
    temperature: Option<&dyn Field>,
) -> Result<(UpAxis, String), String> {
    let Some(temperature) = temperature else {
        return Err("no temperature grid tells which way is up".into());
    };
    let (lo, hi) = density.world_bounds();
    let extent = hi - lo;
    if !(extent.min_element() > 0.0) || !extent.is_finite() {
        return Err("the density has no extent to tell it from".into());
    }
    // A lattice of cell centres over the density's bounds, up to 32 a side.
    const N: usize = 32;
    let (mut wd, mut wt) = (0.0f64, 0.0f64);
    let (mut md, mut mt) = (DVec3::ZERO, DVec3::ZERO);
    for i in 0..N * N * N {
        let c = DVec3::new((i % N) as f64, ((i / N) % N) as f64, (i / (N * N)) as f64);
        let p = lo + extent * (c + 0.5) / N as f64;
        let d = (density.value_at_world(p) as f64).max(0.0);
        let t = (temperature.value_at_world(p) as f64).max(0.0);
        if d.is_finite() && t.is_finite() {
            (wd, wt) = (wd + d, wt + t);
            (md, mt) = (md + p * d, mt + p * t);
        }
    }
    if !(wd > 0.0 && wt > 0.0) {
        return Err("the temperature is zero wherever the density is not".into());
    }
    let offset = (md / wd - mt / wt) / extent;
    let (y, z) = (offset.y, offset.z);
    let (axis, along, across) = if y.abs() >= z.abs() {
        (UpAxis::Y, y, z)
    } else {
        (UpAxis::Z, z, y)
    };
    if along > 0.05 && along > 2.0 * across.abs() {
        Ok((
            axis,
            format!(
                "the smoke lies above the heat along +{} ({:.0} % of the extent)",
                axis.name(),
                along * 100.0
            ),
        ))
    } else {
        Err(format!(
            "the smoke's centre is not clearly above the heat's along y or z (offsets {:.0} % and {:.0} % of the extent)",
            y * 100.0,
            z * 100.0
        ))
    }
}

/// The up axis for a file from `tool` under `choice`, and why (for the stats). With no
/// tool recognised, what the data says ([`up_from_data`]), y when it says nothing.
pub fn resolve_up_axis(
    choice: UpAxisChoice,
    tool: &Option<(Tool, String)>,
    data: Option<&Result<(UpAxis, String), String>>,
) -> (UpAxis, String) {
    match (choice, tool) {
        (UpAxisChoice::Fixed(a), _) => (a, format!("{} (--up-axis)", a.name())),
        (UpAxisChoice::Auto, Some((Tool::Blender, how))) => {
            (UpAxis::Z, format!("z (auto: Blender is Z-up; {how})"))
        }
        (UpAxisChoice::Auto, Some((t, how))) => {
            (UpAxis::Y, format!("y (auto: {} is Y-up; {how})", t.name()))
        }
        (UpAxisChoice::Auto, None) => match data {
            Some(Ok((a, why))) => (
                *a,
                format!("{} (auto: no tool recognised; {why})", a.name()),
            ),
            Some(Err(why)) => (
                UpAxis::Y,
                format!("y (auto: no tool recognised and {why}; y, murk's default)"),
            ),
            None => (UpAxis::Y, "y (auto: no tool recognised)".into()),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(name: &str, kind: FieldKind, class: &str) -> SourceField {
        SourceField {
            name: name.into(),
            unique_name: name.into(),
            kind,
            type_name: String::new(),
            class: class.into(),
        }
    }

    fn names(n: &[&str]) -> Vec<SourceField> {
        n.iter()
            .map(|s| grid(s, FieldKind::Scalar, "fog volume"))
            .collect()
    }

    #[test]
    fn mantaflow_is_told_by_its_shadow_grid_or_staggered_velocity() {
        // Mantaflow's fire cache: no colour grids, no metadata.
        let fire = names(&["density", "shadow", "temperature", "flame"]);
        let (tool, how) = detect_tool(&[], &fire).unwrap();
        assert_eq!(
            (tool, how.as_str()),
            (Tool::Blender, "Mantaflow's grid set (shadow grid)")
        );
        let mut v = names(&["density", "temperature"]);
        v.push(grid("velocity", FieldKind::Vector, "staggered"));
        let (tool, how) = detect_tool(&[], &v).unwrap();
        assert_eq!(
            (tool, how.as_str()),
            (Tool::Blender, "Mantaflow's grid set (staggered velocity)")
        );
        // A collocated velocity tells nothing.
        let mut v = names(&["density", "temperature"]);
        v.push(grid("velocity", FieldKind::Vector, "unknown"));
        assert!(detect_tool(&[], &v).is_none());
    }

    #[test]
    fn tools_are_told_apart_by_creator_then_names() {
        let houdini = vec![("creator".into(), "Houdini/SOP_OpenVDB_Write".into())];
        assert_eq!(
            detect_tool(&houdini, &names(&["density"])).unwrap().0,
            Tool::Houdini
        );
        let blender = names(&[
            "density",
            "flame",
            "temperature",
            "color_r",
            "color_g",
            "color_b",
        ]);
        assert_eq!(detect_tool(&[], &blender).unwrap().0, Tool::Blender);
        // Metadata wins over names.
        assert_eq!(detect_tool(&houdini, &blender).unwrap().0, Tool::Houdini);
        assert_eq!(
            detect_tool(&[], &names(&["density", "Cd"])).unwrap().0,
            Tool::Houdini
        );
        assert_eq!(
            detect_tool(&[], &names(&["density", "flames"])).unwrap().0,
            Tool::EmberGen
        );
        assert!(detect_tool(&[], &names(&["density", "temperature"])).is_none());
    }

    #[test]
    fn temperature_maps_like_each_tools_default_fire_shader() {
        let b = Some((Tool::Blender, String::new()));
        let h = Some((Tool::Houdini, String::new()));
        assert_eq!(temperature_mapping(b.clone(), 1.0).scale, 1000.0);
        assert_eq!(temperature_mapping(h, 2.0).scale, 5000.0);
        // Kelvin stays Kelvin whatever the tool.
        let k = temperature_mapping(b, 1800.0);
        assert_eq!(
            (k.scale, k.offset, k.convention.as_str()),
            (1.0, 0.0, "kelvin")
        );
    }

    #[test]
    fn z_up_maps_murks_frame_and_back() {
        let v = DVec3::new(0.6, 1.0, 0.5);
        assert_eq!(UpAxis::Z.from_y_up(DVec3::Y), DVec3::Z);
        assert_eq!(UpAxis::Z.to_y_up(UpAxis::Z.from_y_up(v)), v);
        // Right-handed: x × up = toward the camera in both frames.
        let (x, up) = (UpAxis::Z.from_y_up(DVec3::X), UpAxis::Z.from_y_up(DVec3::Y));
        assert_eq!(x.cross(up), UpAxis::Z.from_y_up(DVec3::Z));
    }
}
