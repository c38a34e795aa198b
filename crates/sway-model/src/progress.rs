//! Progress reporting as a pluggable observer: pipelines call it, the runner draws it.

/// Observer of a long computation. Implementations must be cheap and thread-safe
/// (pipelines call [`Progress::advance`] from rayon workers).
pub trait Progress: Sync {
    /// A new stage with `total` units of work begins.
    fn start(&self, stage: &str, total: u64);
    /// `n` units are done.
    fn advance(&self, n: u64);
    /// The current stage is done.
    fn finish(&self);
}

/// Reports nothing (tests, library use).
#[derive(Debug, Clone, Copy, Default)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn start(&self, _stage: &str, _total: u64) {}
    fn advance(&self, _n: u64) {}
    fn finish(&self) {}
}
