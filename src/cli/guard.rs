//! Checks of a render or bake plan made before any work: limits on what murk is asked to
//! do (threads, lights), and the files a command reads and writes, for the output guard
//! (`murk::output::guard`: no output replaces an input, another output, or anything but
//! a regular file). Also the wording of plan errors
//! in scene mode: they name the scene and its keys, not flags the user never typed.

use anyhow::{Result, anyhow};
use murk::output::guard::Role;
use murk::render::RenderPlan;
use murk::render::sequence::FramePaths;
use std::collections::HashSet;
use std::path::Path;

/// The most worker threads murk starts: more than any machine it runs on has cores, and
/// few enough that starting them is instant (4294967296 took 13 s before failing).
pub const MAX_THREADS: usize = 1024;

/// The most lights a render or bake takes. Each light costs a shadow map (up to the
/// bake's budget) and three float channels of the frame, so 1,000 lights took 1 GB.
pub const MAX_LIGHTS: usize = 32;

/// The most memory the frame's channels may take: width × height × channels × 4 bytes.
/// 16384 × 16384 with the default channels would be 8.6 GB, allocated before the first
/// pixel; past this murk refuses at once rather than fail an allocation later.
pub const MAX_FRAME_BYTES: f64 = 4.0 * 1024.0 * 1024.0 * 1024.0;

/// Refuses settings past murk's limits and outputs that would clobber an input, another
/// output or something other than a regular file. `scene` is the scene file, if any.
pub fn check_plan(plan: &RenderPlan, scene: Option<&Path>) -> Result<()> {
    if let Some(n) = plan.sampling.threads
        && n > MAX_THREADS
    {
        return Err(anyhow!(
            "--threads {n} is more than murk starts (at most {MAX_THREADS})"
        ));
    }
    if plan.lights.len() > MAX_LIGHTS {
        return Err(anyhow!(
            "{} lights: murk renders at most {MAX_LIGHTS} (each costs a shadow map and three channels)",
            plan.lights.len()
        ));
    }
    // Beauty (R, G, B, A), Z, emission and shadow layers, and a scatter layer per light:
    // a bound on the channels a render writes.
    let channels = 5 + 3 + 3 + 3 * plan.lights.len();
    let bytes = plan.camera.width as f64 * plan.camera.height as f64 * channels as f64 * 4.0;
    if bytes > MAX_FRAME_BYTES {
        return Err(anyhow!(
            "a {}x{} frame of up to {channels} channels needs {:.1} GiB; murk renders frames up to {} GiB (lower --res)",
            plan.camera.width,
            plan.camera.height,
            bytes / 1024f64.powi(3),
            MAX_FRAME_BYTES / 1024f64.powi(3)
        ));
    }
    let mut names = HashSet::new();
    for l in &plan.lights {
        if !names.insert(l.name.as_str()) {
            return Err(anyhow!(
                "two lights named \"{}\": each light's scatter layer is named after it",
                printable(&l.name)
            ));
        }
    }
    check_outputs(&plan_inputs(plan, scene, None), &plan_outputs(plan, None))
}

/// What a render or bake reads: the input, the scene file and the shadow cache, named
/// after `frame` when it is one frame of a sequence.
pub fn plan_inputs(plan: &RenderPlan, scene: Option<&Path>, frame: Option<i64>) -> Vec<Role> {
    let of = |what: &str| match frame {
        Some(f) => format!("frame {f}'s {what}"),
        None => format!("the {what}"),
    };
    let mut inputs = vec![Role::new(&plan.input, of("input"))];
    if let Some(s) = scene {
        inputs.push(Role::new(s, "the scene file"));
    }
    if let Some(c) = &plan.shadows.cache {
        inputs.push(Role::new(c, of("shadow cache")));
    }
    inputs
}

/// What a render or bake writes: the output, the stats (unless `-`, standard output) and
/// the preview, named after `frame` when it is one frame of a sequence.
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
            anyhow!(in_scene(s, &format!("{e:#}")))
        }
        _ => e,
    }
}

/// A plan error in scene mode: prefixed with the scene's path, and each `--flag` the user
/// did not type (so the value came from the scene) named as the scene's key `flag`.
pub fn in_scene(scene: &Path, message: &str) -> String {
    let typed: Vec<String> = std::env::args()
        .filter(|a| a.starts_with("--"))
        .map(|a| a.split('=').next().unwrap_or("").to_string())
        .collect();
    let mut out = String::with_capacity(message.len());
    let mut rest = message;
    while let Some(at) = rest.find("--") {
        out.push_str(&rest[..at]);
        let tail = &rest[at..];
        let end = tail[2..]
            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '-'))
            .map_or(tail.len(), |e| e + 2);
        let flag = &tail[..end];
        if end > 2 && !typed.iter().any(|t| t == flag) {
            out.push_str(&format!("`{}`", flag[2..].replace('-', "_")));
        } else {
            out.push_str(flag);
        }
        rest = &tail[end..];
    }
    out.push_str(rest);
    let prefix = format!("{}: ", scene.display());
    if out.starts_with(&prefix) {
        out
    } else {
        format!("{prefix}{out}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn untyped_flags_become_scene_keys() {
        let m = in_scene(Path::new("s.toml"), "--sigma-a \"x\" is not three numbers");
        assert_eq!(m, "s.toml: `sigma_a` \"x\" is not three numbers");
        assert_eq!(in_scene(Path::new("s.toml"), "s.toml: bad"), "s.toml: bad");
    }

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
