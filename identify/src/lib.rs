//! System identification: from a recorded run to a vehicle file (`host-sim identify` is its
//! command, docs/identification.md). A library of its own: it reads a run's `timeseries.csv`
//! and fits the core's `VehicleParams`, and needs nothing of the simulator (no plant, no
//! scenario, no plotting: the figure is drawn by `host-sim`).
//!
//! - [`regression`]: linear least squares (nalgebra's SVD) with the parameters' covariance
//!   and the refusal of a record that does not excite a regressor.
//! - [`record`]: a run's `timeseries.csv` as the fit reads it; the pulses as the prior's
//!   nominal thrust.
//! - [`tether_record`]: a dive's raw tether log as the same record (the vehicle's telemetry:
//!   its own estimate and the pulses it wrote).
//! - [`fit`]: the per-axis integral-form regressions.
//! - [`physical`]: the anchor that gives them newtons, the physical model with 95 %
//!   intervals.
//! - [`sway`]: sway's mass and drags from the turns (no sway thruster).
//! - [`thrusters`]: the installed thrusters' published curve (a thruster file), the
//!   anchor a builder has without weighing the vehicle.
//! - [`validate`]: the held-out blocks simulated with the identified model and the prior;
//!   RMS figures.
//! - [`vehicle_file`]: the identified vehicle file.

pub mod fit;
pub mod physical;
pub mod record;
pub mod regression;
pub mod sway;
pub mod tether_record;
pub mod thrusters;
pub mod validate;
pub mod vehicle_file;

use anyhow::Result;
use controller_core::params::VehicleParams;
pub use physical::{Anchor, Identified};
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
    /// Sway: fitted from the turns, or the prior's ratios and why.
    pub sway: sway::Sway,
}

/// Identify a vehicle from a record, starting from `prior`.
pub fn identify(rec: &Record, prior: &VehicleParams, anchor: Anchor) -> Result<Outcome> {
    rec.check()?;
    // The excitation is judged once, on the prior's lag (a refusal names the axes).
    fit::check_excitation(rec, &rec.nominal_thrust_n(prior)?, prior)?;
    let (axes, lag_s) = fit::fit_axes_with_lag(rec, prior)?;
    let thrust = rec.nominal_thrust_lagged_n(prior, lag_s)?;
    let mut identified = physical::physical(axes, anchor);
    identified.thruster_time_constant_s = lag_s;
    let lever = f64::from(prior.thruster_lever_arm_m);
    let ratios = vehicle_file::identified_params(&identified, prior, None);
    let known = sway::Known::from_model(&identified.model, identified.lo[0], identified.hi[0]);
    let sway = sway::fit_sway(rec, &thrust, lever, known, &ratios);
    let fitted_sway = match &sway {
        sway::Sway::Fitted(m) => Some(m),
        sway::Sway::Prior { .. } => None,
    };
    let params = vehicle_file::identified_params(&identified, prior, fitted_sway);
    let fitted = identified
        .axes
        .fits
        .clone()
        .map(|f| f.theta.iter().copied().collect::<Vec<f64>>());
    let validation = validate::predict(&fitted, lever, rec, &thrust);
    let prior_thrust = rec.nominal_thrust_n(prior)?;
    let prior_thetas = fit::Axis::ALL.map(|a| fit::prior_theta(a, prior));
    let prior_validation = validate::predict(&prior_thetas, lever, rec, &prior_thrust);
    Ok(Outcome {
        identified,
        params,
        validation,
        prior_validation,
        sway,
    })
}
