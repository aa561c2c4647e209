//! Checks of a render or bake plan made before any work: the files a command reads and
//! writes, for the output guard (`murk::output::guard`: no output replaces an input,
//! another output, or anything but a regular file). Also the wording of plan errors
//! in scene mode: they name the scene and its keys, not flags the user never typed.

use anyhow::{Result, anyhow};
use murk::output::guard::Role;
use murk::render::sequence::FramePaths;
use murk::render::{RenderOptions, RenderPlan};
use murk::scene::{PlanError, flag_name};
use std::path::Path;

/// Refuses outputs that would clobber an input, another output or something other than
/// a regular file in a writable folder (see `murk::output::guard`). `scene` is the scene
/// file, if any. (Limits on what a render may ask
/// for are the plan's.)
pub fn check_plan(plan: &RenderPlan, scene: Option<&Path>) -> Result<()> {
    check_outputs(&plan_inputs(plan, scene, None), &plan_outputs(plan, None))
}

/// What a render or bake reads: the input, the scene file, the shadow cache and the
/// holdout, named
/// after `frame` when it is one frame of a sequence.
pub fn plan_inputs(plan: &RenderPlan, scene: Option<&Path>, frame: Option<i64>) -> Vec<Role> {
    let of = |what: &str| match frame {
        Some(f) => format!("frame {f}'s {what}"),
        None => format!("the {what}"),
    };
    let mut inputs = vec![Role::new(&plan.input, of("input"))];
    // A scene's other [[volume]] files (the first is the input).
    for v in plan.volumes.iter().flat_map(|v| v.list.iter().skip(1)) {
        inputs.push(Role::new(&v.file, of(&format!("volume \"{}\"", v.name))));
    }
    if let Some(s) = scene {
        inputs.push(Role::new(s, "the scene file"));
    }
    if let Some(c) = &plan.shadows.cache {
        inputs.push(Role::new(c, of("shadow cache")));
    }
    if let Some(h) = &plan.production.holdout {
        inputs.push(Role::new(
            &h.path,
            if h.deep {
                "the holdout (--holdout-deep)"
            } else {
                "the holdout (--holdout-depth)"
            },
        ));
    }
    inputs
}

/// What a render or bake writes: the output, the stats (unless `-`, standard output), the
/// preview and the deep EXR, named after `frame` when it is one frame of a sequence.
pub fn plan_outputs(plan: &RenderPlan, frame: Option<i64>) -> Vec<Role> {
    let of = |what: &str| match frame {
        Some(f) => format!("frame {f}'s {what}"),
        None => format!("the {what}"),
    };
    let mut outputs = vec![Role::new(&plan.outputs.path, of("output (-o)"))];
    if let Some(p) = plan.outputs.stats.as_ref().filter(|p| p.as_os_str() != "-") {
        outputs.push(Role::new(p, of("stats file")));
    }
    if let Some((p, _)) = &plan.outputs.preview {
        outputs.push(Role::new(p, of("preview")));
    }
    if let Some(d) = &plan.outputs.deep {
        outputs.push(Role::new(&d.path, of("deep EXR (--deep)")));
    }
    outputs
}

/// The outputs of every frame of a sequence against the inputs of every frame (frame 1's
/// output may be frame 1001's input), before the first frame.
pub fn check_sequence(
    plan: &RenderPlan,
    paths: &FramePaths,
    frames: &[i64],
    scene: Option<&Path>,
) -> Result<()> {
    let (mut inputs, mut outputs) = (Vec::new(), Vec::new());
    for &f in frames {
        let p = paths.plan(plan, f);
        inputs.extend(plan_inputs(&p, scene, Some(f)));
        outputs.extend(plan_outputs(&p, Some(f)));
    }
    check_outputs(&inputs, &outputs)
}

/// [`murk::output::guard::check_outputs`], as a command's error.
pub fn check_outputs(inputs: &[Role], outputs: &[Role]) -> Result<()> {
    murk::output::guard::check_outputs(inputs, outputs).map_err(|e| anyhow!("{e}"))
}

/// `s` with control characters escaped (`\u{1b}`), as text from files is printed.
pub fn printable(s: &str) -> String {
    s.chars()
        .flat_map(|c| {
            if c.is_control() {
                c.escape_default().collect::<Vec<_>>()
            } else {
                vec![c]
            }
        })
        .collect()
}

/// A message as printed: control characters escaped (whatever file text it quotes), and
/// numbers of more than 24 digits (an f64 near its limits printed plainly; 64-bit
/// integers such as byte offsets have at most 20) in scientific notation.
pub fn message_text(s: &str) -> String {
    let s = printable(s);
    let mut out = String::with_capacity(s.len());
    let mut rest = s.as_str();
    while let Some(start) = rest.find(|c: char| c.is_ascii_digit()) {
        let (before, from) = rest.split_at(start);
        let len = from
            .find(|c: char| !(c.is_ascii_digit() || c == '.'))
            .unwrap_or(from.len());
        let number = from[..len].trim_end_matches('.');
        let digits = number.chars().filter(char::is_ascii_digit).count();
        out.push_str(before);
        match number.parse::<f64>() {
            Ok(v) if digits > 24 => out.push_str(&murk::vdb::guard::number_text(v)),
            _ => out.push_str(number),
        }
        rest = &from[number.len()..];
    }
    out.push_str(rest);
    out
}

/// An error of a render or bake in scene mode, named after the scene when it names no
/// file (the input's errors name the input).
pub fn name_scene(e: anyhow::Error, scene: Option<&Path>, input: &Path) -> anyhow::Error {
    match scene {
        Some(s) if !e.to_string().contains(&*input.to_string_lossy()) => {
            anyhow!(with_prefix(s, &format!("{e:#}")))
        }
        _ => e,
    }
}

/// A plan error as printed: each option named as the user gave it — a flag they typed
/// (`--sigma-a`, set in `flags`) or, in scene mode, the scene file's key (`sigma_a`),
/// prefixed with the scene's path.
pub fn plan_error_text(e: &PlanError, flags: &RenderOptions, scene: Option<&Path>) -> String {
    match scene {
        None => e.to_string(),
        Some(s) => with_prefix(
            s,
            &e.named(&|key| {
                if flags.is_given(key) {
                    flag_name(key)
                } else {
                    format!("`{key}`")
                }
            }),
        ),
    }
}

/// `message` prefixed with the scene's path, once.
fn with_prefix(scene: &Path, message: &str) -> String {
    let prefix = format!("{}: ", scene.display());
    if message.starts_with(&prefix) {
        message.to_string()
    } else {
        format!("{prefix}{message}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_numbers_are_compact() {
        let huge = format!("--density-scale must be a positive number, not {}", -1e308);
        assert_eq!(
            message_text(&huge),
            "--density-scale must be a positive number, not -1e308"
        );
        assert_eq!(message_text("grid 12 at byte 3.5."), "grid 12 at byte 3.5.");
        let offset = "byte 9223372036854775807 of f-9223372036854775808.vdb";
        assert_eq!(message_text(offset), offset);
    }

    #[test]
    fn control_characters_are_escaped() {
        assert_eq!(printable("a\u{1b}[31mb\n"), "a\\u{1b}[31mb\\n");
    }
}
