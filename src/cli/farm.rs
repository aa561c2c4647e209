//! `murk farm openjd`: an Open Job Description job template (specification 2023-09, the
//! format AWS Deadline Cloud runs) for a sequence. Whole frames: a `Render` step with a
//! task per frame. Frames in pieces (`--tiles N`): a `Bake` step baking each frame's
//! deep shadow maps once, a `Render` step with a task per frame and piece reading them,
//! and a `Stitch` step putting each frame's pieces together (with its preview) and
//! removing the pieces and the maps. Frames are range expressions (`1001-2100`), which
//! hold any number of frames. Paths are job parameters, so a farm can remap them, each
//! with a default: what was given here, relative to the template's folder.

use super::args::{BakeArgs, RenderArgs};
use anyhow::{Result, anyhow};
use clap::{Args, Subcommand};
use murk::output::guard::Role;
use murk::render::RenderPlan;
use murk::render::sequence::{FramePaths, choose_frames};
use murk::scene::frames::frame_ranges;
use murk::scene::plan::ShadowMode;
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
        /// stitched.
        #[arg(long, value_name = "N", default_value_t = 1)]
        tiles: usize,
        /// The job template to write (JSON, which is YAML too).
        #[arg(long, value_name = "JOB.yaml")]
        job: PathBuf,
    },
}

pub const EXAMPLES: &str = "Examples:
  murk farm openjd 'cache/fluid_####.vdb' --frames 1-250 -o 'render/fluid_####.exr' --preview 'render/fluid_####.png' --job job.yaml
  murk farm openjd 'cache/fluid_####.vdb' --frames 1-250 --tiles 4 --res 1920x1080 -o 'render/fluid_####.exr' --job job.yaml

Run a job with `openjd check job.yaml && openjd run job.yaml --step Render` (whole frames)
or `openjd run job.yaml --step Stitch --run-dependencies` (frames in pieces); output
folders are made by the tasks.";

/// The flags of `murk render` that the template sets itself: the paths (job
/// parameters), the frames and pieces (task parameters), `--quiet`, and this command's
/// own. A user's are not forwarded (twice, `murk render` refuses them).
const SET_BY_THE_TEMPLATE: [&str; 12] = [
    "-o",
    "--camera-file",
    "--output",
    "--stats",
    "--preview",
    "--shadow-cache",
    "--frames",
    "--tile",
    "--tiles",
    "--job",
    "--skip-existing",
    "--quiet",
];

/// The flags of `raw` (this command's arguments after `farm openjd`) forwarded verbatim
/// to a task: those `keep` accepts, without the input and the flags the template sets.
fn forwarded_flags(raw: &[String], input: &Path, keep: &dyn Fn(&str) -> bool) -> Vec<String> {
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
    let mut out = Vec::new();
    let mut input_seen = false;
    let mut i = 0;
    while i < raw.len() {
        let a = &raw[i];
        let flag = a.split_once('=').map_or(a.as_str(), |(f, _)| f);
        let with_value = a.starts_with('-') && !a.contains('=') && takes_value(flag);
        let forward = if !a.starts_with('-') && !input_seen && Path::new(a) == input {
            input_seen = true;
            false
        } else {
            !SET_BY_THE_TEMPLATE.contains(&flag) && keep(flag)
        };
        if forward {
            out.push(a.clone());
            if with_value && i + 1 < raw.len() {
                out.push(raw[i + 1].clone());
            }
        }
        i += if with_value { 2 } else { 1 };
    }
    out
}

/// Whether `flag` is one `murk bake-shadows` takes.
fn is_bake_flag(flag: &str) -> bool {
    let cmd = BakeArgs::augment_args(clap::Command::new("x"));
    cmd.get_arguments().any(|a| {
        a.get_long().is_some_and(|l| flag == format!("--{l}"))
            || a.get_short().is_some_and(|s| flag == format!("-{s}"))
    })
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

/// Refuses `text` (`what` names it) when it holds `{{` or `}}`: Open Job Description
/// reads them in a template's names and command arguments as the bounds of an
/// expression, so the job would not run what was given here.
fn no_expression(text: &str, what: &str) -> Result<()> {
    if text.contains("{{") || text.contains("}}") {
        return Err(anyhow!(
            "{what}: \"{{{{\" and \"}}}}\" would be read by Open Job Description as an expression; rename it without double braces"
        ));
    }
    Ok(())
}

fn on_run(args: Vec<String>) -> Value {
    json!({ "actions": { "onRun": { "command": "{{Param.Murk}}", "args": args } } })
}

/// The job's command lines, as built from the arguments and the plan.
struct Tasks {
    /// Per frame, before the renders: one shadow-map bake shared by the frame's pieces.
    bake: Option<Vec<String>>,
    render: Vec<String>,
    /// Per frame, after its pieces: none with one piece (the render writes the frame).
    stitch: Option<Vec<String>>,
}

/// What the job's tasks need to know besides the forwarded flags.
struct Job<'a> {
    tiles: usize,
    /// Whether the frame number goes into `murk stitch` (a pattern or several frames).
    per_frame: bool,
    stats: bool,
    preview: bool,
    shadow_cache: bool,
    camera_file: bool,
    /// Whether a bake per frame is shared by its pieces.
    share_bake: bool,
    /// The preview's exposure and background, for `murk stitch`.
    look: &'a [String],
}

