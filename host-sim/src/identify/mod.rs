//! System identification: from a recorded run to a vehicle file.
//!
//! - [`regression`]: linear least squares with parameter covariance and 95 % intervals,
//!   and the refusal of a record that does not excite a regressor.

pub mod regression;
