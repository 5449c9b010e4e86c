//! The checks every user-given number goes through: finite, positive, not negative; the
//! error names the key. Shared by the world's keys and the simulator's scenario keys.

use anyhow::{bail, Result};

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