/// The task command lines; `raw` are the user's arguments, `input` the input as given.
fn tasks(raw: &[String], input: &Path, job: &Job) -> Tasks {
    let tiles = job.tiles;
    let frame = || ["--frames".to_string(), "{{Task.Param.Frame}}".into()];
    let mut render: Vec<String> = vec!["render".into(), "{{Param.Input}}".into()];
    render.extend(frame());
    let whole = tiles == 1;
    let piece = |tile: &str| format!("{{{{Param.Output}}}}.piece{tile}of{tiles}.exr");
    let shadows = "{{Param.Output}}.shadows.vdb".to_string();
    if whole {
        render.extend(["-o".into(), "{{Param.Output}}".into()]);
    } else {
        render.extend([
            "--tile".into(),
            format!("{{{{Task.Param.Tile}}}}/{tiles}"),
            "-o".into(),
            piece("{{Task.Param.Tile}}"),
        ]);
    }
    let mut param = |on: bool, flag: &str, name: &str| {
        if on {
            render.extend([flag.to_string(), format!("{{{{Param.{name}}}}}")]);
        }
    };
    param(job.stats && whole, "--stats", "Stats");
    param(job.preview && whole, "--preview", "Preview");
    param(job.shadow_cache, "--shadow-cache", "ShadowCache");
    param(job.camera_file, "--camera-file", "CameraFile");
    let bake = (job.share_bake && !whole).then(|| {
        let mut bake: Vec<String> = vec![
            "bake-shadows".into(),
            "{{Param.Input}}".into(),
            "--frame".into(),
            "{{Task.Param.Frame}}".into(),
            "-o".into(),
            shadows.clone(),
            "--quiet".into(),
        ];
        bake.extend(forwarded_flags(raw, input, &is_bake_flag));
        bake
    });
    if bake.is_some() {
        render.extend(["--shadow-cache".into(), shadows.clone()]);
    }
    render.push("--quiet".into());
    render.extend(forwarded_flags(raw, input, &|_| true));
    let stitch = (!whole).then(|| {
        let mut stitch: Vec<String> = vec!["stitch".into()];
        if job.per_frame {
            stitch.extend(["--frame".into(), "{{Task.Param.Frame}}".into()]);
        }
        stitch.extend((1..=tiles).map(|t| piece(&t.to_string())));
        stitch.extend(["-o".into(), "{{Param.Output}}".into()]);
        if job.preview {
            stitch.extend(["--preview".into(), "{{Param.Preview}}".into()]);
            stitch.extend(job.look.iter().cloned());
        }
        stitch.push("--remove-pieces".into());
        if bake.is_some() {
            stitch.extend(["--remove".into(), shadows.clone()]);
        }
        stitch.push("--quiet".into());
        stitch
    });
    Tasks {
        bake,
        render,
        stitch,
    }
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
    for a in &raw {
        no_expression(a, a)?;
    }
    let (merged, vdb) = super::render::options_for(input, options.options())?;
    if merged.output.is_none() {
        return Err(anyhow!(
            "-o: name the frames' output, e.g. -o 'render/fluid_####.exr'"
        ));
    }
    super::render::check_output_names(&merged)?;
    let plan = RenderPlan::new(&merged, vdb).map_err(|e| anyhow!("{e}"))?;
    if tiles > plan.camera.height {
        return Err(anyhow!(
            "--tiles {tiles}: more pieces than the image's {} rows",
            plan.camera.height
        ));
    }
    // Paths may come from a scene file too.
    let given = [
        Some(&plan.input),
        Some(&plan.outputs.path),
        merged.stats.as_ref(),
        merged.preview.as_ref(),
        merged.shadow_cache.as_ref(),
        merged.camera_file.as_ref(),
    ];
    for p in given.into_iter().flatten() {
        no_expression(&p.to_string_lossy(), &p.display().to_string())?;
    }
    let paths = FramePaths::of(&plan);
    let frames = choose_frames(&paths, &plan, merged.frames.as_deref())?;
    if tiles > 1 && merged.stats.is_some() {
        return Err(anyhow!(
            "--stats describes a whole render, not a piece: give it without --tiles"
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
    for (name, flag, path, flow) in [
        ("Stats", "--stats", &merged.stats, "OUT"),
        ("Preview", "--preview", &merged.preview, "OUT"),
        ("ShadowCache", "--shadow-cache", &merged.shadow_cache, "IN"),
        ("CameraFile", "--camera-file", &merged.camera_file, "IN"),
    ] {
        if let Some(p) = path {
            params.push(path_param(name, p, &job_dir, flow, flag)?);
        }
    }
    let mut look = Vec::new();
    if let Some(e) = merged.exposure {
        look.extend(["--exposure".to_string(), e.to_string()]);
    }
    if let Some(b) = &merged.background {
        look.extend(["--background".to_string(), b.clone()]);
    }
    // A bake shared by a frame's pieces must be the bake each would make: not when the
    // render chooses the tolerance (--max-error) or flags bake-shadows lacks decide
    // the lights (--up-axis), nor without a deep shadow map to bake, nor with an
    // environment light (bake-shadows, with no --scattering path, refuses one).
    let share_bake = plan.shadows.mode == ShadowMode::Dsm
        && !plan.lights.is_empty()
        && plan.transport.environment.is_none()
        && merged.shadow_cache.is_none()
        && merged.max_error.is_none()
        && merged.up_axis.is_none();
    let spec = Job {
        tiles,
        per_frame: paths.output.is_pattern() || frames.len() > 1,
        stats: merged.stats.is_some(),
        preview: merged.preview.is_some(),
        shadow_cache: merged.shadow_cache.is_some(),
        camera_file: merged.camera_file.is_some(),
        share_bake,
        look: &look,
    };
    let tasks = tasks(&raw, input, &spec);
    // A range expression, not a list: a list holds at most 1,024 values.
    let frame_param =
        json!({ "name": "Frame", "type": "INT", "range": frame_ranges(&frames, ":") });
    let name = format!(
        "murk {}",
        input.file_name().unwrap_or_default().to_string_lossy()
    );
    let mut steps = Vec::new();
    if let Some(bake) = tasks.bake {
        steps.push(json!({
            "name": "Bake",
            "parameterSpace": { "taskParameterDefinitions": [frame_param] },
            "script": on_run(bake),
        }));
    }
    let mut render = json!({
        "name": "Render",
        "parameterSpace": {
            "taskParameterDefinitions": if tiles == 1 {
                json!([frame_param])
            } else {
                json!([frame_param, { "name": "Tile", "type": "INT", "range": format!("1-{tiles}") }])
            },
        },
        "script": on_run(tasks.render),
    });
    if !steps.is_empty() {
        render["dependencies"] = json!([{ "dependsOn": "Bake" }]);
    }
    steps.push(render);
    if let Some(stitch) = tasks.stitch {
        steps.push(json!({
            "name": "Stitch",
            "dependencies": [{ "dependsOn": "Render" }],
            "parameterSpace": { "taskParameterDefinitions": [frame_param] },
            "script": on_run(stitch),
        }));
    }
    let n = frames.len();
    let template = json!({
        "specificationVersion": "jobtemplate-2023-09",
        "name": name,
        "description": format!(
            "murk render of {n} frames in {tiles} piece(s) each. Made by murk farm openjd."
        ),
        "parameterDefinitions": params,
        "steps": steps,
    });
    let text = serde_json::to_string_pretty(&template)? + "\n";
    murk::output::write_atomically(job, |tmp| {
        std::fs::write(tmp, text.as_bytes()).map_err(|e| anyhow!("{}: {e}", job.display()))
    })?;
    if !merged.quiet {
        let mut what = vec![format!("{} render tasks", n * tiles)];
        if share_bake && tiles > 1 {
            what.insert(0, format!("{n} shadow bakes"));
        }
        if tiles > 1 {
            what.push(format!("{n} stitch tasks"));
        }
        eprintln!(
            "murk: wrote {} ({n} frames x {tiles} pieces: {})",
            job.display(),
            what.join(", ")
        );
    }
    Ok(())
}

/// The renders' outputs must not replace their inputs (as `murk render` would refuse on
/// the farm), and the job must replace none of the files the job reads or writes: any
/// frame's input, shadow cache, output, preview, stats, piece or shared shadow maps, or
/// the scene.
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
        // With pieces: each piece, and the frame's shared shadow maps.
        let beside = |suffix: String| {
            let mut path = p.outputs.path.clone().into_os_string();
            path.push(suffix);
            PathBuf::from(path)
        };
        if tiles > 1 {
            for t in 1..=tiles {
                let piece = beside(format!(".piece{t}of{tiles}.exr"));
                files.push(Role::new(piece, format!("frame {f}'s piece {t}")));
            }
            let maps = beside(".shadows.vdb".into());
            files.push(Role::new(maps, format!("frame {f}'s shadow maps")));
        }
    }
    super::guard::check_outputs(&files, &[Role::new(job, "the job (--job)")])
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    /// A task's command line as a worker runs it: the parameters filled in.
    fn filled(task: &[String]) -> Vec<String> {
        let values = [
            ("{{Param.Input}}", "cache/f_####.vdb"),
            ("{{Param.Output}}", "render/f_####.exr"),
            ("{{Param.Stats}}", "render/f_####.json"),
            ("{{Param.Preview}}", "render/f_####.png"),
            ("{{Param.ShadowCache}}", "cache/shadows_####.vdb"),
            ("{{Param.CameraFile}}", "shot.chan"),
            ("{{Task.Param.Frame}}", "7"),
            ("{{Task.Param.Tile}}", "2"),
        ];
        let fill = |a: &String| {
            values
                .iter()
                .fold(a.clone(), |a, (from, to)| a.replace(from, to))
        };
        std::iter::once("murk".to_string())
            .chain(task.iter().map(fill))
            .collect()
    }

    /// Every flag of `murk render` a user may give `murk farm openjd`, with and without
    /// pieces and the optional outputs: every task's command line is one `murk` takes
    /// (a flag the template sets too, such as --quiet, was refused by every task).
    #[test]
    fn every_flag_a_user_passes_through_gives_tasks_murk_accepts() {
        let cmd = RenderArgs::augment_args(clap::Command::new("x"));
        let input = Path::new("cache/f_####.vdb");
        let look = ["--exposure".to_string(), "-1".to_string()];
        let mut tried = 0;
        for arg in cmd.get_arguments() {
            let Some(long) = arg.get_long() else {
                continue;
            };
            let mut raw = vec![input.display().to_string(), format!("--{long}")];
            if arg.get_action().takes_values() {
                // A value clap takes: a listed one, the first word of a value name
                // such as `hg|water-drop`, else a number.
                let value = arg
                    .get_possible_values()
                    .first()
                    .map(|v| v.get_name().to_string())
                    .or_else(|| {
                        let names = arg.get_value_names()?;
                        let word = names.first()?.split('|').next()?;
                        word.chars()
                            .all(|c| c.is_ascii_lowercase() || c == '-')
                            .then(|| word.to_string())
                    })
                    .unwrap_or_else(|| "1".to_string());
                raw.push(value);
            }
            raw.extend(["-o", "render/f_####.exr", "--job", "job.yaml"].map(String::from));
            for tiles in [1, 3] {
                for (outputs, share_bake) in [(false, true), (true, false)] {
                    let job = Job {
                        tiles,
                        per_frame: true,
                        stats: outputs,
                        preview: outputs,
                        shadow_cache: outputs,
                        camera_file: outputs,
                        share_bake,
                        look: &look,
                    };
                    let t = tasks(&raw, input, &job);
                    assert_eq!(
                        t.stitch.is_some(),
                        tiles > 1,
                        "a Stitch step only for pieces"
                    );
                    assert_eq!(t.bake.is_some(), tiles > 1 && share_bake);
                    for task in [Some(t.render), t.bake, t.stitch].into_iter().flatten() {
                        let line = filled(&task);
                        if let Err(e) = crate::cli::Cli::try_parse_from(&line) {
                            panic!("--{long}, tiles {tiles}: murk {}: {e}", line[1..].join(" "));
                        }
                    }
                }
            }
            tried += 1;
        }
        assert!(tried > 40, "{tried} flags");
    }
}
