//! The crate's one error type.

use core::fmt;

/// Why a parameter set, gain set, reference or command was refused.
///
/// Every constructor that takes numbers from outside validates them once and returns this;
/// the control step itself has no error path.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Error {
    /// A value was NaN or infinite. The payload names the field.
    NonFinite(&'static str),
    /// A value that must be strictly positive was zero or negative.
    NotPositive(&'static str),
    /// A value that must not be negative was negative.
    Negative(&'static str),
    /// A value was outside its documented range.
    OutOfRange(&'static str),
    /// The parameters describe a vehicle the model cannot represent
    /// (for example a singular mass matrix).
    NonPhysical(&'static str),
    /// A gain outside the range its law stays stable with at the control period, given the
    /// law's other gains ([`crate::law::gain_bounds`]).
    GainRange {
        /// The gain.
        name: &'static str,
        /// The value refused.
        value: f32,
        /// Smallest value accepted.
        min: f32,
        /// Largest value accepted.
        max: f32,
    },
}

// The range's numbers are finite constants and the value is checked finite before any range
// is: equality is reflexive for every error made.
impl Eq for Error {}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::NonFinite(name) => write!(f, "{name} is not finite"),
            Error::NotPositive(name) => write!(f, "{name} must be > 0"),
            Error::Negative(name) => write!(f, "{name} must be >= 0"),
            Error::OutOfRange(name) => write!(f, "{name} is out of range"),
            Error::NonPhysical(name) => write!(f, "non-physical parameters: {name}"),
            Error::GainRange {
                name,
                value,
                min,
                max,
            } => write!(
                f,
                "{name} = {value:?} is outside {min:.3}..={max:.3}, the range its law stays \
                 stable in at a 20 ms control period with its other gains (docs/safety.md, \
                 Gain bounds)"
            ),
        }
    }
}

impl core::error::Error for Error {}

/// Check that `value` is finite.
pub(crate) fn finite(name: &'static str, value: f32) -> Result<f32, Error> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(Error::NonFinite(name))
    }
}

/// Check that `value` is finite and strictly positive.
pub(crate) fn positive(name: &'static str, value: f32) -> Result<f32, Error> {
    let v = finite(name, value)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(Error::NotPositive(name))
    }
}

/// Check that `value` is finite and not negative.
pub(crate) fn non_negative(name: &'static str, value: f32) -> Result<f32, Error> {
    let v = finite(name, value)?;
    if v >= 0.0 {
        Ok(v)
    } else {
        Err(Error::Negative(name))
    }
}
