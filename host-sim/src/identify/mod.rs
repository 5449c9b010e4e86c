//! System identification: from a recorded run to a vehicle file (`host-sim identify`,
//! docs/identification.md).
//!
//! - [`regression`]: linear least squares (nalgebra's SVD) with the parameters' covariance
//!   and the refusal of a record that does not excite a regressor.
//! - [`record`]: a run's `timeseries.csv` as the fit reads it; the pulses as the prior's
//!   nominal thrust.
//! - [`fit`]: the per-axis integral-form regressions, the anchor that gives them newtons,
//!   the physical model with 95 % intervals.
//! - [`validate`]: the held-out blocks simulated with the identified model and the prior;
//!   RMS figures and a plot.
//! - [`vehicle_file`]: the identified vehicle file.

pub mod fit;
pub mod record;
pub mod regression;
pub mod validate;
pub mod vehicle_file;

use anyhow::Result;
use controller_core::params::VehicleParams;
pub use fit::{Anchor, Identified};
pub use record::Record;

/// Everything one identification gives.
pub struct Outcome {
    /// The model and its intervals.
    pub identified: Identified,
    /// The identified vehicle's parameters (what the vehicle file holds).
    pub params: VehicleParams,
    /// Held-out prediction with the identified model.
    pub validation: validate::Prediction,
    /// The same with the prior.
    pub prior_validation: validate::Prediction,
}

/// Identify a vehicle from a record, starting from `prior`.
pub fn identify(rec: &Record, prior: &VehicleParams, anchor: Anchor) -> Result<Outcome> {
    rec.check()?;
    let thrust = rec.nominal_thrust_n(prior)?;
    let axes = fit::fit_axes(rec, &thrust, prior)?;
    let identified = fit::physical(axes, anchor);
    let params = vehicle_file::identified_params(&identified, prior);
    let validation = validate::predict(&identified.model, prior, rec, &thrust);
    let prior_validation = validate::predict(&validate::prior_model(prior), prior, rec, &thrust);
    Ok(Outcome {
        identified,
        params,
        validation,
        prior_validation,
    })
}
