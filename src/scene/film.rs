//! The film-back camera model of Maya, Houdini, Blender, Nuke and USD: a focal length
//! and a film gate (apertures) in millimetres, the gate shifted off the lens axis (lens
//! shift, USD's aperture offsets), the gate fitted to the image (film fit), a pixel
//! aspect ratio and near/far clipping planes. [`FilmBack::window`] turns it into the
//! screen window the camera shoots rays through.

use serde::Deserialize;

/// How the film gate is fitted to an image of another aspect ratio, as Maya names it
/// (Blender's sensor fit; USD's `expandAperture` is `Overscan`).
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum FilmFit {
    /// The gate's width spans the image's width.
    #[default]
    Horizontal,
    /// The gate's height spans the image's height.
    Vertical,
    /// The gate fills the image: the gate is cropped, no part of the image is outside it.
    Fill,
    /// The whole gate is in the image, with more around it in one direction.
    Overscan,
}

impl FilmFit {
    /// The fit named `word` (horizontal, vertical, fill, overscan).
    pub fn parse(word: &str) -> Result<FilmFit, String> {
        match word.trim().to_ascii_lowercase().as_str() {
            "horizontal" => Ok(FilmFit::Horizontal),
            "vertical" => Ok(FilmFit::Vertical),
            "fill" => Ok(FilmFit::Fill),
            "overscan" => Ok(FilmFit::Overscan),
            _ => Err(format!(
                "\"{word}\": expected horizontal, vertical, fill or overscan"
            )),
        }
    }
}

/// A film back. Perspective: the focal length and the apertures in millimetres (only
/// their ratios matter). Orthographic: the apertures in tenths of a scene unit, as USD
/// stores them (a 20 mm aperture is 2 units wide).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilmBack {
    pub orthographic: bool,
    pub focal_length: f64,
    pub horizontal_aperture: f64,
    pub vertical_aperture: f64,
    /// Lens shift: the gate's centre off the lens axis, in the apertures' units.
    pub horizontal_offset: f64,
    pub vertical_offset: f64,
    pub fit: FilmFit,
    /// A pixel's width over its height.
    pub pixel_aspect: f64,
    /// Clipping planes, distances along the view axis.
    pub near: f64,
    pub far: f64,
}

impl Default for FilmBack {
    /// USD's fallback camera: a 50 mm lens on a 20.955 × 15.2908 mm gate (35 mm
    /// Academy), clipping from 1 to 10⁶.
    fn default() -> FilmBack {
        FilmBack {
            orthographic: false,
            focal_length: 50.0,
            horizontal_aperture: 20.955,
            vertical_aperture: 15.2908,
            horizontal_offset: 0.0,
            vertical_offset: 0.0,
            fit: FilmFit::Horizontal,
            pixel_aspect: 1.0,
            near: 1.0,
            far: 1e6,
        }
    }
}

/// The image's edges in camera space: at unit distance before the eye (perspective,
/// tangents of the view's half-angles) or in scene units (orthographic); x right, y up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Window {
    pub orthographic: bool,
    pub left: f64,
    pub right: f64,
    pub bottom: f64,
    pub top: f64,
    pub near: f64,
    pub far: f64,
}

/// USD's aperture unit: tenths of a scene unit (GfCamera::APERTURE_UNIT).
const APERTURE_UNIT: f64 = 0.1;

impl FilmBack {
    /// The problem with the film back, if any: the sizes must be positive and finite,
    /// the clipping range increasing.
    pub fn check(&self) -> Result<(), String> {
        let positive = |v: f64, what: &str| {
            if v > 0.0 && v.is_finite() {
                Ok(())
            } else {
                Err(format!("{what} {v} must be a positive number"))
            }
        };
        if !self.orthographic {
            positive(self.focal_length, "the focal length")?;
        }
        positive(self.horizontal_aperture, "the horizontal aperture")?;
        positive(self.vertical_aperture, "the vertical aperture")?;
        positive(self.pixel_aspect, "the pixel aspect ratio")?;
        if !(self.horizontal_offset.is_finite() && self.vertical_offset.is_finite()) {
            return Err("the aperture offsets must be finite numbers".into());
        }
        if !(self.near >= 0.0 && self.far > self.near) {
            return Err(format!(
                "the clipping range {}..{} must have 0 <= near < far",
                self.near, self.far
            ));
        }
        Ok(())
    }

