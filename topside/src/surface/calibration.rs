//! The compass calibration turn from the ground station: ArduPilot's
//! `MAV_CMD_DO_START_MAG_CAL` (42424) in a `COMMAND_LONG` becomes the firmware's
//! `StartCompassCal` (a full circle in place at [`YAW_RATE_RAD_S`], refused as not a full
//! turn after [`TIME_LIMIT_S`]; the command's own parameters, ArduPilot's magnetometer mask,
//! retry, autosave, delay and reboot, have no meaning here and are ignored). The vehicle
//! accepts it only armed in `Hold` (POSHOLD) with its estimate ready: the refusal's reason
//! goes back as `STATUSTEXT` with `COMMAND_ACK` `DENIED`.
//!
//! The outcome comes in the vehicle's `Status` ([`SwingOutcome`]); when a turn ends, every
//! station is told by `STATUSTEXT`; an accepted fit is the calibration in force on the
//! vehicle, so `COMPASS_DEV_SIN` / `COMPASS_DEV_COS` take its values (degrees), are saved
//! with the other parameters and sent to every station as `PARAM_VALUE`.

use super::params::{self, CompassDeviationDeg};
use super::telemetry;
use super::topside::Topside;
use anyhow::Result;
use firmware::compass_swing::SwingOutcome;
use mavlink::dialects::ardupilotmega::{MavCmd, MavResult, MavSeverity};
use protocol::Command;

/// Yaw rate of a turn started from the ground station (rad/s): a circle in about 25 s.
pub const YAW_RATE_RAD_S: f32 = 0.25;
/// Time limit of that turn (s): twice the circle's time.
pub const TIME_LIMIT_S: f32 = 60.0;

impl Topside {
    /// `MAV_CMD_DO_START_MAG_CAL` from `station`: the turn asked of the vehicle; accepted or
    /// refused with the vehicle's reason.
    pub(super) fn start_mag_cal(&mut self, station: super::transport::StationId) -> Result<()> {
        let cmd = MavCmd::MAV_CMD_DO_START_MAG_CAL;
        match self.v.command(&Command::StartCompassCal {
            yaw_rate_rad_s: YAW_RATE_RAD_S,
            time_limit_s: TIME_LIMIT_S,
        })? {
            Ok(()) => {
                self.mag_cal = None;
                self.gcs.text(
                    MavSeverity::MAV_SEVERITY_INFO,
                    "Compass calibration: turning a full circle in place",
                )?;
                self.gcs.ack(station, cmd, MavResult::MAV_RESULT_ACCEPTED)
            }
            Err(why) => self.refuse(station, cmd, &format!("Compass calibration refused: {why}")),
        }
    }

    /// After each control period: when the vehicle reports a turn that ended (and was not
    /// reported yet), tell every station; an accepted one sets `COMPASS_DEV_*`.
    pub(super) fn poll_mag_cal(&mut self) -> Result<()> {
        let Some(outcome) = self.v.last_status().map(|st| st.compass_swing) else {
            return Ok(());
        };
        let ended = matches!(
            outcome,
            SwingOutcome::Accepted { .. } | SwingOutcome::Refused(_) | SwingOutcome::Aborted
        );
        if !ended || self.mag_cal == Some(outcome) {
            return Ok(());
        }
        self.mag_cal = Some(outcome);
        match outcome {
            SwingOutcome::Accepted { cal, residual_rad } => {
                let deg = CompassDeviationDeg::of(&cal);
                self.v.settings.compass = deg;
                super::params_file::save(&self.params_file, &self.v.settings)?;
                self.gcs.text(
                    MavSeverity::MAV_SEVERITY_INFO,
                    &format!(
                        "Compass calibration accepted: COMPASS_DEV_SIN {:.2}, COMPASS_DEV_COS {:.2} deg (residual {:.2} deg)",
                        deg.sin_deg,
                        deg.cos_deg,
                        residual_rad.to_degrees()
                    ),
                )?;
                for name in ["COMPASS_DEV_SIN", "COMPASS_DEV_COS"] {
                    if let Some((i, _)) = params::find(name) {
                        telemetry::send_param(&mut self.gcs, &self.v.settings, i, None)?;
                    }
                }
                Ok(())
            }
            SwingOutcome::Refused(why) => self.gcs.text(
                MavSeverity::MAV_SEVERITY_WARNING,
                &format!(
                    "Compass calibration refused: {}; the old calibration stays",
                    super::words::compass(why)
                ),
            ),
            _ => self.gcs.text(
                MavSeverity::MAV_SEVERITY_WARNING,
                "Compass calibration stopped (disarmed or mode changed); the old calibration stays",
            ),
        }
    }
}
