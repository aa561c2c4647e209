//! 8-bit sRGB PNG previews of the beauty pass.

use std::path::Path;
use std::str::FromStr;

use image::{ImageBuffer, ImageFormat, Rgb, Rgba};

use super::OutputError;
use super::frame::{Frame, names};
use crate::files::{FileError, write_atomically};

/// What the premultiplied beauty is composited over.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Background {
    /// Keep alpha: an RGBA PNG with un-premultiplied colours.
    #[default]
    Transparent,
    /// Opaque black.
    Black,
    /// A grey checkerboard of 16-pixel squares, as image viewers show.
    Checker,
    /// An opaque linear RGB colour.
    Color([f32; 3]),
}

/// The checker squares' size in pixels.
pub const CHECKER_SIZE: usize = 16;
/// The two checker greys, linear (sRGB display values 0.4 and 0.6).
pub const CHECKER_GREYS: [f32; 2] = [0.132_868, 0.318_547];

impl Background {
    /// The linear background colour at pixel (x, y), or `None` for transparent.
    pub fn color_at(self, x: usize, y: usize) -> Option<[f32; 3]> {
        match self {
            Self::Transparent => None,
            Self::Black => Some([0.0; 3]),
            Self::Checker => {
                let grey = CHECKER_GREYS[(x / CHECKER_SIZE + y / CHECKER_SIZE) % 2];
                Some([grey; 3])
            }
            Self::Color(c) => Some(c),
        }
    }
}

impl FromStr for Background {
    type Err = OutputError;

    /// Parses `transparent`, `black`, `checker` (case-insensitive) or a linear
    /// colour `R,G,B` such as `0.18,0.18,0.18`.
    fn from_str(s: &str) -> Result<Self, OutputError> {
        let err = || OutputError::Parse {
            what: "preview background",
            value: s.to_owned(),
            expected: "transparent, black, checker or a linear colour R,G,B",
        };
        match s.trim().to_ascii_lowercase().as_str() {
            "transparent" => return Ok(Self::Transparent),
            "black" => return Ok(Self::Black),
            "checker" => return Ok(Self::Checker),
            _ => {}
        }
        let parts: Vec<f32> = s
            .split(',')
            .map(|p| p.trim().parse::<f32>().map_err(|_| err()))
            .collect::<Result<_, _>>()?;
        match parts.as_slice() {
            [r, g, b] if parts.iter().all(|v| v.is_finite()) => Ok(Self::Color([*r, *g, *b])),
            _ => Err(err()),
        }
    }
}

/// How [`write_preview`] renders the beauty pass.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PreviewOptions {
    /// Exposure in stops: colours are multiplied by `2^exposure` after
    /// compositing.
    pub exposure: f32,
    /// What the image is composited over.
    pub background: Background,
}

/// The sRGB transfer function (linear → encoded), clamped to [0, 1]; NaN → 0.
pub fn srgb_encode(linear: f32) -> f32 {
    if linear.is_nan() || linear <= 0.0 {
        0.0
    } else if linear >= 1.0 {
        1.0
    } else if linear <= 0.003_130_8 {
        linear * 12.92
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    }
}

