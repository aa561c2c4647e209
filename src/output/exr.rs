//! Writing a [`Frame`] as one single-part scanline OpenEXR file.

use std::fmt;
use std::path::Path;
use std::str::FromStr;

use exr::block::UncompressedBlock;
use exr::block::writer::ChunksWriter;
use exr::image::write::layers::{LayersWriter, WritableLayers};
use exr::meta::attribute::{AttributeValue, Chromaticities, IntegerBounds, LineOrder, Text};
use exr::meta::header::standard_names;
use exr::prelude::{
    AnyChannel, AnyChannels, Blocks, Encoding, FlatSamples, Image, ImageAttributes, Layer,
    LayerAttributes, SmallVec, Vec2, WritableImage, f16,
};

use rayon::prelude::*;

use super::OutputError;
use super::frame::{Frame, PixelRect, is_depth_channel};
use crate::files::{FileError, write_atomically};

/// EXR compression methods offered on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum ExrCompression {
    /// No compression.
    None,
    /// Run-length encoding (lossless).
    Rle,
    /// Zip, one scanline per block (lossless): the usual choice for compositing.
    #[default]
    Zips,
    /// Zip, 16 scanlines per block (lossless).
    Zip,
    /// Wavelet (lossless), good for noisy images.
    Piz,
    /// DreamWorks lossy DCT, 32 scanlines per block (Z and other f32 channels
    /// stay lossless).
    Dwaa,
}

impl ExrCompression {
    /// Every method, in the order of the OpenEXR enum.
    pub const ALL: [ExrCompression; 6] = [
        Self::None,
        Self::Rle,
        Self::Zips,
        Self::Zip,
        Self::Piz,
        Self::Dwaa,
    ];

    /// The lower-case name accepted by [`FromStr`] (`none`, `rle`, `zips`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Rle => "rle",
            Self::Zips => "zips",
            Self::Zip => "zip",
            Self::Piz => "piz",
            Self::Dwaa => "dwaa",
        }
    }

    pub(crate) fn to_exr(self) -> exr::compression::Compression {
        use exr::compression::Compression as C;
        match self {
            Self::None => C::Uncompressed,
            Self::Rle => C::RLE,
            Self::Zips => C::ZIP1,
            Self::Zip => C::ZIP16,
            Self::Piz => C::PIZ,
            Self::Dwaa => C::DWAA(None),
        }
    }
}

impl fmt::Display for ExrCompression {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for ExrCompression {
    type Err = OutputError;

