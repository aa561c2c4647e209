//! The colour space of what the EXR holds: murk renders in linear Rec.709 (D65); with
//! `--colorspace acescg` every colour triple is converted to ACEScg (AP1 primaries, the
//! ACES white) and the `chromaticities` attribute says so. The matrix (with its
//! chromatic adaptation) and the primaries come from the `kolor` crate, not from
//! constants typed here.

use super::frame::Frame;
use kolor::details::cat::{LMSConeSpace, chromatic_adaptation_transform};
use kolor::details::color::{RGBPrimaries, WhitePoint};
use kolor::details::xyz::{rgb_to_xyz, xyz_to_rgb};
use std::str::FromStr;

/// What colour space the EXR's colour channels are in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ColorSpace {
    /// Linear Rec.709 primaries, D65 white (murk's working space).
    #[default]
    LinRec709,
    /// ACEScg: linear, AP1 primaries, the ACES white point (≈ D60).
    AcesCg,
}

impl FromStr for ColorSpace {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "lin_rec709" | "linear" | "lin_srgb" => Ok(ColorSpace::LinRec709),
            "acescg" | "ACEScg" => Ok(ColorSpace::AcesCg),
            o => Err(format!(
                "--colorspace \"{o}\": expected lin_rec709 or acescg"
            )),
        }
    }
}

/// The ACES white point as the ACES specification (S-2014-004) gives it, to five
/// places: the `chromaticities` attribute carries these numbers. kolor's D60 is the
/// CIE daylight locus at 6000 K, (0.321626, 0.337736), a different point.
const ACES_WHITE: [f32; 2] = [0.32168, 0.33767];

impl ColorSpace {
    /// The name `--colorspace` takes.
    pub fn name(self) -> &'static str {
        match self {
            ColorSpace::LinRec709 => "lin_rec709",
            ColorSpace::AcesCg => "acescg",
        }
    }

    /// The EXR `chromaticities`: red, green, blue, white (CIE xy).
    pub fn chromaticities(self) -> [[f32; 2]; 4] {
        // Rec.709's white is D65 as EXR writes it (0.3127, 0.3290).
        let (p, white) = match self {
            ColorSpace::LinRec709 => (RGBPrimaries::BT_709, [0.3127, 0.3290]),
            ColorSpace::AcesCg => (RGBPrimaries::AP1, ACES_WHITE),
        };
        let [r, g, b] = *p.values();
        [r, g, b, white]
    }

    /// Column-major 3×3 matrix from linear Rec.709 to this space; `None` for Rec.709.
    pub fn from_rec709(self) -> Option<[f32; 9]> {
        match self {
            ColorSpace::LinRec709 => None,
            // Rec.709 → XYZ, D65 → the ACES white by Bradford (as the ACES project adapts; kolor's
            // own default, the Sharp cone space, differs from the published matrix by
            // up to 0.005), XYZ → AP1.
            ColorSpace::AcesCg => {
                let [x, y] = ACES_WHITE.map(f64::from);
                let aces = [(x / y) as f32, 1.0, ((1.0 - x - y) / y) as f32];
                let d65 = WhitePoint::D65.values();
                let to_xyz = rgb_to_xyz(RGBPrimaries::BT_709.values(), d65);
                let adapt = chromatic_adaptation_transform(
                    kolor::Vec3::from_slice(d65),
                    kolor::Vec3::from_slice(&aces),
                    LMSConeSpace::Bradford,
                );
                let from_xyz = xyz_to_rgb(RGBPrimaries::AP1.values(), &aces);
                Some((from_xyz * adapt * to_xyz).to_cols_array())
            }
        }
    }
}

/// `frame` with every colour triple (`R`,`G`,`B` and each layer's `.R`,`.G`,`.B`)
/// converted into `space`; alpha, depth and the `shadow` fraction layer untouched.
pub fn convert_frame(frame: &Frame, space: ColorSpace) -> Frame {
    match space.from_rec709() {
        Some(m) => apply_matrix(frame, m),
        None => frame.clone(),
    }
}

/// `frame`, whose colour triples are in `space`, back in linear Rec.709 (for a preview
/// made from a written EXR): the inverse of [`convert_frame`].
pub fn convert_frame_to_rec709(frame: &Frame, space: ColorSpace) -> Frame {
    match space.from_rec709() {
        Some(m) => apply_matrix(
            frame,
            glam::Mat3::from_cols_array(&m).inverse().to_cols_array(),
        ),
        None => frame.clone(),
    }
}

/// `frame` with the column-major matrix `m` applied to every colour triple.
fn apply_matrix(frame: &Frame, m: [f32; 9]) -> Frame {
    let mut out = frame.clone();
    let names: Vec<String> = frame
        .channel_names()
        .iter()
        .map(|s| s.to_string())
        .collect();
    for r in names.iter().filter(|n| *n == "R" || n.ends_with(".R")) {
        let stem = &r[..r.len() - 1];
        if stem == "shadow." {
            continue; // a fraction of light received, not a colour
        }
        let (g, b) = (format!("{stem}G"), format!("{stem}B"));
        let (Some(cr), Some(cg), Some(cb)) =
            (frame.channel(r), frame.channel(&g), frame.channel(&b))
        else {
            continue;
        };
        let conv = |i: usize| {
            let (x, y, z) = (cr[i], cg[i], cb[i]);
            [
                m[0] * x + m[3] * y + m[6] * z,
                m[1] * x + m[4] * y + m[7] * z,
                m[2] * x + m[5] * y + m[8] * z,
            ]
        };
        let converted: Vec<[f32; 3]> = (0..cr.len()).map(conv).collect();
        for (c, name) in [r.as_str(), g.as_str(), b.as_str()].into_iter().enumerate() {
            if let Some(dst) = out.channel_mut(name) {
                for (d, v) in dst.iter_mut().zip(&converted) {
                    *d = v[c];
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn acescg_keeps_white_and_matches_the_published_matrix() {
        let m = ColorSpace::AcesCg.from_rec709().unwrap();
        // Rows sum to 1: white stays white (the conversion adapts D65 to the ACES white).
        for row in 0..3 {
            let s = m[row] + m[3 + row] + m[6 + row];
            assert!((s - 1.0).abs() < 1e-5, "row {row} sums to {s}");
        }
        // The Rec.709 → ACEScg matrix as the ACES project publishes it (Bradford):
        // first row 0.6131, 0.3395, 0.0474.
        assert!(
            (m[0] - 0.6131).abs() < 2e-3 && (m[3] - 0.3395).abs() < 2e-3,
            "{m:?}"
        );
        let c = ColorSpace::AcesCg.chromaticities();
        assert_eq!(c[0], [0.713, 0.293]);
        // ACES' white exactly as specified, not the daylight locus' D60 near it.
        assert_eq!(c[3], [0.32168, 0.33767]);
    }
}
