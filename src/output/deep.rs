//! The deep scanline OpenEXR writer: per pixel a list of samples with depth ranges
//! (`Z`..`ZBack`, 32-bit float) and premultiplied `R,G,B,A` (16-bit half floats, packed
//! by [`super::deep_pack`]; 32-bit float and as given with `half` off), ZIPS-compressed,
//! state TIDY (sorted, non-overlapping), as Nuke's deep nodes and OpenEXR's
//! `DeepScanLine` readers take it.
//!
//! The `exr` crate that writes the flat file reads and writes no deep data, so this is
//! written here on `flate2`, byte for byte as the OpenEXR file layout gives it: magic and
//! version (with the non-image bit), the header, the offset table (one entry a scan
//! line), then per scan line its `y`, the packed sizes of its sample-count table and of
//! its sample data, the unpacked size of its sample data, the sample-count table
//! (cumulative counts across the line) and the samples (channel by channel in name
//! order, pixel by pixel). Each part goes through OpenEXR's ZIP transform (bytes split
//! into even and odd halves, then a delta predictor, then zlib) and is stored as is
//! where that does not make it smaller.

use super::OutputError;
use crate::files::{FileError, write_atomically};
use exr::prelude::f16;
use flate2::Compression;
use flate2::write::ZlibEncoder;
use rayon::prelude::*;
use std::io::Write;
use std::path::Path;

pub use super::deep_pack::DeepSample;

/// A deep image: each pixel's samples, front to back, rows top to bottom.
#[derive(Clone, Debug, Default)]
pub struct DeepImage {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<Vec<DeepSample>>,
    /// Layers each sample carries too (deep AOVs: channels `<layer>.R`, `.G`, `.B`),
    /// premultiplied as the colour is.
    pub aov_layers: Vec<String>,
    /// With `aov_layers`: per pixel, each sample's values (3 a layer, in its order),
    /// sample after sample; else empty.
    pub aovs: Vec<Vec<f32>>,
}

impl DeepImage {
    /// Samples in the whole image.
    pub fn sample_count(&self) -> usize {
        self.pixels.iter().map(Vec::len).sum()
    }
}

/// What the deep file's header carries beside the image.
#[derive(Clone, Debug, Default)]
pub struct DeepExrOptions {
    pub world_to_camera: Option<[[f32; 4]; 4]>,
    pub world_to_ndc: Option<[[f32; 4]; 4]>,
    /// Free-form string attributes.
    pub extra_strings: Vec<(String, String)>,
    /// The colour space the samples' colour is written in (converted from linear
    /// Rec.709, as the flat file's), named by the `chromaticities` attribute.
    pub colorspace: super::ColorSpace,
    /// Colour and opacity as half floats and depths rounded ([`super::deep_pack`]);
    /// off: all 32-bit float, as given.
    pub half: bool,
    /// The deep tolerance the samples were merged with: the depths' rounding moves a
    /// split by a share of it.
    pub tolerance: f64,
    /// The displayWindow (the frame less its overscan) and `pixelAspectRatio`.
    pub plate: super::Plate,
    /// Per pixel, the flat file's `R, G, B, A` as it stores them ([`flat_targets`];
    /// empty: none): with `half`, samples' half values are moved so each pixel flattens
    /// onto them ([`super::deep_pack::land_on`]).
    pub targets: Vec<[f32; 4]>,
}

/// The flat file's beauty and alpha per pixel as [`super::write_exr`] stores them with
/// `opts`: in its colour space, half floats unless `--float` or beyond the half range.
pub fn flat_targets(frame: &super::Frame, opts: &super::ExrOptions) -> Vec<[f32; 4]> {
    let converted;
    let frame = if opts.colorspace == super::ColorSpace::LinRec709 || opts.colour_converted {
        frame
    } else {
        converted = super::colorspace::convert_frame(frame, opts.colorspace);
        &converted
    };
    let (Some(r), Some(g), Some(b), Some(a)) = (
        frame.channel("R"),
        frame.channel("G"),
        frame.channel("B"),
        frame.channel("A"),
    ) else {
        return Vec::new();
    };
    let half = !super::exr::overflowing_layers(frame, opts).contains(&String::new());
    let stored = |v: f32| {
        if half && !opts.float {
            f16::from_f32(v).to_f32()
        } else {
            v
        }
    };
    (0..r.len())
        .map(|i| [stored(r[i]), stored(g[i]), stored(b[i]), stored(a[i])])
        .collect()
}

/// What a written deep file holds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DeepWriteSummary {
    pub bytes: u64,
    pub samples: u64,
    pub max_samples_per_pixel: u32,
}

