//! The scene's grids in their roles: which grid is density, emission, temperature and
//! colour (named, or detected from the names Houdini, Blender and EmberGen use), decoded
//! only when the render needs them.

use super::plan::{GridChoice, RenderPlan};
use super::stats::{RenderStats, Sanitised};
use crate::field::VoxelGrid;
use crate::vdb::{ValueKind, VdbFile};
use anyhow::{Result, anyhow};

/// Names grids get from Houdini, Blender and EmberGen, by role, in order of preference.
pub const DENSITY_NAMES: &[&str] = &["density", "density_grid", "smoke", "soot"];
pub const EMISSION_NAMES: &[&str] = &["flame", "flames", "fire", "emission", "fuel"];
pub const TEMPERATURE_NAMES: &[&str] = &["temperature", "heat", "temp"];
pub const COLOR_NAMES: &[&str] = &["Cd", "color", "colour"];

/// Picks the grid for a role: the one named, else the first usual name that exists.
fn choose(
    file: &VdbFile,
    choice: &GridChoice,
    usual: &[&str],
    role: &str,
    kind: ValueKind,
) -> Result<Option<String>> {
    match choice {
        GridChoice::Off => Ok(None),
        GridChoice::Named(n) => {
            let g = file.grid(n)?;
            if g.kind != kind {
                let want = if kind == ValueKind::Vector {
                    "vec3"
                } else {
                    "float"
                };
                return Err(anyhow!(
                    "{}: grid \"{}\" ({}) cannot be the {role} grid: it must hold {want} values",
                    file.path().display(),
                    g.unique_name,
                    g.value_type
                ));
            }
            Ok(Some(g.unique_name.clone()))
        }
        GridChoice::Detect => Ok(usual
            .iter()
            .find_map(|n| {
                file.grids()
                    .iter()
                    .find(|g| g.name.eq_ignore_ascii_case(n) && g.kind == kind)
            })
            .map(|g| g.unique_name.clone())),
    }
}

/// The decoded grids of a render.
pub struct SceneGrids {
    pub density: VoxelGrid,
    pub emission: Option<VoxelGrid>,
    pub temperature: Option<VoxelGrid>,
    pub color: Option<VoxelGrid>,
    /// An emission or temperature grid exists, whether or not it is used.
    pub emission_found: bool,
}

/// Picks the grids for every role and decodes those the render needs (`scatters`: the
/// colour grid is needed only then), recording roles, decoded and skipped grids and
/// sanitised voxels in `st`.
pub fn load_grids(
    file: &VdbFile,
    plan: &RenderPlan,
    scatters: bool,
    st: &mut RenderStats,
) -> Result<SceneGrids> {
    let density_name = choose(
        file,
        &plan.density_grid,
        DENSITY_NAMES,
        "density",
        ValueKind::Scalar,
    )?
    .ok_or_else(|| {
        anyhow!(
            "{}: no density grid found (the file has: {}); name one with --density-grid",
            plan.input.display(),
            file.grid_list()
        )
    })?;
    let emission_name = choose(
        file,
        &plan.emission_grid,
        EMISSION_NAMES,
        "emission",
        ValueKind::Scalar,
    )?;
    let temperature_name = choose(
        file,
        &plan.temperature_grid,
        TEMPERATURE_NAMES,
        "temperature",
        ValueKind::Scalar,
    )?;
    let color_name = choose(
        file,
        &plan.color_grid,
        COLOR_NAMES,
        "color",
        ValueKind::Vector,
    )?;
    let emission_found = emission_name.is_some() || temperature_name.is_some();
    let emission_wanted = emission_name.is_some()
        && plan.emission_intensity > 0.0
        && plan.emission_color.max_element() > 0.0;
    let temperature_wanted = temperature_name.is_some() && plan.blackbody_intensity > 0.0;
    let emission_name = emission_name.filter(|_| emission_wanted);
    let temperature_name = temperature_name.filter(|_| temperature_wanted);

    let load = |name: &String| VoxelGrid::load(file, name);
    let density = load(&density_name)?;
    let emission_grid = emission_name.as_ref().map(load).transpose()?;
    let temperature_grid = temperature_name.as_ref().map(load).transpose()?;
    // The colour grid only tints scattering: not decoded when nothing scatters.
    let color_grid = color_name
        .filter(|_| scatters)
        .as_ref()
        .map(load)
        .transpose()?;
    for (role, g) in [
        ("density", Some(&density)),
        ("emission", emission_grid.as_ref()),
        ("temperature", temperature_grid.as_ref()),
        ("color", color_grid.as_ref()),
    ] {
        if let Some(g) = g {
            st.grid_roles.insert(role.into(), g.name().into());
            st.grids_decoded.push(g.name().into());
            let s = g.stats();
            st.sanitised.insert(
                g.name().into(),
                Sanitised {
                    nan: s.nan,
                    inf: s.inf,
                    negative: s.negative,
                },
            );
            st.sanitised_total += s.sanitised();
            st.grid_memory_bytes += g.memory_bytes();
        }
    }
    st.grids_not_decoded = file
        .grids()
        .iter()
        .map(|g| g.unique_name.clone())
        .filter(|n| !st.grids_decoded.contains(n))
        .collect();
    Ok(SceneGrids {
        density,
        emission: emission_grid,
        temperature: temperature_grid,
        color: color_grid,
        emission_found,
    })
}
