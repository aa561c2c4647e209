//! `murk render`.

use anyhow::{Result, anyhow};
use murk::render::piece::Piece;
use murk::render::sequence::{
    FrameOutcome, FramePaths, SequenceOptions, check_inputs_exist, choose_frames, frame_is_done,
    prepare_places, render_sequence,
};
use murk::render::{
    FrameJob, RenderOptions, RenderPlan, bake_shadow_file, run as render, run_frame,
};
use murk::scene::reuse::FrameReuse;
use std::path::{Path, PathBuf};

pub const EXAMPLES: &str = "Examples:
  murk render fixtures/cloud.vdb -o cloud.exr --preview cloud.png
  murk render fixtures/cloud.vdb -o cloud.exr --res 320x180 --light sun:1,1,0:1,0.9,0.8:8 --light sun:-1,0.2,0:0.3,0.4,1:2
  murk render fixtures/pyro.vdb -o pyro.exr --no-lights --stats pyro.json
  murk render fixtures/scene.toml -o cloud.exr --spp 4

With no --light the scene is lit by the default sun, sun:0.6,1,0.5:1,1,1:6 (from the upper right front, white, irradiance 6).
With no camera flags the camera frames the density's world bounds.";

pub const BAKE_EXAMPLES: &str = "Examples:
  murk bake-shadows fixtures/cloud.vdb -o shadows.vdb
  murk render fixtures/cloud.vdb -o frame1.exr --shadow-cache shadows.vdb --eye 3,1,2
  murk bake-shadows fixtures/cloud.vdb -o shadows.vdb --light sun:1,1,0 --light point:2,3,1:1,1,1:40 --dsm-tolerance 1e-4

The map stores the integral of density toward each light, so it depends on the density grid and
where the lights are, not on their colour or intensity or on sigma. Render with the same --light
flags (in the same order, so the names sun0, point0, ... match).";

/// The options of a render: the flags over a scene file, if given, and the .vdb input.
pub fn options_for(input: &Path, options: RenderOptions) -> Result<(RenderOptions, PathBuf)> {
    let is_scene = input
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
    if is_scene {
        let scene = RenderOptions::from_scene_file(input)?;
        let merged = options.over(scene);
        // With [[volume]] tables the first volume's file stands for the input (frame
        // patterns, output checks); the plan reads them all.
        let vdb = merged
            .input
            .clone()
            .or_else(|| merged.volume.first().map(|v| v.file.clone()))
            .ok_or_else(|| {
                anyhow!(
                    "{}: the scene names no `input` .vdb file and no [[volume]]",
                    input.display()
                )
            })?;
        Ok((merged, vdb))
    } else {
        Ok((options, input.to_path_buf()))
    }
}

/// A render's output names must say what murk writes: `-o` an OpenEXR, `--preview` a
/// PNG (`-o out.png` once wrote an EXR named .png). A name with no extension is left.
pub fn check_output_names(options: &RenderOptions) -> Result<()> {
    let wrong = |p: &Path, ext: &str| p.extension().is_some_and(|e| !e.eq_ignore_ascii_case(ext));
    if let Some(o) = options.output.as_deref().filter(|o| wrong(o, "exr")) {
        return Err(anyhow!(
            "-o {}: murk writes OpenEXR; name it {} (and for a PNG of the beauty pass add --preview {})",
            o.display(),
            o.with_extension("exr").display(),
            o.with_extension("png").display()
        ));
    }
    if let Some(p) = options.preview.as_deref().filter(|p| wrong(p, "png")) {
        return Err(anyhow!(
            "--preview {}: the preview is a PNG; name it {}",
            p.display(),
            p.with_extension("png").display()
        ));
    }
    Ok(())
}

/// The plan of a render or bake: options from the flags over a scene file, if given.
fn plan_for(input: &Path, flags: RenderOptions) -> Result<(RenderPlan, bool)> {
    let (options, vdb) = options_for(input, flags.clone())?;
    let quiet = options.quiet;
    let scene = scene_of(input, &vdb);
    let plan = RenderPlan::new(&options, vdb)
        .map_err(|e| anyhow!(super::guard::plan_error_text(&e, &flags, scene)))?;
    super::guard::check_plan(&plan, scene)
        .map_err(|e| super::guard::name_scene(e, scene, &plan.input))?;
    Ok((plan, quiet))
}

