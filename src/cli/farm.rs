//! `murk farm openjd`: an Open Job Description job template (specification 2023-09, the
//! format AWS Deadline Cloud runs) for a sequence: a `Render` step with a task per frame
//! and piece, a `Stitch` step after it that puts each frame's pieces together (with one
//! piece it checks the piece and writes the frame). Paths are job parameters, so a farm
//! can remap them, each with a default: what was given here, made absolute.

use super::args::RenderArgs;
use anyhow::{Result, anyhow};
use clap::{Args, Subcommand};
use murk::output::guard::Role;
use murk::render::RenderPlan;
use murk::render::sequence::{FramePaths, choose_frames};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

#[derive(Subcommand, Debug)]
pub enum FarmCommand {
    /// Write an Open Job Description job template (2023-09) rendering a sequence, for
    /// AWS Deadline Cloud (`deadline bundle submit`) or `openjd run`.
    #[command(after_help = EXAMPLES)]
    Openjd {
        /// A .vdb (or mesh) with a frame pattern, or a scene .toml.
        input: PathBuf,
        #[command(flatten)]
        options: Box<RenderArgs>,
        /// Split every frame into N bands of rows, rendered as separate tasks and
        /// stitched (default 1).
        #[arg(long, value_name = "N", default_value_t = 1)]
        tiles: usize,
        /// The job template to write (JSON, which is YAML too).
        #[arg(long, value_name = "JOB.yaml")]
        job: PathBuf,
    },
}

pub const EXAMPLES: &str = "Examples:
  murk farm openjd 'cache/fluid_####.vdb' --frames 1-250 -o 'render/fluid_####.exr' --job job.yaml
  murk farm openjd 'cache/fluid_####.vdb' --frames 1-250 --tiles 4 --res 1920x1080 -o 'render/fluid_####.exr' --job job.yaml
  openjd check job.yaml && openjd run job.yaml --step Stitch --run-dependencies";

/// The flags forwarded verbatim to every `murk render` task: all those given, except
/// the paths (job parameters), the frames and pieces (task parameters) and this
/// command's own.
fn forwarded_flags(raw: &[String], input: &Path) -> Vec<String> {
    let cmd = RenderArgs::augment_args(clap::Command::new("x"));
    let takes_value = |flag: &str| {
        cmd.get_arguments().any(|a| {
            let long = a.get_long().map(|l| format!("--{l}"));
            let short = a.get_short().map(|s| format!("-{s}"));
            (long.as_deref() == Some(flag) || short.as_deref() == Some(flag))
                && a.get_action().takes_values()
        }) || flag == "--tiles"
            || flag == "--job"
    };
    let dropped = [
        "-o",
        "--output",
        "--stats",
        "--preview",
        "--shadow-cache",
        "--frames",
        "--tile",
        "--tiles",
        "--job",
        "--skip-existing",
    ];
    let mut out = Vec::new();
    let mut input_seen = false;
    let mut i = 0;
    while i < raw.len() {
        let a = &raw[i];
        let flag = a.split_once('=').map_or(a.as_str(), |(f, _)| f);
        let with_value = a.starts_with('-') && !a.contains('=') && takes_value(flag);
        let keep = if !a.starts_with('-') && !input_seen && Path::new(a) == input {
            input_seen = true;
            false
        } else {
            !dropped.contains(&flag)
        };
        if keep {
            out.push(a.clone());
            if with_value && i + 1 < raw.len() {
                out.push(raw[i + 1].clone());
            }
        }
        i += if with_value { 2 } else { 1 };
    }
    out
}

fn absolute(p: &Path) -> Result<String> {
    Ok(std::path::absolute(p)
        .map_err(|e| anyhow!("{}: {e}", p.display()))?
        .display()
        .to_string())
}

/// `path` relative to the folder `base` (both made absolute first): Open Job Description
/// joins a PATH parameter's default to the template's folder, and requires it relative
/// and inside that folder. `flag` names the path in the error.
fn relative_to(path: &Path, base: &Path, flag: &str) -> Result<String> {
    let (p, b) = (
        PathBuf::from(absolute(path)?),
        PathBuf::from(absolute(base)?),
    );
    let (pc, bc): (Vec<_>, Vec<_>) = (p.components().collect(), b.components().collect());
    let common = pc.iter().zip(&bc).take_while(|(a, b)| a == b).count();
    if common < bc.len() {
        return Err(anyhow!(
            "{flag} {}: outside {}, the folder of the job template: Open Job Description takes a path's default only inside it (write --job in a folder above every path, e.g. the project's root)",
            path.display(),
            b.display()
        ));
    }
    let mut out = PathBuf::new();
    for c in &pc[common..] {
        out.push(c);
    }
    Ok(out.display().to_string())
}

fn path_param(name: &str, path: &Path, job_dir: &Path, flow: &str, what: &str) -> Result<Value> {
    Ok(json!({
        "name": name,
        "type": "PATH",
        "objectType": "FILE",
        "dataFlow": flow,
        "description": format!("murk render {what}"),
        "default": relative_to(path, job_dir, what)?,
    }))
}

fn on_run(args: Vec<String>) -> Value {
    json!({ "actions": { "onRun": { "command": "{{Param.Murk}}", "args": args } } })
}

