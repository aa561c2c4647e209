//! What is written and which production conventions are assumed: `output`,
//! `compression`, `float`, `preview`, `exposure`, `background`, `stats`, `quiet`,
//! `z_empty`, `crop_data_window`, `colorspace`, `up_axis`.

use super::defaults;
use super::values::{up_axis_choice, z_empty};
use crate::output::{Background, ExrCompression, ExrOptions, PreviewOptions};
use crate::scene::conventions::UpAxisChoice;
use crate::scene::options::RenderOptions;
use std::path::{Path, PathBuf};

/// What is written.
#[derive(Clone, Debug)]
pub struct OutputPlan {
    /// The EXR (or, for `bake-shadows`, the cache).
    pub path: PathBuf,
    pub exr: ExrOptions,
    pub preview: Option<(PathBuf, PreviewOptions)>,
    pub stats: Option<PathBuf>,
    pub quiet: bool,
    /// `--deep`: the deep EXR and its merge tolerance (`--deep-tolerance`).
    pub deep: Option<DeepPlan>,
}

/// The deep EXR written beside the flat one.
#[derive(Clone, Debug, PartialEq)]
pub struct DeepPlan {
    pub path: PathBuf,
    pub tolerance: f64,
    /// `--deep-aovs`: the layers each sample carries too (`emission`, `scatter`,
    /// `indirect`, `lights`, `all`), as given; empty: none.
    pub aovs: Vec<String>,
}

/// The names `--deep-aovs` takes.
pub const DEEP_AOVS: [&str; 5] = ["emission", "scatter", "indirect", "lights", "all"];

/// `--deep-aovs`' list: known names, each once.
fn deep_aovs(list: Option<&str>) -> Result<Vec<String>, String> {
    let mut out: Vec<String> = Vec::new();
    for name in list.unwrap_or("").split(',').map(str::trim) {
        if name.is_empty() {
            continue;
        }
        if !DEEP_AOVS.contains(&name) {
            return Err(format!(
                "{{deep_aovs}}: {name:?} is not one of {}",
                DEEP_AOVS.join(", ")
            ));
        }
        if !out.iter().any(|n| n == name) {
            out.push(name.to_string());
        }
    }
    if list.is_some() && out.is_empty() {
        return Err(format!(
            "{{deep_aovs}} is empty: name one of {}",
            DEEP_AOVS.join(", ")
        ));
    }
    Ok(out)
}

impl OutputPlan {
    pub(super) fn from_options(o: &RenderOptions, input: &Path) -> Result<OutputPlan, String> {
        let path = o
            .output
            .clone()
            .ok_or("no output file: give -o OUT.exr (or `output` in the scene file)")?;
        let compression = match &o.compression {
            Some(c) => c.parse::<ExrCompression>().map_err(|e| e.to_string())?,
            None => ExrCompression::default(),
        };
        let preview = match &o.preview {
            Some(p) => {
                let background = match &o.background {
                    Some(b) => b.parse::<Background>().map_err(|e| e.to_string())?,
                    None => Background::Checker,
                };
                let exposure = o.exposure.unwrap_or(defaults::EXPOSURE);
                if !exposure.is_finite() {
                    return Err("{exposure} must be a finite number".into());
                }
                Some((
                    p.clone(),
                    PreviewOptions {
                        exposure,
                        background,
                    },
                ))
            }
            None => None,
        };
        let tolerance = o.deep_tolerance.unwrap_or(defaults::DEEP_TOLERANCE);
        if !(0.0..1.0).contains(&tolerance) {
            return Err(format!(
                "{{deep_tolerance}} must be at least 0 and below 1 (an opacity), not {tolerance}"
            ));
        }
        let aovs = deep_aovs(o.deep_aovs.as_deref())?;
        if !aovs.is_empty() && o.deep.is_none() {
            return Err(
                "{deep_aovs} adds channels to the deep file: give {deep} FILE.exr too".into(),
            );
        }
        let deep = o.deep.as_ref().map(|p| DeepPlan {
            path: p.clone(),
            tolerance,
            aovs,
        });
        if deep.as_ref().is_some_and(|d| d.path == path) {
            return Err(
                "{deep} names the same file as the flat EXR (-o); give it its own name".into(),
            );
        }
        Ok(OutputPlan {
            deep,
            path,
            exr: ExrOptions {
                compression,
                float: o.float,
                input_file: Some(input.display().to_string()),
                z_empty: z_empty(&o.z_empty)?,
                crop_data_window: o.crop_data_window,
                colorspace: match &o.colorspace {
                    Some(c) => c.parse()?,
                    None => crate::output::ColorSpace::default(),
                },
                ..ExrOptions::default()
            },
            preview,
            stats: o.stats.clone(),
            quiet: o.quiet,
        })
    }
}

/// Refuses a frame whose channels would not fit in [`defaults::MAX_FRAME_BYTES`].
pub(super) fn check_frame_size(width: usize, height: usize, lights: usize) -> Result<(), String> {
    // Beauty (R, G, B, A), Z, emission and shadow layers, and a scatter layer per light:
    // a bound on the channels a render writes.
    let channels = 5 + 3 + 3 + 3 * lights;
    let bytes = width as f64 * height as f64 * channels as f64 * 4.0;
    if bytes > defaults::MAX_FRAME_BYTES {
        return Err(format!(
            "a {width}x{height} frame of up to {channels} channels needs {:.1} GiB; murk renders frames up to {} GiB (lower {{res}})",
            bytes / 1024f64.powi(3),
            defaults::MAX_FRAME_BYTES / 1024f64.powi(3)
        ));
    }
    Ok(())
}

/// Production caches: which conventions are assumed, and what the user fixed.
#[derive(Clone, Debug, PartialEq)]
pub struct ProductionPlan {
    /// `--up-axis`.
    pub up_axis: UpAxisChoice,
    /// `--up` was given: the camera's up is not the world's.
    pub up_explicit: bool,
    /// `--temperature-scale` or `--temperature-offset` was given: no convention is
    /// detected.
    pub temperature_explicit: bool,
    /// The scene names no light: the default sun, which follows the up axis.
    pub default_light: bool,
    /// `--holdout-depth` or `--holdout-deep`: the image that cuts the volume.
    pub holdout: Option<crate::scene::holdout::HoldoutSpec>,
}

impl ProductionPlan {
    pub(super) fn from_options(o: &RenderOptions) -> Result<ProductionPlan, String> {
        Ok(ProductionPlan {
            up_axis: up_axis_choice(&o.up_axis)?,
            up_explicit: o.up.is_some(),
            temperature_explicit: o.temperature_scale.is_some() || o.temperature_offset.is_some(),
            default_light: !o.no_lights && o.lights.is_empty() && o.light.is_empty(),
            holdout: match (&o.holdout_depth, &o.holdout_deep) {
                (Some(_), Some(_)) => {
                    return Err("{holdout_depth} and {holdout_deep}: one holdout at a time".into());
                }
                (Some(d), None) => Some(crate::scene::holdout::HoldoutSpec::parse(d)?),
                (None, Some(d)) => Some(crate::scene::holdout::HoldoutSpec::deep(d)?),
                (None, None) => None,
            },
        })
    }
}