/// The plan of a render: as [`plan_for`], and its outputs named for what murk writes
/// (after the checks that outputs replace no input, which say more).
fn render_plan_for(input: &Path, flags: RenderOptions) -> Result<(RenderPlan, bool)> {
    let (merged, _) = options_for(input, flags.clone())?;
    let planned = plan_for(input, flags)?;
    check_output_names(&merged)?;
    Ok(planned)
}

/// The scene file, if `input` is one (the .vdb it names is then another path).
fn scene_of<'a>(input: &'a Path, vdb: &Path) -> Option<&'a Path> {
    (vdb != input).then_some(input)
}

/// `murk render`: one image, or a sequence when a path holds a frame pattern or frames
/// are given, or a piece with --tile. `Ok(false)`: some frame failed (each was reported).
pub fn run_sequence_or_frame(
    input: &Path,
    options: RenderOptions,
    sequence: &super::args::SequenceArgs,
) -> Result<bool> {
    let piece = sequence
        .tile
        .as_deref()
        .map(Piece::parse)
        .transpose()
        .map_err(|e| anyhow!(e))?;
    let (merged, vdb) = options_for(input, options.clone())?;
    let spec = merged.frames.clone();
    let probe = RenderPlan::new(&merged, vdb.clone());
    let is_sequence = spec.is_some()
        || probe
            .as_ref()
            .is_ok_and(|p| FramePaths::of(p).any_pattern());
    if !is_sequence {
        if piece.is_none() && !sequence.skip_existing {
            return run(input, options).map(|_| true);
        }
        let (plan, quiet) = render_plan_for(input, options)?;
        if sequence.skip_existing && frame_is_done(&plan) {
            if !quiet {
                eprintln!("murk: {} exists: skipped", plan.outputs.path.display());
            }
            return Ok(true);
        }
        let scene = scene_of(input, &plan.input);
        let job = FrameJob { frame: None, piece };
        let stats = run_frame(
            &plan,
            &super::progress::Bars::new(quiet),
            &mut FrameReuse::default(),
            job,
        )
        .map_err(|e| super::guard::name_scene(e.into(), scene, &plan.input))?;
        print_warnings(&stats.scene.warnings);
        if !quiet {
            eprintln!(
                "murk: wrote {} ({}x{}{}) in {:.2} s",
                plan.outputs.path.display(),
                stats.width,
                stats.height,
                piece.map(|p| format!(", piece {p}")).unwrap_or_default(),
                stats.total_seconds
            );
        }
        return Ok(true);
    }
    let (plan, quiet) = render_plan_for(input, options)?;
    let scene = scene_of(input, &plan.input).map(Path::to_path_buf);
    let paths = FramePaths::of(&plan);
    let frames = choose_frames(&paths, &plan, spec.as_deref())?;
    check_inputs_exist(&paths, &plan, &frames)?;
    super::guard::check_sequence(&plan, &paths, &frames, scene.as_deref())?;
    prepare_places(&paths, &frames)?;
    let bars = super::progress::Bars::new(quiet);
    let check = |p: &RenderPlan| super::guard::check_plan(p, scene.as_deref());
    // Each note once, at the first frame that has it: a sequence's frames mostly share
    // theirs (the tool, the up axis), and a note only some frames have (no velocity grid
    // for --shutter) names the first of them.
    let mut noted = std::collections::HashSet::new();
    let mut report = |frame: i64, p: &RenderPlan, outcome: &FrameOutcome<anyhow::Error>| {
        let mut lines = Vec::new();
        match outcome {
            FrameOutcome::Failed(e) => lines.push(format!(
                "murk: error: frame {frame}: {}",
                super::one_line(&super::error_chain(e))
            )),
            FrameOutcome::Skipped if !quiet => lines.push(format!(
                "murk: frame {frame}: {} exists: skipped",
                p.outputs.path.display()
            )),
            FrameOutcome::Skipped => {}
            FrameOutcome::Written(st) => {
                // Warnings even with --quiet, as for one image.
                lines.extend(st.scene.warnings.iter().map(|w| {
                    format!(
                        "murk: warning: frame {frame}: {}",
                        super::guard::message_text(w)
                    )
                }));
                if !quiet && p.outputs.stats.is_some() {
                    lines.push(format!(
                        "murk: frame {frame}: wrote {} in {:.2} s (shadows: {})",
                        p.outputs.path.display(),
                        st.total_seconds,
                        st.scene
                            .shadow_maps
                            .first()
                            .map_or("none".into(), |m| m.source.clone())
                    ));
                }
                if !quiet {
                    lines.extend(st.scene.notes.iter().filter_map(|n| {
                        let text = super::guard::message_text(n);
                        noted
                            .insert(text.clone())
                            .then(|| format!("murk: note: frame {frame}: {text}"))
                    }));
                }
            }
        }
        for l in lines {
            bars.println(&l);
        }
    };
    let summary = render_sequence(
        &plan,
        &paths,
        &frames,
        SequenceOptions {
            skip_existing: sequence.skip_existing,
            piece,
        },
        &bars,
        &check,
        &mut report,
    );
    if !quiet {
        eprintln!(
            "murk: {} frames: {} written, {} skipped, {} failed, in {:.2} s (shadow maps reused in {} frames{})",
            frames.len(),
            summary.written,
            summary.skipped,
            summary.failed.len(),
            summary.seconds,
            summary.shadow_maps_reused,
            match summary.gpu_scenes_kept {
                0 => String::new(),
                n => format!("; the scene's GPU buffers kept in {n}"),
            }
        );
    }
    if !summary.failed.is_empty() {
        let list: Vec<String> = summary.failed.iter().map(i64::to_string).collect();
        eprintln!(
            "murk: error: {} of {} frames failed: {}",
            summary.failed.len(),
            frames.len(),
            list.join(",")
        );
        return Ok(false);
    }
    Ok(true)
}