/// What a channel of the file holds.
#[derive(Clone, Copy)]
enum Source {
    /// Colour (0..3) or alpha (3).
    Rgba(usize),
    Z,
    ZBack,
    /// The AOV value at this place among a sample's.
    Aov(usize),
}

/// The file's channels in the order OpenEXR stores them (by name).
fn channels(aov_layers: &[String]) -> Vec<(String, Source)> {
    let mut list: Vec<(String, Source)> = vec![
        ("R".into(), Source::Rgba(0)),
        ("G".into(), Source::Rgba(1)),
        ("B".into(), Source::Rgba(2)),
        ("A".into(), Source::Rgba(3)),
        ("Z".into(), Source::Z),
        ("ZBack".into(), Source::ZBack),
    ];
    for (k, layer) in aov_layers.iter().enumerate() {
        for (c, name) in ["R", "G", "B"].iter().enumerate() {
            list.push((format!("{layer}.{name}"), Source::Aov(3 * k + c)));
        }
    }
    list.sort_by(|a, b| a.0.as_bytes().cmp(b.0.as_bytes()));
    list
}
const HALF: i32 = 1;
const FLOAT: i32 = 2;
const ZIPS: u8 = 2;
/// `deepImageState` TIDY: sorted and non-overlapping.
const TIDY: u8 = 3;

struct Header(Vec<u8>);

impl Header {
    fn attr(&mut self, name: &str, kind: &str, value: &[u8]) {
        let b = &mut self.0;
        b.extend_from_slice(name.as_bytes());
        b.push(0);
        b.extend_from_slice(kind.as_bytes());
        b.push(0);
        b.extend_from_slice(&(value.len() as i32).to_le_bytes());
        b.extend_from_slice(value);
    }
    fn int(&mut self, name: &str, v: i32) {
        self.attr(name, "int", &v.to_le_bytes());
    }
    fn string(&mut self, name: &str, v: &str) {
        self.attr(name, "string", v.as_bytes());
    }
    fn m44f(&mut self, name: &str, m: &[[f32; 4]; 4]) {
        let bytes: Vec<u8> = m.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
        self.attr(name, "m44f", &bytes);
    }
}

/// The box from `(x, y)` over `w` × `h` pixels.
fn box2i((x, y): (i64, i64), (w, h): (usize, usize)) -> Vec<u8> {
    [x, y, x + w as i64 - 1, y + h as i64 - 1]
        .map(|v| v.clamp(i32::MIN as i64, i32::MAX as i64) as i32)
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect()
}

/// OpenEXR's ZIP transform of `raw`: even bytes then odd bytes, each byte then the
/// difference from the one before (+128), then zlib. `None` where that is no smaller.
fn zip(raw: &[u8]) -> std::io::Result<Option<Vec<u8>>> {
    let half = raw.len().div_ceil(2);
    let mut t = vec![0u8; raw.len()];
    let (even, odd) = t.split_at_mut(half);
    for ((pair, e), k) in raw.chunks(2).zip(even).zip(0..) {
        *e = pair[0];
        if let (Some(&b), Some(o)) = (pair.get(1), odd.get_mut(k)) {
            *o = b;
        }
    }
    let mut prev = t.first().copied().unwrap_or(0);
    for v in t.iter_mut().skip(1) {
        let d = v.wrapping_sub(prev).wrapping_add(128);
        prev = *v;
        *v = d;
    }
    let mut z = ZlibEncoder::new(Vec::new(), Compression::default());
    z.write_all(&t)?;
    let packed = z.finish()?;
    Ok((packed.len() < raw.len()).then_some(packed))
}

/// One scan line's samples and their AOV values as written: packed
/// ([`super::deep_pack`]) with `half` on.
type Row = (Vec<Vec<DeepSample>>, Vec<Vec<f32>>);

fn pack_row(
    row: &[Vec<DeepSample>],
    aovs: &[Vec<f32>],
    m: usize,
    targets: &[[f32; 4]],
    opts: &DeepExrOptions,
) -> Row {
    if !opts.half {
        return (row.to_vec(), aovs.to_vec());
    }
    let mut values = Vec::with_capacity(if m > 0 { row.len() } else { 0 });
    let samples = row
        .iter()
        .enumerate()
        .map(|(x, px)| {
            let mut out = Vec::with_capacity(px.len());
            let mut out_aovs = Vec::new();
            let given = aovs.get(x).map_or(&[][..], Vec::as_slice);
            super::deep_pack::round_with_aovs(px, given, m, &mut out, &mut out_aovs);
            // Not with AOVs: moving opacity would move their flattened values, which
            // are rounded against the samples as they are.
            if let (Some(t), 0) = (targets.get(x), m) {
                super::deep_pack::land_on(&mut out, *t, opts.tolerance);
            }
            super::deep_pack::round_depths(&mut out, opts.tolerance);
            if m > 0 {
                values.push(out_aovs);
            }
            out
        })
        .collect();
    (samples, values)
}

