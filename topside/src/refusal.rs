//! The marker of an input refused before any work started (exit status 2), shared with the
//! desktop simulator so that both programs say the same thing the same way.

use std::fmt;

/// An input refused before any work started: attached as context to the error that says
/// why, e.g. `vehicle_file::load(path).map_err(refused)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Refused;

impl fmt::Display for Refused {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("refused")
    }
}

/// Mark `e` as a refused input (see [`Refused`]).
pub fn refused(e: anyhow::Error) -> anyhow::Error {
    e.context(Refused)
}

/// Whether `e` is a refused input (see [`Refused`]).
pub fn is_refused(e: &anyhow::Error) -> bool {
    e.downcast_ref::<Refused>().is_some()
}
