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

    /// The frame or the options cannot be written to this file.
    #[error("cannot write {}: {reason}", path.display())]
    Invalid {
        /// The target file.
        path: PathBuf,
        /// The problem.
        reason: String,
    },

    /// The target is not one murk may replace (see [`check_target`](crate::files::guard::check_target)).
    #[error("{}: {reason}", path.display())]
    Refused {
        /// The target file.
        path: PathBuf,
        /// Why not.
        reason: String,
    },

    /// The temporary file next to the target could not be created.
    #[error(
        "cannot write {}: cannot create temporary file {}: {source}",
        path.display(),
        temp.display()
    )]
    CreateTemp {
        /// The target file.
        path: PathBuf,
        /// The temporary file.
        temp: PathBuf,
        /// The cause.
        source: std::io::Error,
    },

    /// The finished temporary file could not be renamed over the target.
    #[error(
        "cannot write {}: cannot rename temporary file {} over it: {source}",
        path.display(),
        temp.display()
    )]
    Rename {
        /// The target file.
        path: PathBuf,
        /// The temporary file.
        temp: PathBuf,
        /// The cause.
        source: std::io::Error,
    },

    /// Any other I/O error while writing the file.
    #[error("cannot write {}: {source}", path.display())]
    Io {
        /// The target file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },

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

impl From<crate::files::FileError> for OutputError {
    fn from(e: crate::files::FileError) -> Self {
        use crate::files::FileError as F;
        match e {
            F::Invalid { path, reason } => OutputError::Invalid { path, reason },
            F::Refused { path, reason } => OutputError::Refused { path, reason },
            F::CreateTemp { path, temp, source } => OutputError::CreateTemp { path, temp, source },
            F::Rename { path, temp, source } => OutputError::Rename { path, temp, source },
            F::Io { path, source } => OutputError::Io { path, source },
        }
    }
}
