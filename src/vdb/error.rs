//! Errors from loading VDB files. Every message names the file (and the grid where
//! there is one) so the CLI can print it as one line.

use std::path::PathBuf;
use thiserror::Error;

#[derive(Debug, Error)]
pub enum VdbError {
    #[error("{path}: {problem}")]
    File { path: PathBuf, problem: String },
    #[error("{path}: grid \"{grid}\": {problem}")]
    Grid {
        path: PathBuf,
        grid: String,
        problem: String,
    },
    #[error("{path}: no grid named \"{grid}\" (the file has: {available})")]
    NoSuchGrid {
        path: PathBuf,
        grid: String,
        available: String,
    },
}

impl VdbError {
    pub fn file(path: impl Into<PathBuf>, problem: impl Into<String>) -> Self {
        VdbError::File {
            path: path.into(),
            problem: problem.into(),
        }
    }
    pub fn grid(path: impl Into<PathBuf>, grid: &str, problem: impl Into<String>) -> Self {
        VdbError::Grid {
            path: path.into(),
            grid: super::guard::short_text(grid),
            problem: problem.into(),
        }
    }

    /// The same error about another path: a file written under a temporary name and
    /// renamed is named as the output the user asked for.
    pub fn at(self, shown: impl Into<PathBuf>) -> Self {
        let path = shown.into();
        match self {
            VdbError::File { problem, .. } => VdbError::File { path, problem },
            VdbError::Grid { grid, problem, .. } => VdbError::Grid {
                path,
                grid,
                problem,
            },
            VdbError::NoSuchGrid {
                grid, available, ..
            } => VdbError::NoSuchGrid {
                path,
                grid,
                available,
            },
        }
    }
}

/// Turns a panic payload into a message (the reader is run under `catch_unwind`).
pub(crate) fn panic_message(payload: Box<dyn std::any::Any + Send>) -> String {
    use super::guard::printable;
    if let Some(s) = payload.downcast_ref::<&str>() {
        format!("the reader failed on malformed data ({})", printable(s))
    } else if let Some(s) = payload.downcast_ref::<String>() {
        format!("the reader failed on malformed data ({})", printable(s))
    } else {
        "the reader failed on malformed data".to_string()
    }
}
