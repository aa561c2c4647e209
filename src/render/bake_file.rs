//! `murk bake-shadows`: the shadow maps of a scene's lights written to a `.vdb` cache.

use super::{
    Progress, RenderError, RenderPlan, Result, check_output_dirs, on_plan_threads, write_stats,
};
use crate::render::stats::{RenderStats, Stage};
use crate::scene::lights::bake_maps;
use crate::scene::plan::GridChoice;
use crate::scene::roles::load_fields;
use std::time::Instant;

/// `murk bake-shadows`: bakes the deep shadow map of every light of `plan` over its
/// density grid and writes them to `plan.outputs.path` (a `.vdb`), for `--shadow-cache`.
pub fn bake_shadow_file(plan: &RenderPlan, progress: &dyn Progress) -> Result<RenderStats> {
    on_plan_threads(plan, || bake_shadow_file_here(plan, progress))
}

fn bake_shadow_file_here(plan: &RenderPlan, progress: &dyn Progress) -> Result<RenderStats> {
    let start = Instant::now();
    check_output_dirs(plan)?;
    if !plan
        .outputs
        .path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("vdb"))
    {
        return Err(RenderError::output_path(
            &plan.outputs.path,
            "a shadow cache is a .vdb file; name the output NAME.vdb",
        ));
    }
    if plan.lights.is_empty() {
        return Err(RenderError::NoLights);
    }
    let mut density_only = plan.clone();
    density_only.grids.emission = GridChoice::Off;
    density_only.grids.temperature = GridChoice::Off;
    density_only.grids.color = GridChoice::Off;
    density_only.shadows.cache = None;
    if let Some(v) = &mut density_only.volumes {
        for v in &mut v.list {
            v.grids.emission = GridChoice::Off;
            v.grids.temperature = GridChoice::Off;
            v.grids.color = GridChoice::Off;
        }
    }
    let mut st = RenderStats {
        murk_version: env!("CARGO_PKG_VERSION").into(),
        input: plan.input.display().to_string(),
        output: plan.outputs.path.display().to_string(),
        ..Default::default()
    };
    let report = &mut st.scene;
    let t = Instant::now();
    let fields = match &density_only.volumes {
        // A scene of several volumes: their summed density, as the render sees it.
        Some(v) => crate::scene::volumes::load_volumes(&density_only, v, false, report)
            .map_err(RenderError::Scene)?,
        None => {
            let source = crate::scene::source::open(&plan.input)?;
            load_fields(source.as_ref(), &density_only, false, report)
                .map_err(RenderError::Scene)?
        }
    };
    report
        .stages
        .insert("build".into(), Stage::ran(t.elapsed().as_secs_f64()));
    let (up, _) = crate::scene::conventions::resolve_up_axis(
        plan.production.up_axis,
        &fields.tool,
        fields.up_from_data.as_ref(),
    );
    // The lights as a render of this input turns them, so that it finds them in the cache.
    let turned = crate::scene::turned_for_up(plan, up);
    let plan = &*turned;
    density_only.lights = plan.lights.clone();
    let density = fields.density.as_ref();
    let sigma_t = plan.medium.sigma_t();
    let hash = density.content_hash().ok_or_else(|| RenderError::Input {
        path: plan.input.clone(),
        problem: "this input cannot be fingerprinted for a shadow cache".into(),
    })?;
    let t = Instant::now();
    let (maps, map_stats) = bake_maps(&density_only, density, hash, sigma_t, progress, None)?;
    report
        .stages
        .insert("shadows".into(), Stage::ran(t.elapsed().as_secs_f64()));
    let t = Instant::now();
    crate::shadow::cache::write(
        &plan.outputs.path,
        hash,
        &plan.lights,
        &maps,
        &map_stats,
        plan.shadows.dsm_tolerance,
        sigma_t,
    )?;
    report
        .stages
        .insert("write".into(), Stage::ran(t.elapsed().as_secs_f64()));
    report.shadow_map_memory_bytes = map_stats.iter().map(|s| s.bake.memory_bytes).sum();
    report.density_memory_bytes = density.memory_bytes();
    report.shadow_maps = map_stats;
    report.lights = plan.lights.iter().map(|l| l.name.clone()).collect();
    report.shadows = "dsm".into();
    st.total_seconds = start.elapsed().as_secs_f64();
    if let Some(path) = &plan.outputs.stats {
        write_stats(path, &st)?;
    }
    Ok(st)
}
