//! Progress reporting, kept out of the algorithms: the library calls these hooks and the
//! command line shows them as bars on stderr.

pub trait Progress: Sync {
    /// A new step with `total` units of work (0 when unknown).
    fn start(&self, step: &str, total: u64);
    fn advance(&self, units: u64);
    fn finish(&self);
}

/// Reports nothing.
pub struct Silent;

impl Progress for Silent {
    fn start(&self, _: &str, _: u64) {}
    fn advance(&self, _: u64) {}
    fn finish(&self) {}
}
