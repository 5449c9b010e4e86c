//! The vehicle's DVL readings to the ground stations and the `.tlog`: each new report the
//! vehicle took (`Telemetry::dvl`) once, as `DEBUG_VECT` named `"DVL"`: `time_usec` its time
//! of validity on the vehicle's clock, `x` and `y` the measured surge and sway over the bottom
//! (m/s), `z` NaN (not measured). MAVLink has no message for a DVL's measured velocity as an
//! autopilot reports it (ArduSub takes a DVL's `VISION_POSITION_DELTA` as an input); the
//! named vector lets a dive's `.tlog` carry what `host-sim identify dive.tlog` fits surge on,
//! and MAVExplorer and QGroundControl's analyze view plot it by name.

use super::topside::Topside;
use anyhow::Result;
use mavlink::dialects::ardupilotmega::{MavMessage, DEBUG_VECT_DATA};
use protocol::DvlReport;

/// The `DEBUG_VECT` name of a DVL report.
pub const DVL_DEBUG_VECT: &str = "DVL";

/// A DVL report as `DEBUG_VECT` `"DVL"`.
pub fn dvl_debug_vect(report: &DvlReport) -> MavMessage {
    MavMessage::DEBUG_VECT(DEBUG_VECT_DATA {
        time_usec: report.t_us,
        x: report.velocity_m_s[0],
        y: report.velocity_m_s[1],
        z: f32::NAN,
        name: DVL_DEBUG_VECT.into(),
    })
}

impl Topside {
    /// Every control period: a DVL report the vehicle took since the last one sent goes to
    /// every station (and so into the `.tlog`).
    pub(super) fn forward_dvl(&mut self) -> Result<()> {
        let report = self.v.tel.dvl;
        if !report.is_some() || report.t_us == self.dvl_sent_us {
            return Ok(());
        }
        self.dvl_sent_us = report.t_us;
        self.gcs.send(dvl_debug_vect(&report))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_report_is_a_named_vector_with_its_time_of_validity() {
        let r = DvlReport {
            t_us: 12_345_678,
            velocity_m_s: [0.25, -0.05],
        };
        let MavMessage::DEBUG_VECT(d) = dvl_debug_vect(&r) else {
            panic!("not a DEBUG_VECT");
        };
        assert_eq!(d.time_usec, 12_345_678);
        assert_eq!((d.x, d.y), (0.25, -0.05));
        assert!(d.z.is_nan());
        assert_eq!(d.name.to_str(), Ok("DVL"));
    }
}