pub fn run(input: &Path, options: RenderOptions) -> Result<()> {
    let (plan, quiet) = render_plan_for(input, options)?;
    let scene = scene_of(input, &plan.input);
    let stats = render(&plan, &super::progress::Bars::new(quiet))
        .map_err(|e| super::guard::name_scene(e.into(), scene, &plan.input))?;
    print_warnings(&stats.scene.warnings);
    if !quiet {
        eprintln!(
            "murk: wrote {} ({}x{}, {} channels) in {:.2} s",
            plan.outputs.path.display(),
            stats.width,
            stats.height,
            stats.channels.len(),
            stats.total_seconds
        );
        for n in &stats.scene.notes {
            eprintln!("murk: note: {}", super::guard::message_text(n));
        }
    }
    Ok(())
}

pub fn bake(input: &Path, options: RenderOptions, frame: Option<i64>) -> Result<()> {
    let (plan, quiet) = plan_for(input, options)?;
    let scene = scene_of(input, &plan.input).map(Path::to_path_buf);
    let scene = scene.as_deref();
    let plan = match frame {
        Some(f) => {
            let at = FramePaths::of(&plan).plan(&plan, f);
            super::guard::check_plan(&at, scene)?;
            at
        }
        None => plan,
    };
    let stats = bake_shadow_file(&plan, &super::progress::Bars::new(quiet))
        .map_err(|e| super::guard::name_scene(e.into(), scene, &plan.input))?;
    print_warnings(&stats.scene.warnings);
    if !quiet {
        for m in &stats.scene.shadow_maps {
            eprintln!(
                "murk: {}: {} bricks ({} likely over the tolerance), {:.1} MB, baked in {:.2} s",
                m.light,
                m.bake.bricks,
                m.bake.bricks_over_tolerance,
                m.bake.memory_bytes as f64 / 1e6,
                m.bake_seconds
            );
        }
        eprintln!(
            "murk: wrote {} in {:.2} s",
            plan.outputs.path.display(),
            stats.total_seconds
        );
    }
    Ok(())
}

/// Warnings are printed even with `--quiet`: they say what lost accuracy unasked.
fn print_warnings(warnings: &[String]) {
    for w in warnings {
        eprintln!("murk: warning: {}", super::guard::message_text(w));
    }
}