    /// The screen window of an image `width` × `height` pixels.
    pub fn window(&self, width: usize, height: usize) -> Window {
        let image_aspect = width as f64 * self.pixel_aspect / height as f64;
        let gate_aspect = self.horizontal_aperture / self.vertical_aperture;
        let horizontal = match self.fit {
            FilmFit::Horizontal => true,
            FilmFit::Vertical => false,
            FilmFit::Fill => image_aspect >= gate_aspect,
            FilmFit::Overscan => image_aspect < gate_aspect,
        };
        let (w, h) = if horizontal {
            (
                self.horizontal_aperture,
                self.horizontal_aperture / image_aspect,
            )
        } else {
            (
                self.vertical_aperture * image_aspect,
                self.vertical_aperture,
            )
        };
        let scale = if self.orthographic {
            APERTURE_UNIT
        } else {
            1.0 / self.focal_length
        };
        let (cx, cy) = (self.horizontal_offset, self.vertical_offset);
        Window {
            orthographic: self.orthographic,
            left: (cx - 0.5 * w) * scale,
            right: (cx + 0.5 * w) * scale,
            bottom: (cy - 0.5 * h) * scale,
            top: (cy + 0.5 * h) * scale,
            near: self.near,
            far: self.far,
        }
    }

    /// The vertical field of view of the gate, degrees (what a Nuke `.chan` holds).
    pub fn vertical_fov_deg(&self) -> f64 {
        2.0 * (0.5 * self.vertical_aperture / self.focal_length)
            .atan()
            .to_degrees()
    }

    /// The focal length that gives the gate a vertical field of view of `deg`.
    pub fn focal_for_vertical_fov(&self, deg: f64) -> f64 {
        0.5 * self.vertical_aperture / (0.5 * deg.to_radians()).tan()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn film(fit: FilmFit) -> FilmBack {
        FilmBack {
            focal_length: 35.0,
            horizontal_aperture: 36.0,
            vertical_aperture: 24.0,
            fit,
            ..FilmBack::default()
        }
    }

    #[test]
    fn the_gate_sets_the_field_of_view_and_the_fit_the_other_side() {
        // A 3:2 gate on a 16:9 image.
        let (w, h) = (1920, 1080);
        let hz = film(FilmFit::Horizontal).window(w, h);
        assert!((hz.right - 18.0 / 35.0).abs() < 1e-15);
        assert!((hz.top - 18.0 / 35.0 * 9.0 / 16.0).abs() < 1e-15);
        let vt = film(FilmFit::Vertical).window(w, h);
        assert!((vt.top - 12.0 / 35.0).abs() < 1e-15);
        assert!((vt.right - 12.0 / 35.0 * 16.0 / 9.0).abs() < 1e-15);
        // The image is wider than the gate: fill matches widths, overscan heights.
        assert_eq!(film(FilmFit::Fill).window(w, h), hz);
        assert_eq!(film(FilmFit::Overscan).window(w, h), vt);
        // A taller image swaps them.
        assert_eq!(
            film(FilmFit::Fill).window(1000, 1000),
            film(FilmFit::Vertical).window(1000, 1000)
        );
    }

    #[test]
    fn lens_shift_moves_the_window_and_pixel_aspect_widens_it() {
        let mut f = film(FilmFit::Horizontal);
        f.horizontal_offset = 3.5;
        f.vertical_offset = -1.75;
        let w = f.window(300, 200);
        assert!((w.left - (3.5 - 18.0) / 35.0).abs() < 1e-15);
        assert!((w.right - (3.5 + 18.0) / 35.0).abs() < 1e-15);
        assert!((w.bottom + w.top - 2.0 * -1.75 / 35.0).abs() < 1e-15);
        f.pixel_aspect = 2.0;
        let w2 = f.window(150, 200);
        assert!((w2.top - w.top).abs() < 1e-15);
        assert!(film(FilmFit::Horizontal).vertical_fov_deg() > 0.0);
        let g = film(FilmFit::Horizontal);
        assert!((g.focal_for_vertical_fov(g.vertical_fov_deg()) - 35.0).abs() < 1e-12);
    }

    #[test]
    fn orthographic_apertures_are_tenths_of_a_unit() {
        let mut f = film(FilmFit::Horizontal);
        f.orthographic = true;
        let w = f.window(36, 24);
        assert!((w.right - w.left - 3.6).abs() < 1e-12);
        assert!((w.top - w.bottom - 2.4).abs() < 1e-12);
    }

    #[test]
    fn bad_film_backs_are_named() {
        let mut f = film(FilmFit::Horizontal);
        f.focal_length = 0.0;
        assert!(f.check().unwrap_err().contains("focal length"));
        let mut f = film(FilmFit::Horizontal);
        f.vertical_aperture = -2.0;
        assert!(f.check().unwrap_err().contains("vertical aperture"));
        let mut f = film(FilmFit::Horizontal);
        f.far = 0.5;
        assert!(f.check().unwrap_err().contains("clipping"));
        assert!(FilmFit::parse("diagonal").is_err());
        assert_eq!(FilmFit::parse("Fill"), Ok(FilmFit::Fill));
    }
}