    /// Parses `none|rle|zips|zip|piz|dwaa` (case-insensitive).
    fn from_str(s: &str) -> Result<Self, OutputError> {
        let wanted = s.trim().to_ascii_lowercase();
        Self::ALL
            .into_iter()
            .find(|c| c.name() == wanted)
            .ok_or_else(|| OutputError::Parse {
                what: "EXR compression",
                value: s.to_owned(),
                expected: "one of none, rle, zips, zip, piz, dwaa",
            })
    }
}

/// How [`write_exr`] stores a frame.
#[derive(Debug, Clone, PartialEq)]
pub struct ExrOptions {
    /// The compression method (default `zips`).
    pub compression: ExrCompression,
    /// `false`: colour channels are stored as 16-bit half floats; `true`: as
    /// 32-bit floats. Depth channels (`Z`) are always 32-bit floats.
    pub float: bool,
    /// The standard `worldToCamera` attribute (m44f). Stored row by row as
    /// given (`m[0][0], m[0][1], ...`); OpenEXR/Imath use row vectors
    /// (`p_cam = p_world * M`, translation in row 3), which is exactly glam's
    /// `Mat4::to_cols_array_2d()` of a column-vector matrix.
    pub world_to_camera: Option<[[f32; 4]; 4]>,
    /// The standard `worldToNDC` attribute (m44f), same layout.
    pub world_to_ndc: Option<[[f32; 4]; 4]>,
    /// The standard `software` attribute; not written when empty.
    pub software: String,
    /// Written as the float attribute `renderTime` (seconds).
    pub render_time_seconds: Option<f64>,
    /// Written as the string attribute `inputFile`.
    pub input_file: Option<String>,
    /// More string attributes, e.g. `("murk/depthRule", "...")`. Names must
    /// not be standard attribute names, nor `renderTime`, `inputFile` or
    /// `murk/nanCount`, nor repeat.
    pub extra_strings: Vec<(String, String)>,
    /// What depth channels hold where there is no depth (the frame's `+inf`): 1e10 by
    /// default, as Cycles writes (OpenImageIO's filtered resize turns `+inf` into NaN);
    /// `f32::INFINITY` keeps `+inf`.
    pub z_empty: f32,
    /// `true`: the dataWindow is cropped to the non-empty pixels ([`Frame::data_window`]);
    /// `false` (default): dataWindow = displayWindow, which every compositor places
    /// right (Blender 3.4's centres a cropped one).
    pub crop_data_window: bool,
    /// The colour space the colour channels are written in (and `chromaticities`).
    pub colorspace: super::ColorSpace,
    /// The frame's colour is already in `colorspace` (stitched pieces that were written
    /// in it): stored as it is, not converted again.
    pub colour_converted: bool,
    /// The plate: the displayWindow, inside the frame by the overscan; and the
    /// `pixelAspectRatio`.
    pub plate: super::Plate,
}

impl Default for ExrOptions {
    fn default() -> Self {
        Self {
            compression: ExrCompression::default(),
            float: false,
            world_to_camera: None,
            world_to_ndc: None,
            software: format!("murk {}", env!("CARGO_PKG_VERSION")),
            render_time_seconds: None,
            input_file: None,
            extra_strings: Vec::new(),
            z_empty: 1e10,
            crop_data_window: false,
            colorspace: super::ColorSpace::default(),
            colour_converted: false,
            plate: super::Plate::default(),
        }
    }
}

/// What [`write_exr`] did besides writing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ExrWriteSummary {
    /// The data window written, in the frame's pixels (the display window is the plate:
    /// the frame less its overscan).
    pub data_window: PixelRect,
    /// NaN samples found in the frame (a renderer bug). They were written as
    /// 0, or as `+inf` ("no depth") in depth channels. When non-zero the count
    /// is also stored in the int attribute `murk/nanCount`.
    pub nan_count: usize,
}

/// The largest finite half float.
pub const HALF_MAX: f32 = 65504.0;

/// The layer of a channel: its name up to the last `.` (`""` for `R`, `G`, `B`, `A`).
fn layer_of(channel: &str) -> String {
    channel
        .rsplit_once('.')
        .map_or(String::new(), |(l, _)| l.to_string())
}

/// The layers [`write_exr`] writes as 32-bit float although `opts` asks for half: those
/// with a colour value beyond ±[`HALF_MAX`] (as half it would be ±inf), in channel order.
pub fn overflowing_layers(frame: &Frame, opts: &ExrOptions) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    if opts.float {
        return out;
    }
    for c in frame.channels() {
        let layer = layer_of(c.name());
        if !is_depth_channel(c.name())
            && !out.contains(&layer)
            && c.data().iter().any(|v| v.abs() > HALF_MAX)
        {
            out.push(layer);
        }
    }
    out
}

/// One note per layer [`write_exr`] will widen to float (see [`overflowing_layers`]),
/// for stderr and the stats.
pub fn half_overflow_notes(frame: &Frame, opts: &ExrOptions) -> Vec<String> {
    overflowing_layers(frame, opts)
        .into_iter()
        .map(|layer| {
            let name = if layer.is_empty() { "beauty (R, G, B, A)" } else { &layer };
            let peak = frame
                .channels()
                .iter()
                .filter(|c| layer_of(c.name()) == layer && !is_depth_channel(c.name()))
                .flat_map(|c| c.data().iter())
                .fold(0f32, |m, v| m.max(v.abs()));
            format!(
                "layer {name} reaches {peak:.3e}, beyond half float's largest value {HALF_MAX}: written as 32-bit float"
            )
        })
        .collect()
}

/// Rec.709 / sRGB primaries with a D65 white point.
pub const REC709_CHROMATICITIES: [[f32; 2]; 4] =
    [[0.64, 0.33], [0.30, 0.60], [0.15, 0.06], [0.3127, 0.3290]];

const RENDER_TIME: &str = "renderTime";
const INPUT_FILE: &str = "inputFile";
const NAN_COUNT: &str = "murk/nanCount";

