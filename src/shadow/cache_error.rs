//! The error of writing or reading a shadow cache ([`cache`](super::cache)).

use crate::files::FileError;
use crate::vdb::VdbError;
use std::path::PathBuf;

/// What can go wrong while writing or reading a shadow cache; every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum CacheError {
    /// The cache does not fit what is rendered, or is not a murk shadow cache.
    #[error("{}: {problem}", path.display())]
    Unusable {
        /// The cache file.
        path: PathBuf,
        /// What does not fit, and what to do.
        problem: String,
    },
    /// The file could not be read or encoded as a VDB (its error names the file).
    #[error(transparent)]
    Read(#[from] VdbError),
    /// The file could not be written.
    #[error(transparent)]
    Write(#[from] FileError),
}
