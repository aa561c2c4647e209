//! The error type of the output module.

use std::path::PathBuf;

/// Everything that can go wrong while building a [`Frame`](super::Frame) or
/// writing it to disk. File errors always name the target file.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// A channel's sample count does not match the frame size.
    #[error("channel `{name}` has {len} samples, but the {width}x{height} frame needs {expected}")]
    ChannelLength {
        /// The channel's name.
        name: String,
        /// How many samples it has.
        len: usize,
        /// How many samples it should have (`width * height`).
        expected: usize,
        /// The frame width.
        width: usize,
        /// The frame height.
        height: usize,
    },

    /// A channel with this name already exists in the frame.
    #[error("channel `{0}` is already in the frame")]
    DuplicateChannel(String),

    /// A channel name that cannot be stored in an EXR file.
    #[error("invalid channel name `{name}`: {reason}")]
    InvalidChannelName {
        /// The rejected name.
        name: String,
        /// Why it was rejected.
        reason: &'static str,
    },

    /// A name (compression, background, ...) could not be parsed.
    #[error("invalid {what} `{value}`: expected {expected}")]
    Parse {
        /// What was being parsed.
        what: &'static str,
        /// The rejected text.
        value: String,
        /// The accepted forms.
        expected: &'static str,
    },

    /// The target file: refused, invalid, or its temporary file not written or renamed.
    #[error(transparent)]
    File(#[from] crate::files::FileError),

    /// The `exr` crate failed to encode the image.
    #[error("cannot write OpenEXR file {}: {source}", path.display())]
    Exr {
        /// The target file.
        path: PathBuf,
        /// The cause.
        source: exr::error::Error,
    },

    /// The `image` crate failed to encode the PNG.
    #[error("cannot write PNG file {}: {source}", path.display())]
    Png {
        /// The target file.
        path: PathBuf,
        /// The cause.
        source: image::ImageError,
    },
}
