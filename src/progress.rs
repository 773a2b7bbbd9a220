//! Progress reporting, kept out of the algorithms: the library calls these hooks and the
//! command line shows them as bars on stderr.

/// Where a long computation reports its steps; the CLI draws bars, [`Silent`] says nothing.
pub trait Progress: Sync {
    /// A new step with `total` units of work (0 when unknown).
    fn start(&self, step: &str, total: u64);
    /// `units` more of the step done.
    fn advance(&self, units: u64);
    /// The step is done.
    fn finish(&self);
}

/// Reports nothing.
pub struct Silent;

impl Progress for Silent {
    fn start(&self, _: &str, _: u64) {}
    fn advance(&self, _: u64) {}
    fn finish(&self) {}
}
