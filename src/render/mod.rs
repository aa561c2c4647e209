//! Rendering: camera, lights, the scene's grids in their roles, and the tiled pixel loop.
//! [`run`] does a whole render: load → build → render → write, timing every stage.

pub mod camera;
pub mod ground;
pub mod light;
pub mod options;
pub mod pixels;
pub mod plan;
pub mod scene;
pub mod shadow_cache;
pub mod shadows;
pub mod stats;

pub use options::{BakeOptions, RenderOptions};
pub use plan::RenderPlan;

use crate::field::Field;
use crate::field::union::FieldUnion;
use crate::integrate::blackbody::BlackbodyTable;
use crate::integrate::{ColorTint, Companion, Emission, Illumination, Medium, Volume};
use crate::output::{Frame, names, write_atomically, write_exr, write_preview};
use crate::vdb::VdbFile;
use anyhow::{Context, Result, anyhow};
use camera::{Camera, Projection};
use glam::DVec3;
use indicatif::{ProgressBar, ProgressStyle};
use plan::{GridChoice, ShadowMode};
use scene::{SceneGrids, load_grids};
use shadows::{SceneLights, bake_maps, light_shadows};
use stats::{RenderStats, Stage};
use std::io::IsTerminal;
use std::path::Path;
use std::time::Instant;

fn resolve_camera(plan: &RenderPlan, density: &dyn Field) -> Result<Camera> {
    let (lo, hi) = density.world_bounds();
    let (lo, hi) = if density.active_bounds().is_empty() {
        (DVec3::splat(-1.0), DVec3::splat(1.0))
    } else {
        (lo, hi)
    };
    let req = &plan.camera;
    let framed = Camera::framing(lo, hi, plan.width, plan.height, req.projection);
    let mut cam = framed;
    cam.up = req.up;
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
    cam.validate().map_err(|e| anyhow!(e))?;
    Ok(cam)
}

/// A rendered image, not yet written: its channels, the EXR header it will carry, and
/// the stats so far (everything but the write stage).
pub struct RenderedImage {
    pub frame: Frame,
    pub exr: crate::output::ExrOptions,
    pub stats: RenderStats,
}

/// Renders a plan and writes its outputs. Returns the stats (also written with --stats).
pub fn run(plan: &RenderPlan) -> Result<RenderStats> {
    let start = Instant::now();
    check_output_dirs(plan)?;
    let RenderedImage {
        frame,
        mut exr,
        stats: mut st,
    } = render_image(plan)?;
    let t = Instant::now();
    exr.render_time_seconds = Some(start.elapsed().as_secs_f64());
    // Every output or none: if a later one fails, the earlier ones of this run go.
    let mut written: Vec<&Path> = Vec::new();
    let result = (|| -> Result<()> {
        write_exr(&plan.output, &frame, &exr)?;
        written.push(&plan.output);
        if let Some((path, opts)) = &plan.preview {
            write_preview(path, &frame, opts)?;
            written.push(path);
        }
        st.stages
            .insert("write".into(), Stage::ran(t.elapsed().as_secs_f64()));
        st.total_seconds = start.elapsed().as_secs_f64();
        if let Some(path) = &plan.stats {
            write_stats(path, &st)?;
        }
        Ok(())
    })();
    if let Err(e) = result {
        for p in written {
            let _ = std::fs::remove_file(p);
        }
        return Err(e);
    }
    Ok(st)
}

