//! The one error a mesh reader returns: the file and what is wrong with it.

use std::path::{Path, PathBuf};

/// A mesh file that cannot be read; prints as one line, `FILE: problem`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}: {problem}", path.display())]
pub struct MeshError {
    pub path: PathBuf,
    pub problem: String,
}

impl MeshError {
    pub fn new(path: &Path, problem: impl Into<String>) -> Self {
        let problem: String = problem.into();
        // One line, whatever a parser put in the message.
        let problem = problem.split_whitespace().collect::<Vec<_>>().join(" ");
        MeshError {
            path: path.to_path_buf(),
            problem,
        }
    }
}
