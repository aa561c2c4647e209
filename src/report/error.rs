//! The error of a report: a render it needed, a plot it drew or a file it wrote.

use crate::field::grid_build::GridError;
use crate::files::FileError;
use crate::render::RenderError;
use crate::scene::PlanError;
use crate::vdb::VdbError;
use std::path::PathBuf;

/// Why a report could not be made; every variant names the file, the plot or the render.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// A render the report measures failed.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// The settings of a render the report measures are invalid.
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// A grid the report builds is invalid.
    #[error(transparent)]
    Grid(#[from] GridError),
    /// A scratch VDB file could not be written.
    #[error(transparent)]
    Vdb(#[from] VdbError),
    /// A file could not be written.
    #[error(transparent)]
    File(#[from] FileError),
    /// A plot could not be drawn.
    #[error("drawing {what}: {problem}")]
    Draw {
        /// The plot (`converge.png`, `the phase plot`, ...).
        what: String,
        /// The drawing library's error.
        problem: String,
    },
    /// A file of the report could not be made.
    #[error("{}: {problem}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        problem: String,
    },
}

impl ReportError {
    /// A drawing error of `what`.
    pub(crate) fn draw(what: impl Into<String>, problem: &dyn std::fmt::Display) -> Self {
        ReportError::Draw {
            what: what.into(),
            problem: problem.to_string(),
        }
    }

    /// A file that could not be made.
    pub(crate) fn write(path: &std::path::Path, problem: impl std::fmt::Display) -> Self {
        ReportError::Write {
            path: path.to_owned(),
            problem: problem.to_string(),
        }
    }
}