/// Renders a plan into memory: load → build → render. Nothing is written.
pub fn render_image(plan: &RenderPlan) -> Result<RenderedImage> {
    let start = Instant::now();
    let mut st = RenderStats {
        murk_version: env!("CARGO_PKG_VERSION").into(),
        input: plan.input.display().to_string(),
        output: plan.output.display().to_string(),
        width: plan.width,
        height: plan.height,
        spp: plan.spp,
        ..Default::default()
    };
    // Load: descriptors and metadata only.
    let t = Instant::now();
    let file = VdbFile::open(&plan.input)?;
    st.stages
        .insert("load".into(), Stage::ran(t.elapsed().as_secs_f64()));

    let medium = Medium {
        sigma_a: plan.sigma_a,
        sigma_s: plan.sigma_s,
        density_scale: plan.density_scale,
        g: plan.g,
    };
    let scatters = !plan.lights.is_empty() && medium.scatters();
    // Build: decode only the grids in a role.
    let t = Instant::now();
    let SceneGrids {
        density,
        emission: emission_grid,
        temperature: temperature_grid,
        color: color_grid,
        emission_found,
    } = load_grids(&file, plan, scatters, &mut st)?;
    st.stages
        .insert("build".into(), Stage::ran(t.elapsed().as_secs_f64()));

    let camera = resolve_camera(plan, &density)?;
    let mut traversal = FieldUnion::new(&density);
    let mut emission = None;
    if emission_grid.is_some() || temperature_grid.is_some() {
        let eg = emission_grid.as_ref().map(|g| Companion::new(g, &density));
        let tg = temperature_grid
            .as_ref()
            .map(|g| Companion::new(g, &density));
        for c in [eg, tg].into_iter().flatten() {
            match c.offset() {
                Some(o) => traversal = traversal.with(c.field, o.as_ivec3()),
                None => st.notes.push("an emission grid is not on the density's lattice: it is sampled only where density is non-zero".into()),
            }
        }
        emission = Some(Emission {
            grid: eg,
            color: plan.emission_color,
            intensity: plan.emission_intensity,
            temperature: tg,
            temperature_scale: plan.temperature_scale,
            temperature_offset: plan.temperature_offset,
            blackbody_intensity: plan.blackbody_intensity,
            table: BlackbodyTable::new(200.0, 40000.0, 2048),
        });
    }
    let emits = emission.as_ref().is_some_and(|e| e.is_active());
    let turned_off =
        plan.emission_grid == GridChoice::Off && plan.temperature_grid == GridChoice::Off;
    let emission_skip_reason = if turned_off {
        "emission and temperature grids turned off"
    } else if emission_found {
        "emission and blackbody intensities are 0"
    } else {
        "no emission or temperature grid in the scene"
    };
    st.stages.insert(
        "emission".into(),
        if emits {
            Stage::ran(0.0)
        } else {
            Stage::skipped(emission_skip_reason)
        },
    );
    let scatter_reason = if plan.lights.is_empty() {
        "no lights"
    } else {
        "sigma_s is 0"
    };
    st.stages.insert(
        "scatter".into(),
        if scatters {
            Stage::ran(0.0)
        } else {
            Stage::skipped(scatter_reason)
        },
    );
    // Shadows: a map per light, baked once here (or read from a cache) and looked up by
    // every sample; or marched per sample.
    let sigma_t = medium.sigma_t();
    // The ground plane needs the lights' shadows even when the medium does not scatter.
    let lit = !plan.lights.is_empty() && sigma_t.max_element() > 0.0;
    let shadows_needed =
        (scatters || (plan.ground.is_some() && lit)) && plan.shadows != ShadowMode::None;
    let mut maps = Vec::new();
    if shadows_needed && plan.shadows == ShadowMode::Dsm {
        let t = Instant::now();
        let (m, map_stats) =
            bake_maps(plan, &density, density.content_hash(), sigma_t, plan.quiet)?;
        maps = m;
        let seconds = t.elapsed().as_secs_f64();
        st.shadow_map_memory_bytes = map_stats.iter().map(|s| s.bake.memory_bytes).sum();
        st.density_memory_bytes = density.memory_bytes();
        st.shadow_maps = map_stats;
        st.stages.insert("shadows".into(), Stage::ran(seconds));
    } else {
        st.stages.insert(
            "shadows".into(),
            if !scatters {
                Stage::skipped(scatter_reason)
            } else if plan.shadows == ShadowMode::None {
                Stage::skipped("--shadows none")
            } else {
                Stage {
                    status: "ran: marched per sample (inside render)".into(),
                    seconds: 0.0,
                }
            },
        );
    }
    st.shadows = match (scatters, plan.shadows) {
        (false, _) => format!("skipped: {scatter_reason}"),
        (true, ShadowMode::None) => "none".into(),
        (true, ShadowMode::March) => "march".into(),
        (true, ShadowMode::Dsm) => "dsm".into(),
    };
    st.lights = plan.lights.iter().map(|l| l.name.clone()).collect();
    let volume = Volume {
        density: &density,
        medium,
        emission,
        color: color_grid.as_ref().map(|c| ColorTint::new(c, &density)),
        traversal: &traversal,
    };
    let sigma_t_min = sigma_t.min_element().max(1e-30);
    let lights = SceneLights {
        lights: &plan.lights,
        density: &density,
        shadows: light_shadows(plan.shadows, maps, plan.lights.len()),
        quadrature: plan.shadow_quadrature(),
        // Past T = termination the light's contribution is dropped, as the camera ray's is.
        enough: (1.0 / plan.termination).ln().max(1.0) / sigma_t_min,
    };
    let light_count = if scatters { plan.lights.len() } else { 0 };
    let job = pixels::PixelJob {
        volume: &volume,
        lights: scatters.then_some(&lights as &dyn Illumination),
        ground: plan.ground.map(|height| {
            (
                ground::Ground {
                    height,
                    visible: plan.ground_visible,
                },
                &lights as &dyn Illumination,
            )
        }),
        light_count,
        camera: &camera,
        settings: plan.march_settings(),
        spp: plan.spp,
        seed: plan.seed,
    };

    // Render.
    let t = Instant::now();
    let tiles = (plan.width.div_ceil(pixels::TILE) * plan.height.div_ceil(pixels::TILE)) as u64;
    let progress = if plan.quiet || !std::io::stderr().is_terminal() {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(tiles)
    };
    progress.set_style(
        ProgressStyle::with_template(
            "{spinner} rendering [{bar:40}] {pos}/{len} tiles {elapsed} (eta {eta})",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(plan.threads.unwrap_or(0))
        .build()
        .context("starting worker threads")?;
    let passes = pool.install(|| pixels::render_pixels(&job, &progress));
    progress.finish_and_clear();
    let render_seconds = t.elapsed().as_secs_f64();
    st.stages
        .insert("render".into(), Stage::ran(render_seconds));
    st.rays = passes.rays;
    st.samples = passes.samples;
    st.samples_per_second = passes.samples as f64 / render_seconds.max(1e-9);

    // Assemble the channels.
    let mut frame = Frame::new(plan.width, plan.height);
    let n = plan.width * plan.height;
    let sum3 = |c: usize| -> Vec<f32> {
        (0..n)
            .map(|i| {
                passes.emission[c][i]
                    + passes.scatter[c][i]
                    + passes.ground.as_ref().map_or(0.0, |g| g[c][i])
            })
            .collect()
    };
    frame.add_channel(names::R, sum3(0))?;
    frame.add_channel(names::G, sum3(1))?;
    frame.add_channel(names::B, sum3(2))?;
    frame.add_channel(names::A, passes.alpha.clone())?;
    frame.add_channel(names::Z, passes.depth.clone())?;
    let add_layer = |frame: &mut Frame, layer: &str, planes: &[Vec<f32>; 3]| -> Result<()> {
        for (name, plane) in names::layer_rgb(layer).into_iter().zip(planes) {
            frame.add_channel(&name, plane.clone())?;
        }
        Ok(())
    };
    if emits {
        add_layer(&mut frame, names::EMISSION, &passes.emission)?;
    }
    if scatters {
        add_layer(&mut frame, names::SCATTER, &passes.scatter)?;
        if plan.lights.len() > 1 {
            for (l, planes) in plan.lights.iter().zip(&passes.per_light) {
                add_layer(&mut frame, &format!("scatter_{}", l.name), planes)?;
            }
        }
    }
    if let Some(shadow) = &passes.shadow {
        add_layer(&mut frame, names::SHADOW, shadow)?;
    }
    let mut exr = plan.exr.clone();
    exr.world_to_camera = Some(camera.world_to_camera().as_mat4().to_cols_array_2d());
    let (near, far) = depth_range(&camera, &density);
    exr.world_to_ndc = Some(camera.world_to_ndc(near, far).as_mat4().to_cols_array_2d());
    exr.extra_strings.push((
        "murk/depthRule".into(),
        "Z is the camera-space distance along the view axis where accumulated alpha first reaches 0.5; +inf where it never does".into(),
    ));
    st.channels = frame
        .channel_names()
        .iter()
        .map(|s| s.to_string())
        .collect();
    st.total_seconds = start.elapsed().as_secs_f64();
    Ok(RenderedImage {
        frame,
        exr,
        stats: st,
    })
}

/// `murk bake-shadows`: bakes the deep shadow map of every light of `plan` over its
/// density grid and writes them to `plan.output` (a `.vdb`), for `--shadow-cache`.
pub fn bake_shadow_file(plan: &RenderPlan) -> Result<RenderStats> {
    let start = Instant::now();
    check_output_dirs(plan)?;
    if !plan
        .output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("vdb"))
    {
        return Err(anyhow!(
            "{}: a shadow cache is a .vdb file; name the output NAME.vdb",
            plan.output.display()
        ));
    }
    if plan.lights.is_empty() {
        return Err(anyhow!("no lights to bake shadows for"));
    }
    let mut st = RenderStats {
        murk_version: env!("CARGO_PKG_VERSION").into(),
        input: plan.input.display().to_string(),
        output: plan.output.display().to_string(),
        ..Default::default()
    };
    let file = VdbFile::open(&plan.input)?;
    let density_only = RenderPlan {
        emission_grid: GridChoice::Off,
        temperature_grid: GridChoice::Off,
        color_grid: GridChoice::Off,
        shadow_cache: None,
        ..plan.clone()
    };
    let t = Instant::now();
    let grids = load_grids(&file, &density_only, false, &mut st)?;
    st.stages
        .insert("build".into(), Stage::ran(t.elapsed().as_secs_f64()));
    let density = grids.density;
    let sigma_t = Medium {
        sigma_a: plan.sigma_a,
        sigma_s: plan.sigma_s,
        density_scale: plan.density_scale,
        g: plan.g,
    }
    .sigma_t();
    let hash = density.content_hash();
    let t = Instant::now();
    let (maps, map_stats) = bake_maps(&density_only, &density, hash, sigma_t, plan.quiet)?;
    st.stages
        .insert("shadows".into(), Stage::ran(t.elapsed().as_secs_f64()));
    let t = Instant::now();
    shadow_cache::write(
        &plan.output,
        hash,
        &plan.lights,
        &maps,
        &map_stats,
        plan.dsm_tolerance,
        sigma_t,
    )?;
    st.stages
        .insert("write".into(), Stage::ran(t.elapsed().as_secs_f64()));
    st.shadow_map_memory_bytes = map_stats.iter().map(|s| s.bake.memory_bytes).sum();
    st.density_memory_bytes = density.memory_bytes();
    st.shadow_maps = map_stats;
    st.lights = plan.lights.iter().map(|l| l.name.clone()).collect();
    st.shadows = "dsm".into();
    st.total_seconds = start.elapsed().as_secs_f64();
    if let Some(path) = &plan.stats {
        write_stats(path, &st)?;
    }
    Ok(st)
}

/// Writes the stats as pretty JSON, atomically.
fn write_stats(path: &Path, st: &RenderStats) -> Result<()> {
    let text = serde_json::to_string_pretty(st)?;
    write_atomically(path, |tmp| {
        std::fs::write(tmp, text.as_bytes()).map_err(|e| anyhow!("{}: {e}", path.display()))
    })
}

/// Fails before any work if an output's directory does not exist.
fn check_output_dirs(plan: &RenderPlan) -> Result<()> {
    let outputs = [
        Some(&plan.output),
        plan.preview.as_ref().map(|p| &p.0),
        plan.stats.as_ref(),
    ];
    for path in outputs.into_iter().flatten() {
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        if !dir.is_dir() {
            return Err(anyhow!(
                "{}: cannot write there: the directory {} does not exist",
                path.display(),
                dir.display()
            ));
        }
        if path.is_dir() {
            return Err(anyhow!("{}: is a directory", path.display()));
        }
    }
    Ok(())
}

/// Near and far planes that bracket the density (for the worldToNDC attribute).
fn depth_range(camera: &Camera, density: &dyn Field) -> (f64, f64) {
    let (lo, hi) = density.world_bounds();
    let w2c = camera.world_to_camera();
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
