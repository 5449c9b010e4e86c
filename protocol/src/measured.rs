//! The vehicle's own measurements as it took them, reported beside the estimate: what a
//! dive's log needs to see the vehicle through its instruments rather than through the
//! estimator's model (the identification of a vehicle from its log, docs/identification.md).

use serde::{Deserialize, Serialize};

/// The latest DVL velocity the vehicle took (its own instrument's reading, or a tether
/// `DvlFix`, given to the on-board estimator: fused, or refused only by its outlier gate), in
/// [`Telemetry::dvl`](crate::Telemetry::dvl) (version 8). The on-board estimate is
/// model-aided with the vehicle file the vehicle was given, and its gate refuses the readings
/// that model disagrees with most; this is the instrument's measurement alone.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct DvlReport {
    /// Time of validity of the measurement (the sensor's time, microseconds); 0 before the
    /// first accepted one.
    pub t_us: u64,
    /// Surge and sway speed over the bottom, body axes `[u, v]` (m/s).
    pub velocity_m_s: [f32; 2],
}

impl DvlReport {
    /// True once a measurement was accepted.
    pub fn is_some(&self) -> bool {
        self.t_us != 0
    }
}
