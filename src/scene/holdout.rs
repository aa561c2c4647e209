//! Holdouts: a depth image from the render's own camera (`--holdout-depth
//! FILE.exr[:CHANNEL]`, the CG render's `Z`) or a deep image (`--holdout-deep`, read by
//! [`super::holdout_deep`]), where the volume is cut. Read before anything is rendered,
//! checked against the output's size and for NaN depths.

use exr::prelude::{FlatSamples, read_all_flat_layers_from_file};
use std::path::{Path, PathBuf};

/// The channels a depth is looked for in, when none is named: murk's and most
/// renderers' `Z`, a `depth` layer's, and Cycles' `Depth.Z`.
pub const DEPTH_CHANNELS: [&str; 3] = ["Z", "depth.Z", "Depth.Z"];

/// `--holdout-depth` (the file and, if named, its channel) or `--holdout-deep`.
#[derive(Clone, Debug, PartialEq)]
pub struct HoldoutSpec {
    pub path: PathBuf,
    pub channel: Option<String>,
    /// A deep image (`--holdout-deep`).
    pub deep: bool,
}

impl HoldoutSpec {
    /// `--holdout-deep FILE.exr`.
    pub fn deep(text: &str) -> Result<HoldoutSpec, String> {
        if text.is_empty() {
            return Err("{holdout_deep} needs a file: FILE.exr".into());
        }
        Ok(HoldoutSpec {
            path: text.into(),
            channel: None,
            deep: true,
        })
    }

    /// The flag that gave it.
    pub fn flag(&self) -> &'static str {
        if self.deep {
            "--holdout-deep"
        } else {
            "--holdout-depth"
        }
    }

    /// `FILE.exr` or `FILE.exr:CHANNEL` (a file whose whole name exists is taken whole).
    pub fn parse(text: &str) -> Result<HoldoutSpec, String> {
        if text.is_empty() {
            return Err("{holdout_depth} needs a file: FILE.exr[:CHANNEL]".into());
        }
        if !Path::new(text).exists()
            && let Some((file, channel)) = text.rsplit_once(':')
            && !file.is_empty()
        {
            if channel.is_empty() {
                return Err(format!(
                    "{{holdout_depth}} {text}: no channel after `:` (FILE.exr:CHANNEL)"
                ));
            }
            return Ok(HoldoutSpec {
                path: file.into(),
                channel: Some(channel.into()),
                deep: false,
            });
        }
        Ok(HoldoutSpec {
            path: text.into(),
            channel: None,
            deep: false,
        })
    }
}

/// A depth per output pixel, row-major (`+inf`: nothing held out there).
#[derive(Clone, Debug, PartialEq)]
pub struct Holdout {
    pub depths: Vec<f32>,
}

/// Reads the holdout's depths for a `width`×`height` frame, `overscan` (x, y) of it
/// beyond the image on each side: the holdout's displayWindow is the image, and its
/// data window may cover the overscan too. Errors say what is wrong with the file in
/// one line (the caller names it).
pub fn load(
    spec: &HoldoutSpec,
    width: usize,
    height: usize,
    overscan: (usize, usize),
) -> Result<Holdout, String> {
    if spec.deep {
        return super::holdout_deep::load(&spec.path, width, height, overscan)
            .map(|depths| Holdout { depths });
    }
    let meta = exr::meta::MetaData::read_from_file(&spec.path, false)
        .map_err(|e| format!("not a readable EXR: {e}"))?;
    let Some(header) = meta.headers.first() else {
        return Err("an EXR without a header".into());
    };
    if header.deep {
        return Err(
            "a deep image; --holdout-depth takes a flat depth image (--holdout-deep a deep one)"
                .into(),
        );
    }
    let display = header.shared_attributes.display_window.size;
    let image = (
        width.saturating_sub(2 * overscan.0),
        height.saturating_sub(2 * overscan.1),
    );
    if (display.0, display.1) != image {
        return Err(format!(
            "its image is {}x{}, the render {}x{}: a holdout comes from the same camera at the same size",
            display.0, display.1, image.0, image.1
        ));
    }
    let image = read_all_flat_layers_from_file(&spec.path).map_err(|e| e.to_string())?;
    let origin = image.attributes.display_window.position;
    let wanted: Vec<&str> = match &spec.channel {
        Some(c) => vec![c.as_str()],
        None => DEPTH_CHANNELS.to_vec(),
    };
    let found = image.layer_data.iter().find_map(|layer| {
        wanted.iter().find_map(|name| {
            let full =
                |c: &exr::prelude::AnyChannel<FlatSamples>| match &layer.attributes.layer_name {
                    Some(l) => format!("{l}.{}", c.name),
                    None => c.name.to_string(),
                };
            layer
                .channel_data
                .list
                .iter()
                .find(|c| full(c) == *name || c.name.to_string() == *name)
                .map(|c| (layer, c, *name))
        })
    });
    let Some((layer, channel, name)) = found else {
        return Err(match &spec.channel {
            Some(c) => format!("no channel `{c}`"),
            None => format!(
                "no depth channel (looked for {})",
                DEPTH_CHANNELS.join(", ")
            ),
        });
    };
    let values: Vec<f32> = match &channel.sample_data {
        FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
        FlatSamples::F32(v) => v.clone(),
        FlatSamples::U32(v) => v.iter().map(|&u| u as f32).collect(),
    };
    let size = layer.size;
    let pos = layer.attributes.layer_position;
    let mut depths = vec![f32::INFINITY; width * height];
    let mut nan = None;
    for ly in 0..size.1 {
        for lx in 0..size.0 {
            let v = values[ly * size.0 + lx];
            let (x, y) = (
                pos.0 as i64 - origin.0 as i64 + lx as i64 + overscan.0 as i64,
                pos.1 as i64 - origin.1 as i64 + ly as i64 + overscan.1 as i64,
            );
            if v.is_nan() {
                nan.get_or_insert((x, y));
            }
            if (0..width as i64).contains(&x) && (0..height as i64).contains(&y) {
                depths[y as usize * width + x as usize] = v;
            }
        }
    }
    if let Some((x, y)) = nan {
        return Err(format!(
            "channel `{name}` holds NaN depths (the first at pixel {x},{y}); give every pixel a depth (+inf where nothing is)"
        ));
    }
    Ok(Holdout { depths })
}