/// One scan line's chunk: `y`, the three sizes, the count table and the samples.
fn chunk(
    y: usize,
    (row, aovs): &Row,
    list: &[(String, Source)],
    half: bool,
) -> std::io::Result<Vec<u8>> {
    let mut counts = Vec::with_capacity(row.len() * 4);
    let mut total: i32 = 0;
    for px in row {
        total = total.saturating_add(px.len() as i32);
        counts.extend_from_slice(&total.to_le_bytes());
    }
    let m = list.len().saturating_sub(6);
    let mut data = Vec::with_capacity(total as usize * 4 * list.len());
    for (_, source) in list {
        for (x, px) in row.iter().enumerate() {
            for (i, s) in px.iter().enumerate() {
                let v = match *source {
                    Source::Rgba(k) => s.rgba[k],
                    Source::Z => s.z,
                    Source::ZBack => s.z_back,
                    Source::Aov(k) => aovs
                        .get(x)
                        .and_then(|a| a.get(i * m + k))
                        .copied()
                        .unwrap_or(0.0),
                };
                if half && !matches!(source, Source::Z | Source::ZBack) {
                    data.extend_from_slice(&f16::from_f32(v).to_le_bytes());
                } else {
                    data.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
    }
    let packed_counts = zip(&counts)?.unwrap_or(counts);
    let unpacked = data.len() as u64;
    let packed_data = if data.is_empty() {
        data
    } else {
        zip(&data)?.unwrap_or(data)
    };
    let mut out = Vec::with_capacity(28 + packed_counts.len() + packed_data.len());
    out.extend_from_slice(&(y as i32).to_le_bytes());
    out.extend_from_slice(&(packed_counts.len() as u64).to_le_bytes());
    out.extend_from_slice(&(packed_data.len() as u64).to_le_bytes());
    out.extend_from_slice(&unpacked.to_le_bytes());
    out.extend_from_slice(&packed_counts);
    out.extend_from_slice(&packed_data);
    Ok(out)
}

/// The whole file's bytes.
fn encode(image: &DeepImage, opts: &DeepExrOptions) -> Result<(Vec<u8>, DeepWriteSummary), String> {
    let (w, h) = (image.width, image.height);
    if w == 0 || h == 0 || image.pixels.len() != w * h {
        return Err(format!(
            "a deep image of {w}x{h} pixels has {} pixel lists",
            image.pixels.len()
        ));
    }
    let m = 3 * image.aov_layers.len();
    if m > 0
        && (image.aovs.len() != w * h
            || image
                .aovs
                .iter()
                .zip(&image.pixels)
                .any(|(a, p)| a.len() != m * p.len()))
    {
        return Err("a deep image's AOV values do not match its samples".into());
    }
    if w > i32::MAX as usize || h > i32::MAX as usize {
        return Err(format!("a deep image of {w}x{h} pixels is too large"));
    }
    let converted;
    let image = match opts.colorspace.from_rec709() {
        Some(m) => {
            let m = glam::Mat3::from_cols_array(&m);
            let mut c = image.clone();
            for s in c.pixels.iter_mut().flatten() {
                let v = m * glam::Vec3::new(s.rgba[0], s.rgba[1], s.rgba[2]);
                s.rgba[..3].copy_from_slice(&v.to_array());
            }
            // The layers' colours too, as the flat file's are.
            for rgb in c.aovs.iter_mut().flat_map(|a| a.chunks_exact_mut(3)) {
                let v = m * glam::Vec3::new(rgb[0], rgb[1], rgb[2]);
                rgb.copy_from_slice(&v.to_array());
            }
            converted = c;
            &converted
        }
        None => image,
    };
    // Scan lines pack and compress independently: on every thread.
    // Colour beyond the half floats' range: all 32-bit, as the flat file's layer is.
    let beyond = |v: &f32| v.abs() as f64 > super::deep_pack::HALF_MAX;
    let fits_half = !image
        .pixels
        .iter()
        .flatten()
        .any(|s| s.rgba.iter().any(beyond))
        && !image.aovs.iter().flatten().any(beyond);
    let widened;
    let opts = if opts.half && !fits_half {
        widened = DeepExrOptions {
            half: false,
            ..opts.clone()
        };
        &widened
    } else {
        opts
    };
    let targets = if opts.targets.len() == w * h {
        opts.targets.as_slice()
    } else {
        &[]
    };
    let rows: Vec<Row> = (0..h)
        .into_par_iter()
        .map(|y| {
            let aovs = image.aovs.get(y * w..(y + 1) * w).unwrap_or(&[]);
            let targets = targets.get(y * w..(y + 1) * w).unwrap_or(&[]);
            pack_row(&image.pixels[y * w..(y + 1) * w], aovs, m, targets, opts)
        })
        .collect();
    let max = rows
        .iter()
        .flat_map(|r| &r.0)
        .map(Vec::len)
        .max()
        .unwrap_or(0);
    let samples: usize = rows.iter().flat_map(|r| &r.0).map(Vec::len).sum();
    let list = channels(&image.aov_layers);
    let mut hd = Header(Vec::new());
    let mut ch = Vec::new();
    for (name, source) in &list {
        ch.extend_from_slice(name.as_bytes());
        ch.push(0);
        let depth = matches!(source, Source::Z | Source::ZBack);
        let kind = if opts.half && !depth { HALF } else { FLOAT };
        ch.extend_from_slice(&kind.to_le_bytes());
        ch.extend_from_slice(&[0, 0, 0, 0]); // pLinear, reserved
        ch.extend_from_slice(&1i32.to_le_bytes());
        ch.extend_from_slice(&1i32.to_le_bytes());
    }
    ch.push(0);
    hd.attr("channels", "chlist", &ch);
    let chroma: Vec<u8> = opts
        .colorspace
        .chromaticities()
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    hd.attr("chromaticities", "chromaticities", &chroma);
    hd.int("chunkCount", h as i32);
    hd.attr("compression", "compression", &[ZIPS]);
    let Some(display) = opts.plate.size(w, h) else {
        return Err(format!(
            "an overscan of {:?} pixels leaves no image",
            opts.plate.overscan
        ));
    };
    hd.attr(
        "dataWindow",
        "box2i",
        &box2i(opts.plate.from_frame(0, 0), (w, h)),
    );
    hd.attr("deepImageState", "deepImageState", &[TIDY]);
    hd.attr("displayWindow", "box2i", &box2i((0, 0), display));
    hd.attr("lineOrder", "lineOrder", &[0]);
    hd.int("maxSamplesPerPixel", max.min(i32::MAX as usize) as i32);
    hd.string("name", "volume");
    hd.attr(
        "pixelAspectRatio",
        "float",
        &opts.plate.pixel_aspect.to_le_bytes(),
    );
    hd.attr("screenWindowCenter", "v2f", &[0u8; 8]);
    hd.attr("screenWindowWidth", "float", &1f32.to_le_bytes());
    hd.string("type", "deepscanline");
    hd.int("version", 1);
    if let Some(m) = &opts.world_to_camera {
        hd.m44f("worldToCamera", m);
    }
    if let Some(m) = &opts.world_to_ndc {
        hd.m44f("worldToNDC", m);
    }
    for (name, value) in &opts.extra_strings {
        hd.string(name, value);
    }
    hd.0.push(0);
    let mut file = Vec::new();
    file.extend_from_slice(&20000630i32.to_le_bytes());
    // Version 2, non-image (deep), and long names where an attribute's name needs them.
    let long = opts.extra_strings.iter().any(|(n, _)| n.len() > 31);
    let version = 2i32 | 0x800 | if long { 0x400 } else { 0 };
    file.extend_from_slice(&version.to_le_bytes());
    file.extend_from_slice(&hd.0);
    let table_at = file.len();
    file.resize(table_at + 8 * h, 0);
    let chunks: Vec<Vec<u8>> = rows
        .par_iter()
        .enumerate()
        .map(|(y, row)| chunk(y, row, &list, opts.half))
        .collect::<std::io::Result<_>>()
        .map_err(|e| e.to_string())?;
    for (y, c) in chunks.iter().enumerate() {
        let offset = file.len() as u64;
        file[table_at + 8 * y..][..8].copy_from_slice(&offset.to_le_bytes());
        file.extend_from_slice(c);
    }
    let summary = DeepWriteSummary {
        bytes: file.len() as u64,
        samples: samples as u64,
        max_samples_per_pixel: max as u32,
    };
    Ok((file, summary))
}

/// Writes `image` as a deep scanline EXR at `path`, replacing it atomically.
pub fn write_deep_exr(
    path: &Path,
    image: &DeepImage,
    opts: &DeepExrOptions,
) -> Result<DeepWriteSummary, OutputError> {
    let invalid = |reason: String| {
        OutputError::File(FileError::Invalid {
            path: path.to_owned(),
            reason,
        })
    };
    let (bytes, summary) = encode(image, opts).map_err(invalid)?;
    write_atomically(path, |temp| {
        std::fs::write(temp, &bytes).map_err(|source| {
            OutputError::File(FileError::Io {
                path: path.to_owned(),
                source,
            })
        })
    })?;
    Ok(summary)
}
