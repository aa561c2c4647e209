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

fn xy_of_white(w: WhitePoint) -> [f32; 2] {
    let [x, y, z] = *w.values();
    [x / (x + y + z), y / (x + y + z)]
}

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
        let (p, w) = match self {
            ColorSpace::LinRec709 => (RGBPrimaries::BT_709, WhitePoint::D65),
            ColorSpace::AcesCg => (RGBPrimaries::AP1, WhitePoint::D60),
        };
        let [r, g, b] = *p.values();
        // Rec.709's white is D65 as EXR writes it (0.3127, 0.3290).
        let white = match self {
            ColorSpace::LinRec709 => [0.3127, 0.3290],
            ColorSpace::AcesCg => xy_of_white(w),
        };
        [r, g, b, white]
    }

    /// Column-major 3×3 matrix from linear Rec.709 to this space; `None` for Rec.709.
    pub fn from_rec709(self) -> Option<[f32; 9]> {
        match self {
            ColorSpace::LinRec709 => None,
            // Rec.709 → XYZ, D65 → D60 by Bradford (as the ACES project adapts; kolor's
            // own default, the Sharp cone space, differs from the published matrix by
            // up to 0.005), XYZ → AP1.
            ColorSpace::AcesCg => {
                let (d65, d60) = (WhitePoint::D65.values(), WhitePoint::D60.values());
                let to_xyz = rgb_to_xyz(RGBPrimaries::BT_709.values(), d65);
                let adapt = chromatic_adaptation_transform(
                    kolor::Vec3::from_slice(d65),
                    kolor::Vec3::from_slice(d60),
                    LMSConeSpace::Bradford,
                );
                let from_xyz = xyz_to_rgb(RGBPrimaries::AP1.values(), d60);
                Some((from_xyz * adapt * to_xyz).to_cols_array())
            }
        }
    }
}

/// `frame` with every colour triple (`R`,`G`,`B` and each layer's `.R`,`.G`,`.B`)
/// converted into `space`; alpha, depth and the `shadow` fraction layer untouched.
pub fn convert_frame(frame: &Frame, space: ColorSpace) -> Frame {
    let Some(m) = space.from_rec709() else {
        return frame.clone();
    };
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
            let dst = out.channel_mut(name).unwrap();
            for (d, v) in dst.iter_mut().zip(&converted) {
                *d = v[c];
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
            assert!((s - 1.0).abs() < 2e-3, "row {row} sums to {s}");
        }
        // The Rec.709 → ACEScg matrix as the ACES project publishes it (Bradford):
        // first row 0.6131, 0.3395, 0.0474.
        assert!(
            (m[0] - 0.6131).abs() < 2e-3 && (m[3] - 0.3395).abs() < 2e-3,
            "{m:?}"
        );
        let c = ColorSpace::AcesCg.chromaticities();
        assert_eq!(c[0], [0.713, 0.293]);
        assert!((c[3][0] - 0.32168).abs() < 1e-3 && (c[3][1] - 0.33767).abs() < 1e-3);
    }
}