/// Write `frame` to `path` as one single-part scanline OpenEXR image.
///
/// Channels are sorted by name (as EXR requires); colour channels are half or
/// float per `opts.float`, depth channels always float. The data window is
/// [`Frame::data_window`] (the bounding box of non-empty pixels, at least
/// 1×1), the display window the whole frame. NaNs are sanitised and counted.
/// The file is replaced atomically (see [`write_atomically`]).
pub fn write_exr(
    path: &Path,
    frame: &Frame,
    opts: &ExrOptions,
) -> Result<ExrWriteSummary, OutputError> {
    let invalid = |reason: String| {
        OutputError::File(FileError::Invalid {
            path: path.to_owned(),
            reason,
        })
    };
    let (w, h) = (frame.width, frame.height);
    if w == 0 || h == 0 {
        return Err(invalid(format!("the frame is empty ({w}x{h})")));
    }
    let Some(display) = opts.plate.size(w, h) else {
        return Err(invalid(format!(
            "an overscan of {:?} pixels leaves no image in the {w}x{h} frame",
            opts.plate.overscan
        )));
    };
    if i32::try_from(w).is_err() || i32::try_from(h).is_err() {
        return Err(invalid(format!(
            "the frame is too large for OpenEXR ({w}x{h})"
        )));
    }
    if frame.channels().is_empty() {
        return Err(invalid("the frame has no channels".to_owned()));
    }
    if let Some(c) = frame
        .channels()
        .iter()
        .find(|c| c.data().len() != frame.pixel_count())
    {
        return Err(invalid(format!(
            "channel `{}` has {} samples, but the {w}x{h} frame needs {}",
            c.name(),
            c.data().len(),
            frame.pixel_count()
        )));
    }

    let converted;
    let frame = if opts.colorspace == super::ColorSpace::LinRec709 || opts.colour_converted {
        frame
    } else {
        converted = super::colorspace::convert_frame(frame, opts.colorspace);
        &converted
    };
    let window = if opts.crop_data_window {
        frame.data_window()
    } else {
        PixelRect {
            x: 0,
            y: 0,
            width: w,
            height: h,
        }
    };
    let wide = overflowing_layers(frame, opts);
    // The channels converted side by side (each its own copy of the frame's samples).
    let converted: Vec<(AnyChannel<FlatSamples>, usize)> = frame
        .channels()
        .par_iter()
        .map(|channel| {
            let depth = is_depth_channel(channel.name());
            let fill = if depth { opts.z_empty } else { 0.0 };
            let nans = channel.data().iter().filter(|v| v.is_nan()).count();
            let cropped = channel
                .data()
                .chunks_exact(w)
                .skip(window.y)
                .take(window.height)
                .flat_map(|row| row.iter().skip(window.x).take(window.width))
                .map(|&v| if v.is_nan() { fill } else { v })
                // Colour is never infinite in the file (depth's +inf means "no depth").
                .map(|v| {
                    if depth {
                        if v == f32::INFINITY { opts.z_empty } else { v }
                    } else {
                        v.clamp(f32::MIN, f32::MAX)
                    }
                });
            let samples =
                if channel.always_float() || opts.float || wide.contains(&layer_of(channel.name()))
                {
                    FlatSamples::F32(cropped.collect())
                } else {
                    FlatSamples::F16(cropped.map(f16::from_f32).collect())
                };
            // pLinear is a hint for lossy compressors; like Nuke, mark nothing linear.
            let channel = AnyChannel {
                quantize_linearly: false,
                ..AnyChannel::new(text(channel.name()), samples)
            };
            (channel, nans)
        })
        .collect();
    let nan_count: usize = converted.iter().map(|(_, n)| n).sum();
    let channels: Vec<AnyChannel<FlatSamples>> = converted.into_iter().map(|(c, _)| c).collect();

    let mut layer_attributes = LayerAttributes {
        layer_position: {
            let (x, y) = opts.plate.from_frame(window.x, window.y);
            Vec2(x as i32, y as i32)
        },
        world_to_camera: opts.world_to_camera.map(flatten),
        world_to_normalized_device: opts.world_to_ndc.map(flatten),
        software_name: (!opts.software.is_empty()).then(|| text(&opts.software)),
        ..LayerAttributes::default()
    };
    let other = &mut layer_attributes.other;
    if let Some(seconds) = opts.render_time_seconds {
        other.insert(text(RENDER_TIME), AttributeValue::F32(seconds as f32));
    }
    if let Some(input) = &opts.input_file {
        other.insert(text(INPUT_FILE), AttributeValue::Text(text(input)));
    }
    if nan_count > 0 {
        let count = i32::try_from(nan_count).unwrap_or(i32::MAX);
        other.insert(text(NAN_COUNT), AttributeValue::I32(count));
    }
    for (name, value) in &opts.extra_strings {
        check_extra_name(name).map_err(|why| invalid(format!("extra attribute `{name}` {why}")))?;
        if other
            .insert(text(name), AttributeValue::Text(text(value)))
            .is_some()
        {
            return Err(invalid(format!("extra attribute `{name}` is given twice")));
        }
    }

    let encoding = Encoding {
        compression: opts.compression.to_exr(),
        blocks: Blocks::ScanLines,
        line_order: LineOrder::Increasing,
    };
    let layer = Layer::new(
        (window.width, window.height),
        layer_attributes,
        encoding,
        AnyChannels::sort(SmallVec::from_vec(channels)),
    );
    let [red, green, blue, white] = opts.colorspace.chromaticities().map(|[x, y]| Vec2(x, y));
    let image_attributes = ImageAttributes {
        chromaticities: Some(Chromaticities {
            red,
            green,
            blue,
            white,
        }),
        pixel_aspect: opts.plate.pixel_aspect,
        ..ImageAttributes::new(IntegerBounds::from_dimensions(display))
    };
    let image = Image::new(image_attributes, layer);

    write_atomically(path, |temp| {
        let exr_error = |source| OutputError::Exr {
            path: path.to_owned(),
            source,
        };
        let file = std::fs::File::create(temp).map_err(|e| exr_error(e.into()))?;
        write_image(&image, std::io::BufWriter::new(file)).map_err(exr_error)
    })?;
    Ok(ExrWriteSummary {
        data_window: window,
        nan_count,
    })
}

