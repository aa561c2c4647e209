//! The error of a render: what stopped it, naming the file or the flag at fault.

use crate::files::FileError;
use crate::output::OutputError;
use crate::scene::SceneError;
use crate::scene::source::SourceError;
use crate::shadow::cache::CacheError;
use std::path::PathBuf;

/// Why a render (or a bake, or a sequence's frame) stopped.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The scene could not be built: the input, a role's field, the camera, a cache.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// An output cannot be written there (its folder, its kind).
    #[error("{}: {problem}", path.display())]
    OutputPath {
        /// The output file.
        path: PathBuf,
        /// What is wrong, and what to do.
        problem: String,
    },
    /// The input does not allow what was asked of it.
    #[error("{}: {problem}", path.display())]
    Input {
        /// The input file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// `--tile` names more pieces than the image has rows.
    #[error(transparent)]
    Piece(#[from] super::piece::PieceError),
    /// A flag's value does not fit the render (an output without a frame pattern for a
    /// sequence). The text names the flag.
    #[error("{0}")]
    Flag(String),
    /// `--frames` is not a frame list, or the frames of an input pattern cannot be found.
    #[error(transparent)]
    Frames(#[from] crate::scene::frames::FramesError),
    /// `murk bake-shadows` with no light.
    #[error("no lights to bake shadows for")]
    NoLights,
    /// The worker threads (`--threads`) could not be started.
    #[error("starting worker threads: {0}")]
    Threads(#[from] rayon::ThreadPoolBuildError),
    /// The stats could not be written to standard output.
    #[error("standard output: {0}")]
    Stdout(std::io::Error),
    /// The stats could not be encoded.
    #[error("encoding the stats: {0}")]
    Stats(#[from] serde_json::Error),
    /// The image could not be assembled or written.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// A file could not be written.
    #[error(transparent)]
    File(#[from] FileError),
    /// `--device gpu`: no GPU, or the scene has what the GPU backend does not render.
    #[error("{0}")]
    Device(String),
    /// The shadow cache could not be written.
    #[error(transparent)]
    ShadowCache(#[from] CacheError),
}

impl From<SourceError> for RenderError {
    fn from(e: SourceError) -> Self {
        RenderError::Scene(e.into())
    }
}

impl RenderError {
    /// An output that cannot be written at `path`.
    pub(super) fn output_path(path: &std::path::Path, problem: impl Into<String>) -> Self {
        RenderError::OutputPath {
            path: path.to_owned(),
            problem: problem.into(),
        }
    }
}
