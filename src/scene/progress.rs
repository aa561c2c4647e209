//! Progress reporting without a terminal dependency: the library calls a [`Progress`]
//! the caller supplies (the command line draws bars with it; tests and other callers
//! pass [`Silent`]).

/// Receives the progress of one long stage.
pub trait Progress: Sync {
    /// A stage begins: `what` (`rendering`, `baking shadow maps`), `total` steps of `unit`.
    fn start(&self, _what: &str, _total: u64, _unit: &str) {}
    /// What the stage is at now (`step 0.25`), shown beside the bar.
    fn note(&self, _what: &str) {}
    /// `n` more steps are done.
    fn advance(&self, _n: u64) {}
    /// The stage is over.
    fn finish(&self) {}
}

/// Reports nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct Silent;

impl Progress for Silent {}