/// Scanline blocks handed to the threads at a time: the file's chunks are written in
/// order, each batch's once all of it is compressed.
const WRITE_BATCH: usize = 256;

/// Writes `image` as the `exr` crate's own writer does, byte for byte, but with its
/// blocks read out of the image and compressed on the current rayon pool (the render's
/// `--threads`), where the crate's writer builds a pool of every core for each file
/// (a `--threads 1` render compressed on all of them) and reads the blocks out on one.
fn write_image(
    image: &Image<Layer<AnyChannels<FlatSamples>>>,
    write: impl std::io::Write + std::io::Seek,
) -> exr::error::UnitResult {
    let headers = image.write().infer_meta_data();
    let layers = image.layer_data.create_writer(&headers);
    exr::block::write(write, headers, true, |meta, chunks| {
        let order: Vec<_> = meta.enumerate_ordered_header_block_indices().collect();
        for batch in order.chunks(WRITE_BATCH) {
            let compressed: Vec<exr::error::Result<exr::block::chunk::Chunk>> = batch
                .par_iter()
                .map(|(_, index)| {
                    UncompressedBlock {
                        index: *index,
                        data: layers.extract_uncompressed_block(&meta.headers, *index),
                    }
                    .compress_to_chunk(&meta.headers)
                })
                .collect();
            for ((at, _), chunk) in batch.iter().zip(compressed) {
                chunks.write_chunk(*at, chunk?)?;
            }
        }
        Ok(())
    })
}

/// EXR strings are byte strings; store UTF-8 bytes as they are.
fn text(s: &str) -> Text {
    Text::from_slice_unchecked(s.as_bytes())
}

fn flatten(m: [[f32; 4]; 4]) -> [f32; 16] {
    let mut out = [0.0; 16];
    for (dst, src) in out.iter_mut().zip(m.iter().flatten()) {
        *dst = *src;
    }
    out
}

