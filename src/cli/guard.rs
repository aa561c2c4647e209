//! Checks of a render or bake plan made before any work: limits on what murk is asked to
//! do (threads, lights), and outputs that must not replace what they should not (an
//! input, another output, anything but a regular file). Also the wording of plan errors
//! in scene mode: they name the scene and its keys, not flags the user never typed.

use anyhow::{Result, anyhow};
use murk::render::{RenderOptions, RenderPlan};
use murk::scene::{PlanError, flag_name};
use std::path::{Path, PathBuf};

/// Refuses outputs that would clobber an input, another output or something other than
/// a regular file. `scene` is the scene file, if any. (Limits on what a render may ask
/// for are the plan's.)
pub fn check_plan(plan: &RenderPlan, scene: Option<&Path>) -> Result<()> {
    let mut inputs: Vec<(&Path, &str)> = vec![(plan.input.as_path(), "the input")];
    if let Some(s) = scene {
        inputs.push((s, "the scene file"));
    }
    if let Some(c) = &plan.shadows.cache {
        inputs.push((c.as_path(), "the shadow cache"));
    }
    let mut outputs: Vec<(&Path, &str)> = vec![(plan.outputs.path.as_path(), "the output (-o)")];
    if let Some(p) = &plan.outputs.stats {
        outputs.push((p.as_path(), "the stats file"));
    }
    if let Some((p, _)) = &plan.outputs.preview {
        outputs.push((p.as_path(), "the preview"));
    }
    for (i, (out, what)) in outputs.iter().enumerate() {
        check_replaceable(out)?;
        let id = identity(out);
        for (other, role) in inputs.iter().chain(&outputs[..i]) {
            if identity(other) == id {
                return Err(anyhow!(
                    "{}: {what} would overwrite {role} ({})",
                    out.display(),
                    other.display()
                ));
            }
        }
    }
    Ok(())
}

/// An output path must be absent or a writable regular file: murk replaces it by
/// renaming a new file over it, which would turn a device or FIFO into a file and
/// replace a symbolic link rather than what it points to.
fn check_replaceable(path: &Path) -> Result<()> {
    let meta = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(_) => return Ok(()),
    };
    let ft = meta.file_type();
    let problem = if ft.is_symlink() {
        "is a symbolic link: murk replaces only regular files (give the link's target)"
    } else if ft.is_dir() {
        "is a directory"
    } else if !ft.is_file() {
        "is not a regular file (a device, FIFO or socket): murk replaces only regular files"
    } else if meta.permissions().readonly() {
        "is read-only: murk does not replace it"
    } else {
        return Ok(());
    };
    Err(anyhow!("{}: {problem}", path.display()))
}

/// What a path refers to: its device and inode if it exists, else its folder's canonical
/// path joined with its name (two spellings of one absent file compare equal).
#[derive(PartialEq, Eq, Debug)]
enum Identity {
    Inode(u64, u64),
    Path(PathBuf),
}

fn identity(path: &Path) -> Identity {
    use std::os::unix::fs::MetadataExt;
    if let Ok(m) = std::fs::metadata(path) {
        return Identity::Inode(m.dev(), m.ino());
    }
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let dir = std::fs::canonicalize(parent).unwrap_or_else(|_| parent.to_path_buf());
    Identity::Path(dir.join(path.file_name().unwrap_or_default()))
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
