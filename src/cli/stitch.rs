//! `murk stitch`: the pieces of a frame put back together, with the whole frame's
//! preview if asked, and the pieces removed once the frame is written if asked (a farm's
//! job leaves no piece beside its outputs).

use anyhow::{Result, anyhow};
use clap::Args;
use murk::output::colorspace::convert_frame_to_rec709;
use murk::output::guard::Role;
use murk::output::{Background, ColorSpace, PreviewOptions, write_exr, write_preview};
use murk::render::sequence::frame_path;
use std::path::{Path, PathBuf};

/// `murk stitch` flags.
#[derive(Args, Debug)]
pub struct StitchArgs {
    /// Every piece of the frame, in any order.
    #[arg(required = true)]
    pub pieces: Vec<PathBuf>,
    /// The whole frame's EXR.
    #[arg(short = 'o', long = "output", value_name = "FULL.exr")]
    pub output: PathBuf,
    /// Put this frame number into the frame patterns (####, %04d, $F4) of the paths.
    #[arg(long, value_name = "N")]
    pub frame: Option<i64>,
    /// Also write an 8-bit sRGB PNG of the whole frame's beauty pass.
    #[arg(long, value_name = "FILE.png")]
    pub preview: Option<PathBuf>,
    /// Preview exposure in stops (default 0).
    #[arg(long, value_name = "STOPS", allow_hyphen_values = true)]
    pub exposure: Option<f32>,
    /// Preview background: transparent, black, checker or r,g,b (default checker).
    #[arg(long, value_name = "BG")]
    pub background: Option<String>,
    /// Delete the pieces once the whole frame is written.
    #[arg(long = "remove-pieces")]
    pub remove_pieces: bool,
    /// Another file of the frame to delete once it is written (e.g. a farm job's shadow
    /// cache); repeatable.
    #[arg(long, value_name = "FILE")]
    pub remove: Vec<PathBuf>,
    /// No report.
    #[arg(long)]
    pub quiet: bool,
}

/// `murk stitch`.
pub fn run(a: StitchArgs) -> Result<()> {
    let at = |p: &Path| match a.frame {
        Some(f) => Ok(frame_path(p, f)?),
        None => Ok(p.to_path_buf()),
    };
    let pieces: Vec<PathBuf> = a.pieces.iter().map(|p| at(p)).collect::<Result<_>>()?;
    let output = at(&a.output)?;
    let preview = match &a.preview {
        Some(p) => {
            let p = at(p)?;
            if p.extension()
                .is_some_and(|e| !e.eq_ignore_ascii_case("png"))
            {
                return Err(anyhow!(
                    "--preview {}: the preview is a PNG; name it {}",
                    p.display(),
                    p.with_extension("png").display()
                ));
            }
            let background = match &a.background {
                Some(b) => b
                    .parse::<Background>()
                    .map_err(|e| anyhow!("--background: {e}"))?,
                None => Background::Checker,
            };
            let exposure = a.exposure.unwrap_or(0.0);
            if !exposure.is_finite() {
                return Err(anyhow!("--exposure must be a finite number"));
            }
            Some((
                p,
                PreviewOptions {
                    exposure,
                    background,
                },
            ))
        }
        None => None,
    };
    let inputs: Vec<Role> = pieces.iter().map(|p| Role::new(p, "a piece")).collect();
    let mut outputs = vec![Role::new(&output, "the output (-o)")];
    outputs.extend(preview.iter().map(|(p, _)| Role::new(p, "the preview")));
    super::guard::check_outputs(&inputs, &outputs)?;
    let whole = murk::output::stitch::stitch_frame(&pieces)?;
    murk::output::prepare_place(&output)?;
    if let Some((p, _)) = &preview {
        murk::output::prepare_place(p)?;
    }
    write_exr(&output, &whole.frame, &whole.options)?;
    if let Some((p, opts)) = &preview {
        // The pieces hold the EXR's colour space; the preview shows linear Rec.709.
        match whole.options.colorspace {
            ColorSpace::LinRec709 => write_preview(p, &whole.frame, opts)?,
            space => write_preview(p, &convert_frame_to_rec709(&whole.frame, space), opts)?,
        }
    }
    let mut removed = 0;
    let extra: Vec<PathBuf> = a.remove.iter().map(|p| at(p)).collect::<Result<_>>()?;
    let doomed = pieces
        .iter()
        .filter(|_| a.remove_pieces)
        .chain(&extra)
        .filter(|p| **p != output);
    for p in doomed {
        match std::fs::remove_file(p) {
            Ok(()) => removed += 1,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(anyhow!("{}: cannot remove it: {e}", p.display())),
        }
    }
    if !a.quiet {
        eprintln!(
            "murk: wrote {} ({}x{}, {} pieces{}{})",
            output.display(),
            whole.frame.width,
            whole.frame.height,
            whole.pieces,
            preview
                .as_ref()
                .map(|(p, _)| format!(", preview {}", p.display()))
                .unwrap_or_default(),
            if removed > 0 {
                format!(", {removed} files removed")
            } else {
                String::new()
            }
        );
    }
    Ok(())
}