/// `murk farm openjd`.
pub fn openjd(input: &Path, options: RenderArgs, tiles: usize, job: &Path) -> Result<()> {
    if options.sequence.tile.is_some() {
        return Err(anyhow!(
            "--tile: murk farm splits frames itself; give --tiles N"
        ));
    }
    if tiles == 0 || tiles > murk::render::piece::MAX_PIECES {
        return Err(anyhow!(
            "--tiles {tiles}: must be 1 to {}",
            murk::render::piece::MAX_PIECES
        ));
    }
    let raw: Vec<String> = std::env::args().skip(3).collect();
    let flags = forwarded_flags(&raw, input);
    let (merged, vdb) = super::render::options_for(input, options.options())?;
    if merged.output.is_none() {
        return Err(anyhow!(
            "-o: name the frames' output, e.g. -o 'render/fluid_####.exr'"
        ));
    }
    let plan = RenderPlan::new(&merged, vdb).map_err(|e| anyhow!("{e}"))?;
    if tiles > plan.camera.height {
        return Err(anyhow!(
            "--tiles {tiles}: more pieces than the image's {} rows",
            plan.camera.height
        ));
    }
    let paths = FramePaths::of(&plan);
    let frames = choose_frames(&paths, &plan, merged.frames.as_deref())?;
    let has_pattern = paths.output.is_pattern();
    if tiles > 1 && (merged.stats.is_some() || merged.preview.is_some()) {
        return Err(anyhow!(
            "--stats and --preview describe a whole render: give them without --tiles"
        ));
    }
    let scene = (plan.input != input).then_some(input);
    check_job(&plan, &paths, &frames, scene, tiles, job)?;
    let job_dir = match job.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let exe = std::env::current_exe().map_err(|e| anyhow!("cannot find murk itself: {e}"))?;
    let mut params = vec![
        json!({
            "name": "Murk",
            "type": "STRING",
            "description": "The murk executable on the workers",
            "default": exe.display().to_string(),
        }),
        path_param("Input", input, &job_dir, "IN", "INPUT")?,
        path_param("Output", &plan.outputs.path, &job_dir, "OUT", "-o")?,
    ];
    let mut render_args: Vec<String> = vec!["render".into(), "{{Param.Input}}".into()];
    let mut extra = |name: &str, flag: &str, path: &Option<PathBuf>, flow: &str| -> Result<()> {
        if let Some(p) = path {
            params.push(path_param(name, p, &job_dir, flow, flag)?);
            render_args.extend([flag.to_string(), format!("{{{{Param.{name}}}}}")]);
        }
        Ok(())
    };
    extra("Stats", "--stats", &merged.stats, "OUT")?;
    extra("Preview", "--preview", &merged.preview, "OUT")?;
    extra("ShadowCache", "--shadow-cache", &merged.shadow_cache, "IN")?;
    let piece = |tile: &str| format!("{{{{Param.Output}}}}.piece{tile}of{tiles}.exr");
    render_args.extend([
        "--frames".into(),
        "{{Task.Param.Frame}}".into(),
        "--tile".into(),
        format!("{{{{Task.Param.Tile}}}}/{tiles}"),
        "-o".into(),
        piece("{{Task.Param.Tile}}"),
        "--quiet".into(),
    ]);
    render_args.extend(flags);
    let mut stitch_args: Vec<String> = vec!["stitch".into()];
    if has_pattern || frames.len() > 1 {
        stitch_args.extend(["--frame".into(), "{{Task.Param.Frame}}".into()]);
    }
    stitch_args.extend((1..=tiles).map(|t| piece(&t.to_string())));
    stitch_args.extend(["-o".into(), "{{Param.Output}}".into()]);
    let frame_param = json!({ "name": "Frame", "type": "INT", "range": frames });
    let name = format!(
        "murk {}",
        input.file_name().unwrap_or_default().to_string_lossy()
    );
    let template = json!({
        "specificationVersion": "jobtemplate-2023-09",
        "name": name,
        "description": format!(
            "murk render of {} frames in {tiles} piece(s) each, stitched. Made by murk farm openjd.",
            frames.len()
        ),
        "parameterDefinitions": params,
        "steps": [
            {
                "name": "Render",
                "parameterSpace": {
                    "taskParameterDefinitions": [
                        frame_param,
                        { "name": "Tile", "type": "INT", "range": (1..=tiles).collect::<Vec<_>>() },
                    ],
                },
                "script": on_run(render_args),
            },
            {
                "name": "Stitch",
                "dependencies": [{ "dependsOn": "Render" }],
                "parameterSpace": { "taskParameterDefinitions": [frame_param] },
                "script": on_run(stitch_args),
            },
        ],
    });
    let text = serde_json::to_string_pretty(&template)? + "\n";
    murk::output::write_atomically(job, |tmp| {
        std::fs::write(tmp, text.as_bytes()).map_err(|e| anyhow!("{}: {e}", job.display()))
    })?;
    if !merged.quiet {
        eprintln!(
            "murk: wrote {} ({} frames x {tiles} pieces: {} render tasks, {} stitch tasks)",
            job.display(),
            frames.len(),
            frames.len() * tiles,
            frames.len()
        );
    }
    Ok(())
}

/// The renders' outputs must not replace their inputs (as `murk render` would refuse on
/// the farm), and the job must replace none of the files the job reads or writes: any
/// frame's input, shadow cache, output, preview, stats or piece, or the scene.
fn check_job(
    plan: &RenderPlan,
    paths: &FramePaths,
    frames: &[i64],
    scene: Option<&Path>,
    tiles: usize,
    job: &Path,
) -> Result<()> {
    super::guard::check_sequence(plan, paths, frames, scene)?;
    let mut files = Vec::new();
    for &f in frames {
        let p = paths.plan(plan, f);
        files.extend(super::guard::plan_inputs(&p, scene, Some(f)));
        files.extend(super::guard::plan_outputs(&p, Some(f)));
        for t in 1..=tiles {
            let mut piece = p.outputs.path.clone().into_os_string();
            piece.push(format!(".piece{t}of{tiles}.exr"));
            files.push(Role::new(piece, format!("frame {f}'s piece {t}")));
        }
    }
    super::guard::check_outputs(&files, &[Role::new(job, "the job (--job)")])
}