/// A value in [0, 1] (clamped; NaN → 0) as a rounded 8-bit code.
pub fn to_u8(v: f32) -> u8 {
    if v.is_nan() {
        return 0;
    }
    (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

/// Write the beauty `R,G,B,A` (premultiplied) of `frame` to `path` as an
/// 8-bit sRGB PNG: composited over the background, scaled by
/// `2^exposure`, then encoded with the clamped sRGB curve. A transparent
/// background gives an RGBA PNG with un-premultiplied colours; the others an
/// RGB PNG. Replaced atomically. Fails if any of R, G, B, A is missing.
pub fn write_preview(path: &Path, frame: &Frame, opts: &PreviewOptions) -> Result<(), OutputError> {
    let invalid = |reason: String| {
        OutputError::File(FileError::Invalid {
            path: path.to_owned(),
            reason,
        })
    };
    let (w, h) = (frame.width, frame.height);
    let (Ok(w32), Ok(h32)) = (u32::try_from(w), u32::try_from(h)) else {
        return Err(invalid(format!("the frame is too large for PNG ({w}x{h})")));
    };
    if w == 0 || h == 0 {
        return Err(invalid(format!("the frame is empty ({w}x{h})")));
    }
    let missing: Vec<&str> = names::RGBA
        .into_iter()
        .filter(|n| frame.channel(n).is_none())
        .collect();
    let (Some(r), Some(g), Some(b), Some(a)) = (
        frame.channel(names::R),
        frame.channel(names::G),
        frame.channel(names::B),
        frame.channel(names::A),
    ) else {
        return Err(invalid(format!(
            "the frame has no beauty channel(s) {} for the preview",
            missing.join(", ")
        )));
    };
    if [r, g, b, a].iter().any(|c| c.len() != w * h) {
        return Err(invalid(format!(
            "the beauty channels do not match the {w}x{h} frame size"
        )));
    }
    let gain = opts.exposure.exp2();
    let pixels = (0..w * h).map(|i| {
        let rgb = [r[i], g[i], b[i]].map(|v| if v.is_nan() { 0.0 } else { v });
        let alpha = if a[i].is_nan() {
            0.0
        } else {
            a[i].clamp(0.0, 1.0)
        };
        match opts.background.color_at(i % w, i / w) {
            Some(bg) => {
                let c = [0, 1, 2].map(|k| (rgb[k] + (1.0 - alpha) * bg[k]) * gain);
                [c[0], c[1], c[2], 1.0]
            }
            None => {
                let un = |v: f32| if alpha > 0.0 { v / alpha * gain } else { 0.0 };
                [un(rgb[0]), un(rgb[1]), un(rgb[2]), alpha]
            }
        }
    });

    let encode_err = |source| OutputError::Png {
        path: path.to_owned(),
        source,
    };
    let size_err = || invalid("internal error: PNG buffer size mismatch".to_owned());
    write_atomically(path, |temp| {
        if opts.background == Background::Transparent {
            let raw: Vec<u8> = pixels
                .flat_map(|[r, g, b, a]| {
                    [
                        to_u8(srgb_encode(r)),
                        to_u8(srgb_encode(g)),
                        to_u8(srgb_encode(b)),
                        to_u8(a),
                    ]
                })
                .collect();
            let img = ImageBuffer::<Rgba<u8>, _>::from_raw(w32, h32, raw).ok_or_else(size_err)?;
            img.save_with_format(temp, ImageFormat::Png)
                .map_err(encode_err)
        } else {
            let raw: Vec<u8> = pixels
                .flat_map(|[r, g, b, _]| [r, g, b].map(|v| to_u8(srgb_encode(v))))
                .collect();
            let img = ImageBuffer::<Rgb<u8>, _>::from_raw(w32, h32, raw).ok_or_else(size_err)?;
            img.save_with_format(temp, ImageFormat::Png)
                .map_err(encode_err)
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_encode_matches_reference_values() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert_eq!(srgb_encode(1.0), 1.0);
        assert!((srgb_encode(0.18) - 0.461_356).abs() < 1e-5);
        assert!((srgb_encode(0.5) - 0.735_357).abs() < 1e-5);
        // linear segment and the continuity at its end
        assert!((srgb_encode(0.001) - 0.012_92).abs() < 1e-7);
        let (lo, hi) = (srgb_encode(0.003_130_8), srgb_encode(0.003_130_9));
        assert!((hi - lo).abs() < 1e-5);
        // clamping
        assert_eq!(srgb_encode(-3.0), 0.0);
        assert_eq!(srgb_encode(7.5), 1.0);
        assert_eq!(srgb_encode(f32::NAN), 0.0);
        assert_eq!(srgb_encode(f32::INFINITY), 1.0);
        // monotonic
        let codes: Vec<u8> = (0..=1000)
            .map(|i| to_u8(srgb_encode(i as f32 / 1000.0)))
            .collect();
        assert!(codes.windows(2).all(|p| p[0] <= p[1]));
        assert_eq!((codes[0], codes[1000]), (0, 255));
        assert_eq!(to_u8(srgb_encode(0.215_86)), 128);
    }

    #[test]
    fn checker_greys_are_srgb_point_four_and_point_six() {
        assert_eq!(to_u8(srgb_encode(CHECKER_GREYS[0])), to_u8(0.4));
        assert_eq!(to_u8(srgb_encode(CHECKER_GREYS[1])), to_u8(0.6));
        let bg = Background::Checker;
        assert_ne!(bg.color_at(0, 0), bg.color_at(CHECKER_SIZE, 0));
        assert_eq!(bg.color_at(0, 0), bg.color_at(CHECKER_SIZE, CHECKER_SIZE));
    }

    #[test]
    fn background_parsing() {
        assert_eq!(
            "transparent".parse::<Background>().unwrap(),
            Background::Transparent
        );
        assert_eq!("Black".parse::<Background>().unwrap(), Background::Black);
        assert_eq!(
            "checker".parse::<Background>().unwrap(),
            Background::Checker
        );
        assert_eq!(
            "0.18, 0.2,1".parse::<Background>().unwrap(),
            Background::Color([0.18, 0.2, 1.0])
        );
        for bad in ["", "white", "1,2", "1,2,3,4", "a,b,c", "nan,0,0"] {
            let e = bad.parse::<Background>().unwrap_err().to_string();
            assert!(e.contains("preview background"), "{e}");
        }
    }
}
