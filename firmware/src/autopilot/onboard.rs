//! The on-board estimator's commands: its start, its sensor readings and fixes, and the
//! compass calibration it uses.

use super::{check_nav, Autopilot, OWN_READING};
use crate::protocol::{Command, DvlReport, NackReason};
use controller_core::nav::compass_cal::CompassCalibration;
use controller_core::nav::onboard::OnboardNav;
use controller_core::nav::Refusal;

impl Autopilot {
    /// Apply `f` to the on-board estimator (refused without one), recording `seq`.
    pub(super) fn feed(
        &mut self,
        seq: u16,
        f: impl FnOnce(&mut OnboardNav, [f32; 3]) -> Result<(), Refusal>,
    ) -> Result<(), NackReason> {
        let thrust = self.thrust_cmd_n;
        let o = self.onboard.as_mut().ok_or(NackReason::NavSource)?;
        f(o, thrust).map_err(NackReason::NavRefused)?;
        // The number of the last tether input taken, which the lock-step telemetry answers;
        // the vehicle's own readings (its IMU, pressure sensor and DVL: number 0, which no
        // tether command carries after its session's opening) do not move it.
        if seq != OWN_READING {
            self.onboard_seq = seq;
        }
        Ok(())
    }

    /// Apply one of the on-board estimator's commands (`StartNav`, `Imu`, `Pressure`,
    /// `UsblFix`, `DvlFix`, `Compass`); on `Err` nothing changed. Kept out of [`handle`]
    /// (`Self::handle`) because the link-time no-panic proof does not hold through the
    /// estimator: the `heapless` history ring it keeps leaves indexing paths the compiler
    /// cannot remove. Its inputs are fuzzed instead (`tests/tests/fuzz.rs`). Out of line, so
    /// that the temporaries of a new estimator (`StartNav`) are not in every command's frame.
    #[inline(never)]
    pub fn handle_nav(&mut self, now_us: u64, seq: u16, cmd: &Command) -> Result<(), NackReason> {
        match cmd {
            Command::StartNav {
                t_us,
                initial,
                config,
            } => {
                check_nav(initial)?;
                let vehicle = *self.controller.vehicle();
                let mut o = OnboardNav::new(vehicle, *config, initial, *t_us, now_us)?;
                // Checked when it was set.
                o.set_compass_calibration(&self.compass_cal)
                    .map_err(NackReason::CompassCal)?;
                // A restart (an estimator running) re-seeds the position, depth and heading;
                // where the running estimate agrees with the new start, it keeps what the
                // running one learned of the instruments and the water.
                if let Some(running) = self.onboard.as_ref() {
                    o.keep_learned(running);
                }
                self.onboard = Some(o);
                self.onboard_seq = seq;
                Ok(())
            }
            Command::Imu(s) => {
                let [_, _, raw_r] = s.gyro_rad_s;
                self.feed_swing(seq, raw_r, Some(s.t_us), |o, thrust| {
                    o.imu(now_us, s, thrust)
                })
            }
            Command::Pressure { t_us, pressure_pa } => {
                self.feed(seq, |o, _| o.pressure(now_us, *t_us, *pressure_pa))
            }
            Command::UsblFix(f) => self.feed(seq, |o, _| o.position(f)),
            Command::DvlFix(f) => {
                let r = self.feed(seq, |o, _| o.dvl(f));
                // A sound measurement is recorded even when the estimator's gate refuses it
                // (`Outlier`: its model disagrees, which is what a log for identifying the
                // model must keep); a broken or mistimed one is not.
                if matches!(r, Ok(()) | Err(NackReason::NavRefused(Refusal::Outlier))) {
                    self.last_dvl = DvlReport {
                        t_us: f.t_us,
                        velocity_m_s: f.velocity_m_s,
                    };
                }
                r
            }
            // The raw reading to a turn (the estimator takes the calibration off its copy).
            Command::Compass(f) => self.feed_swing(seq, f.yaw_rad, None, |o, _| o.heading(f)),
            Command::SetCompassCal(cal) => self.set_compass_calibration(cal),
            _ => self.handle(now_us, seq, cmd),
        }
    }

    /// A new compass calibration (`COMPASS_DEV_*`): only disarmed (a new deviation turns
    /// the heading the laws fly on), checked (finite, within 30 degrees); used by the
    /// running on-board estimator at once and by every one started later. On a refusal the
    /// calibration in force stays.
    pub fn set_compass_calibration(&mut self, cal: &CompassCalibration) -> Result<(), NackReason> {
        if self.armed {
            return Err(NackReason::Armed);
        }
        let cal = cal.validate().map_err(NackReason::CompassCal)?;
        if let Some(o) = self.onboard.as_mut() {
            o.set_compass_calibration(&cal)
                .map_err(NackReason::CompassCal)?;
        }
        self.compass_cal = cal;
        Ok(())
    }

    /// The compass calibration in force.
    pub fn compass_calibration(&self) -> CompassCalibration {
        self.compass_cal
    }

    /// The latest sound DVL velocity the on-board estimator was given (fused, or refused only
    /// by its outlier gate), as the instrument measured it (zeros before the first): the
    /// telemetry's record of the vehicle's own speed.
    pub fn last_dvl(&self) -> DvlReport {
        self.last_dvl
    }
}
