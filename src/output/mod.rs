//! Output: the rendered [`Frame`] (named float channels, Nuke-style layer
//! names), written as one single-part scanline OpenEXR file ([`write_exr`]),
//! as an 8-bit sRGB PNG preview ([`write_preview`]), always replacing the
//! target atomically ([`write_atomically`], which lives in [`crate::files`] so that every
//! stage may write files through it).

pub mod attr;
pub mod colorspace;
pub mod deep;
pub mod deep_pack;
mod error;
mod exr;
mod frame;
mod plate;
mod preview;
pub mod stitch;

pub use crate::files::guard;
pub use crate::files::place::{make_folder, prepare as prepare_place};
pub use crate::files::write_atomically;
pub use colorspace::ColorSpace;
pub use deep::{DeepExrOptions, DeepImage, DeepSample, write_deep_exr};
pub use error::OutputError;
pub use exr::{
    ExrCompression, ExrOptions, ExrWriteSummary, HALF_MAX, REC709_CHROMATICITIES,
    half_overflow_notes, overflowing_layers, write_exr,
};
pub use frame::{Channel, Frame, PixelRect, is_depth_channel, names};
pub use plate::Plate;
pub use preview::{
    Background, CHECKER_GREYS, CHECKER_SIZE, PreviewOptions, srgb_encode, to_u8, write_preview,
};
