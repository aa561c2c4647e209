//! `murk stitch`: the pieces of a frame rendered with `--tile I/N` put back together into
//! the EXR the one-piece render writes (the same pixels, channels, storage and data
//! window). Pieces of different frames or sizes, a piece twice or missing: refused. A
//! piece's rows are read where their own chunk headers put them, not where its offset
//! table points.

use super::OutputError;
use super::attr;
use super::exr::{ExrCompression, ExrOptions, write_exr};
use super::frame::{Frame, is_depth_channel};
use super::plate::Plate;
use exr::block::reader::ChunksReader;
use exr::image::read::image::{LayersReader, ReadLayers};
use exr::image::read::layers::ReadChannels;
use exr::meta::attribute::AttributeValue;
use exr::prelude::{FlatImage, FlatSamples, read};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Why pieces could not be stitched; every variant names the piece (or pieces) at fault.
#[derive(Debug, thiserror::Error)]
pub enum StitchError {
    /// `murk stitch` was given no pieces.
    #[error("no pieces to stitch")]
    NoPieces,
    /// A piece cannot be read, is not a piece, or does not fit the others.
    #[error("{}: {problem}", path.display())]
    Piece {
        /// The piece at fault.
        path: PathBuf,
        /// What is wrong with it.
        problem: String,
    },
    /// Two pieces claim the same place in the frame.
    #[error("{} and {}: both are piece {index}/{count}", first.display(), second.display())]
    Twice {
        /// One piece.
        first: PathBuf,
        /// The other.
        second: PathBuf,
        /// The place both claim.
        index: usize,
        /// How many pieces the frame has.
        count: usize,
    },
    /// The pieces leave rows of the frame out.
    #[error("the pieces cover rows 0-{covered} of {height}")]
    Rows {
        /// The first row not covered.
        covered: usize,
        /// The frame's height.
        height: usize,
    },
    /// The stitched frame could not be built or written.
    #[error(transparent)]
    Output(#[from] OutputError),
}

type Result<T> = std::result::Result<T, StitchError>;

/// The error for a piece at `path`.
fn bad(path: &Path, problem: impl Into<String>) -> StitchError {
    StitchError::Piece {
        path: path.to_owned(),
        problem: problem.into(),
    }
}

/// One piece as read.
struct Piece {
    path: PathBuf,
    index: usize,
    count: usize,
    rows: (usize, usize),
    size: (usize, usize),
    plate: Plate,
    /// The data window's origin and size.
    window: (usize, usize, usize, usize),
    channels: Vec<(String, Vec<f32>, bool)>,
    strings: HashMap<String, String>,
    render_time: f32,
    compression: exr::compression::Compression,
    world_to_camera: Option<[f32; 16]>,
    world_to_ndc: Option<[f32; 16]>,
    software: String,
}

/// The image in `path`, its chunks read in file order and each placed at the rows its
/// own header names: the offset table at the file's start is not used (a wrong one
/// would put rows at other rows' places). Every row of the data window must be stored
/// exactly once.
fn read_by_rows(path: &Path) -> Result<FlatImage> {
    let fail = |e: exr::error::Error| bad(path, format!("{e}"));
    let file = std::fs::File::open(path).map_err(|e| bad(path, format!("{e}")))?;
    let reader = exr::block::read(std::io::BufReader::new(file), false).map_err(fail)?;
    let headers = reader.headers().to_vec();
    let [header] = &headers[..] else {
        return Err(bad(
            path,
            format!("not a murk piece (it has {} parts)", headers.len()),
        ));
    };
    if header.deep || !matches!(header.blocks, exr::meta::BlockDescription::ScanLines) {
        return Err(bad(
            path,
            "not a murk piece (it is stored in tiles or deep)",
        ));
    }
    let attributes = header.shared_attributes.clone();
    let height = header.layer_size.1;
    let layers = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers();
    let mut collect = layers.create_layers_reader(&headers).map_err(fail)?;
    let mut stored = vec![false; height];
    let mut twice = None;
    let chunks = reader.all_chunks(false).map_err(fail)?;
    chunks
        .decompress_sequential(false, |meta, block| {
            let (y, h) = (block.index.pixel_position.1, block.index.pixel_size.1);
            for row in stored.iter_mut().skip(y).take(h) {
                if std::mem::replace(row, true) {
                    twice.get_or_insert(y);
                }
            }
            collect.read_block(&meta.headers, block)
        })
        .map_err(fail)?;
    if let Some(y) = twice {
        return Err(bad(
            path,
            format!("the rows from {y} of its data window are stored twice"),
        ));
    }
    if let Some(y) = stored.iter().position(|s| !s) {
        return Err(bad(
            path,
            format!("row {y} of its data window is not stored (the file is cut short or damaged)"),
        ));
    }
    Ok(exr::image::Image {
        attributes,
        layer_data: collect.into_layers(),
    })
}

fn read_piece(path: &Path) -> Result<Piece> {
    let image = read_by_rows(path)?;
    let [layer] = &image.layer_data[..] else {
        return Err(bad(
            path,
            format!("not a murk piece (it has {} parts)", image.layer_data.len()),
        ));
    };
    let mut strings = HashMap::new();
    let mut render_time = 0.0;
    for (k, v) in image.attributes.other.iter().chain(&layer.attributes.other) {
        match v {
            AttributeValue::Text(t) => {
                strings.insert(k.to_string(), t.to_string());
            }
            AttributeValue::F32(f) if k.eq("renderTime") => render_time = *f,
            _ => {}
        }
    }
    let get = |key: &str| {
        strings.get(key).ok_or_else(|| {
            bad(
                path,
                format!("not a piece of a `murk render --tile` (no {key} in its header)"),
            )
        })
    };
    let (index, count) = get(attr::TILE)?
        .split_once('/')
        .and_then(|(i, n)| Some((i.parse().ok()?, n.parse().ok()?)))
        .ok_or_else(|| bad(path, format!("a malformed {} attribute", attr::TILE)))?;
    let rows = get(attr::TILE_ROWS)?
        .split_once('-')
        .and_then(|(a, b)| Some((a.parse().ok()?, b.parse().ok()?)))
        .ok_or_else(|| bad(path, format!("a malformed {} attribute", attr::TILE_ROWS)))?;
    // The frame is the displayWindow (the plate) and its overscan around it.
    let overscan = match strings.get(attr::OVERSCAN) {
        Some(t) => Plate::parse_overscan(t)
            .ok_or_else(|| bad(path, format!("a malformed {} attribute", attr::OVERSCAN)))?,
        None => (0, 0),
    };
    let display = image.attributes.display_window;
    let size = (
        display.size.0.saturating_add(overscan.0.saturating_mul(2)),
        display.size.1.saturating_add(overscan.1.saturating_mul(2)),
    );
    let pos = layer.attributes.layer_position;
    let origin = |p: i32, d: i32, o: usize| {
        usize::try_from(p as i64 - d as i64 + o as i64).unwrap_or(usize::MAX)
    };
    let window = (
        origin(pos.0, display.position.0, overscan.0),
        origin(pos.1, display.position.1, overscan.1),
        layer.size.0,
        layer.size.1,
    );
    let plate = Plate {
        overscan,
        pixel_aspect: image.attributes.pixel_aspect,
    };
    let (rows_ok, window_ok) = (
        rows.0 < rows.1 && rows.1 <= size.1,
        window.0.saturating_add(window.2) <= size.0 && window.1.saturating_add(window.3) <= size.1,
    );
    if !(1..=count).contains(&index) || !rows_ok || !window_ok {
        return Err(bad(path, "its piece attributes do not fit its image"));
    }
    let channels = layer
        .channel_data
        .list
        .iter()
        .map(|c| {
            let (data, float) = match &c.sample_data {
                FlatSamples::F16(v) => (v.iter().map(|h| h.to_f32()).collect(), false),
                FlatSamples::F32(v) => (v.clone(), true),
                FlatSamples::U32(v) => (v.iter().map(|&u| u as f32).collect(), true),
            };
            (c.name.to_string(), data, float)
        })
        .collect();
    Ok(Piece {
        path: path.to_path_buf(),
        index,
        count,
        rows,
        size,
        plate,
        window,
        channels,
        strings,
        render_time,
        compression: layer.encoding.compression,
        world_to_camera: layer.attributes.world_to_camera,
        world_to_ndc: layer.attributes.world_to_normalized_device,
        software: layer
            .attributes
            .software_name
            .as_ref()
            .map(|t| t.to_string())
            .unwrap_or_default(),
    })
}

/// A piece's attribute `name` parsed, `None` when it has none (pieces written before it).
fn attribute<T: std::str::FromStr>(piece: &Piece, name: &str) -> Result<Option<T>> {
    piece
        .strings
        .get(name)
        .map(|v| {
            v.parse()
                .map_err(|_| bad(&piece.path, format!("a malformed {name} attribute")))
        })
        .transpose()
}

/// What must be the same in every piece, with the words that say so when it is not.
fn same(pieces: &[Piece]) -> Result<()> {
    let first = &pieces[0];
    let frame_of = |p: &Piece| {
        let input = p.strings.get("inputFile").map_or("?", String::as_str);
        match p.strings.get(attr::FRAME) {
            Some(f) => format!("frame {f}, {input}"),
            None => input.to_string(),
        }
    };
    let names = |p: &Piece| p.channels.iter().map(|c| c.0.clone()).collect::<Vec<_>>();
    for p in &pieces[1..] {
        let a = first.path.display();
        if frame_of(p) != frame_of(first) {
            return Err(bad(
                &p.path,
                format!(
                    "a piece of another frame ({}) than {a} ({})",
                    frame_of(p),
                    frame_of(first)
                ),
            ));
        }
        if p.size != first.size || p.plate.overscan != first.plate.overscan {
            return Err(bad(
                &p.path,
                format!(
                    "{}x{}, but {a} is {}x{}: pieces of different sizes",
                    p.size.0, p.size.1, first.size.0, first.size.1
                ),
            ));
        }
        if p.count != first.count {
            return Err(bad(
                &p.path,
                format!(
                    "a piece of {} but {a} is a piece of {}",
                    p.count, first.count
                ),
            ));
        }
        if names(p) != names(first) {
            return Err(bad(
                &p.path,
                format!(
                    "its channels ({}) are not those of {a} ({})",
                    names(p).join(","),
                    names(first).join(",")
                ),
            ));
        }
        // How the pixels are stored; the data window (attr::CROP) may differ: each
        // piece's pixels are read by their rows and columns.
        for (key, what) in [
            (attr::STORAGE, "storage"),
            (attr::COLORSPACE, "colour space"),
            (attr::Z_EMPTY, "empty depth"),
        ] {
            let (x, y) = (p.strings.get(key), first.strings.get(key));
            if x != y {
                let text = |v: Option<&String>| v.map_or("none".to_string(), |v| v.clone());
                return Err(bad(
                    &p.path,
                    format!(
                        "its {what} ({key} {}) is not that of {a} ({})",
                        text(x),
                        text(y)
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Reads the pieces, checks they are every piece of one frame, and writes the whole frame
/// to `out`. Returns the frame's size and the number of pieces.
pub fn stitch(pieces: &[PathBuf], out: &Path) -> Result<(usize, usize, usize)> {
    let whole = stitch_frame(pieces)?;
    write_exr(out, &whole.frame, &whole.options)?;
    Ok((whole.frame.width, whole.frame.height, whole.pieces))
}

/// A frame put together from its pieces, as its EXR is written.
pub struct Stitched {
    /// The channels as the pieces store them (in the pieces' colour space).
    pub frame: Frame,
    pub options: ExrOptions,
    pub pieces: usize,
}

/// Reads the pieces and checks they are every piece of one frame: the whole frame.
pub fn stitch_frame(pieces: &[PathBuf]) -> Result<Stitched> {
    if pieces.is_empty() {
        return Err(StitchError::NoPieces);
    }
    let mut read: Vec<Piece> = pieces
        .iter()
        .map(|p| read_piece(p))
        .collect::<Result<_>>()?;
    same(&read)?;
    read.sort_by_key(|p| p.index);
    let count = read[0].count;
    for w in read.windows(2) {
        if w[0].index == w[1].index {
            return Err(StitchError::Twice {
                first: w[0].path.clone(),
                second: w[1].path.clone(),
                index: w[0].index,
                count,
            });
        }
    }
    let have: Vec<usize> = read.iter().map(|p| p.index).collect();
    let missing: Vec<String> = (1..=count)
        .filter(|i| !have.contains(i))
        .map(|i| format!("{i}/{count}"))
        .collect();
    if !missing.is_empty() {
        return Err(bad(
            &read[0].path,
            format!(
                "missing piece{} {} of the frame",
                if missing.len() > 1 { "s" } else { "" },
                missing.join(", ")
            ),
        ));
    }
    let mut next_row = 0;
    for p in &read {
        if p.rows.0 != next_row {
            return Err(bad(
                &p.path,
                format!(
                    "its rows {}-{} do not follow the previous piece's (row {next_row})",
                    p.rows.0, p.rows.1
                ),
            ));
        }
        next_row = p.rows.1;
    }
    let (w, h) = read[0].size;
    if next_row != h {
        return Err(StitchError::Rows {
            covered: next_row,
            height: h,
        });
    }
    let mut frame = Frame::new(w, h);
    let z_empty = attribute(&read[0], attr::Z_EMPTY)?.unwrap_or(ExrOptions::default().z_empty);
    for (c, (name, _, _)) in read[0].channels.iter().enumerate() {
        let depth = is_depth_channel(name);
        let fill = if depth { f32::INFINITY } else { 0.0 };
        let mut data = vec![fill; w * h];
        let mut float = false;
        for p in &read {
            let (x0, y0, pw, ph) = p.window;
            let (_, src, f) = &p.channels[c];
            float |= *f;
            for y in y0.max(p.rows.0)..(y0 + ph).min(p.rows.1) {
                let row = &src[(y - y0) * pw..][..pw];
                let dst = &mut data[y * w + x0..][..pw];
                dst.copy_from_slice(row);
                // A piece's "no depth" is the stitch's too (+inf), so that it counts
                // as empty when the window is cropped, and is written as it was.
                if depth {
                    dst.iter_mut()
                        .filter(|v| **v == z_empty)
                        .for_each(|v| *v = f32::INFINITY);
                }
            }
        }
        frame.add_channel(name.clone(), data)?;
        // Stored as float in a piece: asked for (a float pass) or widened because the
        // layer overflows half there, and then in the whole frame too.
        if float {
            frame.store_as_float(name);
        }
    }
    let first = &read[0];
    let unflatten = |m: [f32; 16]| {
        let mut out = [[0f32; 4]; 4];
        for (i, v) in m.into_iter().enumerate() {
            out[i / 4][i % 4] = v;
        }
        out
    };
    let mut extra: Vec<(String, String)> = first
        .strings
        .iter()
        .filter(|(k, _)| {
            k.starts_with("murk/")
                && ![
                    attr::TILE,
                    attr::TILE_ROWS,
                    attr::STORAGE,
                    attr::COLORSPACE,
                    attr::Z_EMPTY,
                    attr::CROP,
                    attr::OVERSCAN,
                ]
                .contains(&k.as_str())
        })
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    extra.sort();
    let opts = ExrOptions {
        compression: ExrCompression::ALL
            .into_iter()
            .find(|c| {
                std::mem::discriminant(&c.to_exr()) == std::mem::discriminant(&first.compression)
            })
            .unwrap_or_default(),
        float: first
            .strings
            .get(attr::STORAGE)
            .is_some_and(|s| s == "float"),
        world_to_camera: first.world_to_camera.map(unflatten),
        world_to_ndc: first.world_to_ndc.map(unflatten),
        software: first.software.clone(),
        render_time_seconds: Some(read.iter().map(|p| p.render_time as f64).sum()),
        input_file: first.strings.get("inputFile").cloned(),
        extra_strings: extra,
        // Written as the pieces were (pieces from before these attributes: murk's
        // defaults): their colour is already in their colour space, and their empty
        // depth already what they were asked for (the stitch's own empty pixels are
        // +inf, which becomes it).
        colorspace: attribute(first, attr::COLORSPACE)?.unwrap_or(Default::default()),
        colour_converted: true,
        z_empty,
        // Cropped when any piece was (cropping drops only empty pixels).
        crop_data_window: read
            .iter()
            .any(|p| p.strings.get(attr::CROP).is_some_and(|c| c == "true")),
        plate: first.plate,
    };
    Ok(Stitched {
        frame,
        options: opts,
        pieces: count,
    })
}
