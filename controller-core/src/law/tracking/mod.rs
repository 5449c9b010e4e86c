//! Laws that really track (issue 3). PLACEHOLDER: being written.

use super::LawOutput;
use crate::error::{positive, Error};
use crate::params::Vehicle;
use crate::reference::RefSample;
use crate::state::{BodyForces, NavState};
use serde::{Deserialize, Serialize};

/// Gains of the tracking laws.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TrackingGains {
    /// Position loop bandwidth.
    pub position_rad_s: f32,
}

impl TrackingGains {
    /// Refuse non-finite or non-positive gains.
    pub fn validate(&self) -> Result<(), Error> {
        positive("position_rad_s", self.position_rad_s)?;
        Ok(())
    }
}

impl Default for TrackingGains {
    fn default() -> Self {
        Self {
            position_rad_s: 0.5,
        }
    }
}

/// Internal state of the tracking laws (integrators, filters).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TrackingState {}

impl TrackingState {
    /// Tell the law what the thrusters really delivered (anti-windup).
    pub fn on_allocation(&mut self, _requested: &BodyForces, _achieved: &BodyForces) {}
}

/// XZ tracking step. PLACEHOLDER.
pub fn step_xz(
    _v: &Vehicle,
    _g: &TrackingGains,
    _st: &mut TrackingState,
    _nav: &NavState,
    _r: &RefSample,
    _dt_s: f32,
) -> LawOutput {
    LawOutput::default()
}

/// XY tracking step. PLACEHOLDER.
pub fn step_xy(
    _v: &Vehicle,
    _g: &TrackingGains,
    _st: &mut TrackingState,
    _nav: &NavState,
    _r: &RefSample,
    _dt_s: f32,
) -> LawOutput {
    LawOutput::default()
}

/// 3-D tracking step (XY law + depth law). PLACEHOLDER.
pub fn step_3d(
    _v: &Vehicle,
    _g: &TrackingGains,
    _st: &mut TrackingState,
    _nav: &NavState,
    _r: &RefSample,
    _dt_s: f32,
) -> LawOutput {
    LawOutput::default()
}
