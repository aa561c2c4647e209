//! The error of building a scene: what in the input, a flag or a cache stops the render.

use super::PlanError;
use super::source::SourceError;
use crate::integrate::phase::water_drop::RadiusError;
use crate::shadow::cache::CacheError;
use std::path::PathBuf;

/// Why a scene could not be built; every variant names the file or the flag at fault.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The input could not be opened, or lacks a field asked for.
    #[error(transparent)]
    Source(#[from] SourceError),
    /// A field of the input cannot fill the role it is given (or no field can).
    #[error("{}: {problem}", path.display())]
    Input {
        /// The input file.
        path: PathBuf,
        /// What does not fit, and what to do.
        problem: String,
    },
    /// A flag's value does not fit what it names.
    #[error("{flag} \"{value}\": {problem}")]
    Flag {
        /// The flag, as typed (`--color-grid`).
        flag: &'static str,
        /// Its value.
        value: String,
        /// What is wrong with it.
        problem: String,
    },
    /// The camera or another setting is invalid.
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// The water-drop phase function's radius is out of range.
    #[error(transparent)]
    Radius(#[from] RadiusError),
    /// The shadow cache cannot be read or does not fit.
    #[error(transparent)]
    ShadowCache(#[from] CacheError),
}

impl SceneError {
    /// An input's field that does not fit.
    pub fn input(path: impl Into<PathBuf>, problem: impl Into<String>) -> Self {
        SceneError::Input {
            path: path.into(),
            problem: problem.into(),
        }
    }
}