fn check_extra_name(name: &str) -> Result<(), &'static str> {
    if name.is_empty() {
        Err("has an empty name")
    } else if name.len() > 255 {
        Err("has a name longer than 255 bytes")
    } else if name.chars().any(char::is_control) {
        Err("has control characters in its name")
    } else if [RENDER_TIME, INPUT_FILE, NAN_COUNT].contains(&name)
        || standard_names::ALL.contains(&name.as_bytes())
    {
        Err("would replace a standard attribute")
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compression_names_round_trip() {
        for c in ExrCompression::ALL {
            assert_eq!(c.name().parse::<ExrCompression>().unwrap(), c);
            assert_eq!(c.to_string(), c.name());
        }
        assert_eq!(
            "ZIPS".parse::<ExrCompression>().unwrap(),
            ExrCompression::Zips
        );
        assert_eq!(
            " piz ".parse::<ExrCompression>().unwrap(),
            ExrCompression::Piz
        );
        assert_eq!(ExrCompression::default(), ExrCompression::Zips);
        let err = "b44".parse::<ExrCompression>().unwrap_err().to_string();
        assert!(err.contains("`b44`") && err.contains("zips"), "{err}");
        assert!("".parse::<ExrCompression>().is_err());
    }

    #[test]
    fn compression_maps_to_openexr_methods() {
        use exr::compression::Compression as C;
        assert_eq!(ExrCompression::Zips.to_exr(), C::ZIP1);
        assert_eq!(ExrCompression::Zip.to_exr(), C::ZIP16);
        assert_eq!(ExrCompression::None.to_exr(), C::Uncompressed);
    }

    #[test]
    fn matrices_are_stored_row_by_row() {
        let m = [
            [1.0, 2.0, 3.0, 4.0],
            [5.0, 6.0, 7.0, 8.0],
            [9.0, 10.0, 11.0, 12.0],
            [13.0, 14.0, 15.0, 16.0],
        ];
        let f = flatten(m);
        assert_eq!(f[1], 2.0);
        assert_eq!(f[4], 5.0);
        assert_eq!(f[15], 16.0);
    }

    #[test]
    fn extra_names_cannot_shadow_standard_attributes() {
        assert!(check_extra_name("murk/depthRule").is_ok());
        for bad in [
            "",
            "channels",
            "dataWindow",
            "software",
            "renderTime",
            "murk/nanCount",
        ] {
            assert!(check_extra_name(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn rejects_empty_and_channelless_frames() {
        let p = Path::new("/tmp/never-written.exr");
        let e = write_exr(p, &Frame::new(0, 3), &ExrOptions::default()).unwrap_err();
        assert!(e.to_string().contains("/tmp/never-written.exr"), "{e}");
        let e = write_exr(p, &Frame::new(2, 2), &ExrOptions::default()).unwrap_err();
        assert!(e.to_string().contains("no channels"), "{e}");
        assert!(!p.exists());
    }

    /// The blocks compressed on the render's threads make the file the `exr` crate's own
    /// writer makes, byte for byte, on one thread or several, over more scanlines than
    /// one batch (half and float channels, ZIP1 and PIZ).
    #[test]
    fn the_threads_write_the_crate_writers_bytes() {
        let (w, h) = (37, 2 * WRITE_BATCH + 9);
        let wave = |k: usize| -> Vec<f32> {
            (0..w * h)
                .map(|i| ((i * (k + 3)) % 101) as f32 * 0.37 - 4.0)
                .collect()
        };
        for compression in [ExrCompression::Zips, ExrCompression::Piz] {
            let channels = vec![
                AnyChannel::new(
                    text("R"),
                    FlatSamples::F16(wave(0).into_iter().map(f16::from_f32).collect()),
                ),
                AnyChannel::new(text("G"), FlatSamples::F32(wave(1))),
                AnyChannel::new(text("Z"), FlatSamples::F32(wave(2))),
            ];
            let encoding = Encoding {
                compression: compression.to_exr(),
                blocks: Blocks::ScanLines,
                line_order: LineOrder::Increasing,
            };
            let layer = Layer::new(
                (w, h),
                LayerAttributes::default(),
                encoding,
                AnyChannels::sort(SmallVec::from_vec(channels)),
            );
            let image = Image::new(
                ImageAttributes::new(IntegerBounds::from_dimensions((w, h))),
                layer,
            );
            let mut want = std::io::Cursor::new(Vec::new());
            image.write().to_buffered(&mut want).unwrap();
            for threads in [1, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let mut got = std::io::Cursor::new(Vec::new());
                pool.install(|| write_image(&image, &mut got)).unwrap();
                assert!(
                    got.get_ref() == want.get_ref(),
                    "{compression}, {threads} threads: {} bytes against {}",
                    got.get_ref().len(),
                    want.get_ref().len()
                );
            }
        }
    }
}
