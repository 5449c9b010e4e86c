//! The checks every user-given number goes through: finite, positive, not negative; the
//! error names the key. Shared by the scenario and the sensor keys.

use anyhow::{bail, Result};
use std::fmt;

/// The marker of an input refused before any work started (the command line's exit code 2):
/// attached as context to the error that says why, e.g. `Scenario::load(..).map_err(refused)`.
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

/// `key` must be a finite number.
pub fn fin(key: &str, v: f64) -> Result<()> {
    if !v.is_finite() {
        bail!("{key} must be a finite number (got {v})");
    }
    Ok(())
}

/// `key` must be finite and > 0.
pub fn pos(key: &str, v: f64) -> Result<()> {
    fin(key, v)?;
    if v <= 0.0 {
        bail!("{key} must be > 0 (got {v})");
    }
    Ok(())
}

/// `key` must be finite and >= 0.
pub fn nonneg(key: &str, v: f64) -> Result<()> {
    fin(key, v)?;
    if v < 0.0 {
        bail!("{key} must be >= 0 (got {v})");
    }
    Ok(())
}

/// Every component of `key` must be finite.
pub fn vec3(key: &str, v: [f64; 3]) -> Result<()> {
    for (i, x) in v.iter().enumerate() {
        fin(&format!("{key}[{i}]"), *x)?;
    }
    Ok(())
}
