//! The compass calibration turn, flown in `Hold`: its start, its steps and its end.

use super::Autopilot;
use crate::compass_swing::{SwingFlight, SwingOutcome};
use crate::protocol::{Mode, NackReason};
use controller_core::nav::onboard::OnboardNav;
use controller_core::nav::Refusal;
use controller_core::reference::Reference;
use controller_core::state::NavState;

impl Autopilot {
    /// [`Self::feed`], then, during a calibration turn, the raw value to it: a gyro rate
    /// about `z` at `Some(t_us)`, or (`None`) a compass reading.
    #[inline(never)]
    pub(super) fn feed_swing(
        &mut self,
        seq: u16,
        raw: f32,
        imu_t_us: Option<u64>,
        f: impl FnOnce(&mut OnboardNav, [f32; 3]) -> Result<(), Refusal>,
    ) -> Result<(), NackReason> {
        self.feed(seq, f)?;
        if let Some(flight) = self.swing.as_mut() {
            match imu_t_us {
                Some(t_us) => flight.imu(raw, t_us),
                None => flight.reading(raw),
            }
        }
        Ok(())
    }

    /// Stop a calibration turn in flight (the calibration in force stays).
    pub(super) fn abort_swing(&mut self) {
        if self.swing.take().is_some() {
            self.swing_outcome = SwingOutcome::Aborted;
        }
    }

    /// How the latest compass calibration turn ended, or that one is flying.
    pub fn swing_outcome(&self) -> SwingOutcome {
        self.swing_outcome
    }

    /// Start the compass calibration turn (`StartCompassCal`, the ground station's
    /// `MAV_CMD_DO_START_MAG_CAL`). Only armed (`NotArmed`), in `Hold` (`NotInHold`: not in
    /// AUTO, `Track` or the pilot modes), with the on-board estimator (`NavSource`), fresh
    /// (`NavStale`) and ready (`NavNotReady`), and a rate and limit in range (`OutOfRange`).
    /// A turn already flying starts again. On `Err` nothing changed.
    #[inline(never)]
    pub(super) fn start_swing(
        &mut self,
        now_us: u64,
        yaw_rate_rad_s: f32,
        time_limit_s: f32,
    ) -> Result<(), NackReason> {
        if !self.armed {
            return Err(NackReason::NotArmed);
        }
        if self.mode != Mode::Hold {
            return Err(NackReason::NotInHold);
        }
        let o = self.onboard.as_ref().ok_or(NackReason::NavSource)?;
        if !self.nav_fresh(now_us) {
            return Err(NackReason::NavStale);
        }
        o.position_ready().map_err(NackReason::NavNotReady)?;
        let nav = self.nav_state();
        let flight =
            SwingFlight::new(&nav, yaw_rate_rad_s, time_limit_s).ok_or(NackReason::OutOfRange)?;
        self.swing = Some(flight);
        self.swing_outcome = SwingOutcome::Turning { turned_rad: 0.0 };
        Ok(())
    }

    /// One control step of the calibration turn: its sticks, or, when it is over, the fit
    /// applied (accepted: the calibration in force, as `SetCompassCal` would set it; refused:
    /// the old one stays) and `Hold` again at the point where the turn started.
    #[inline(never)]
    pub(super) fn swing_step(
        &mut self,
        now_us: u64,
        nav: &NavState,
        dt_s: f32,
    ) -> Option<[f32; 2]> {
        let flight = self.swing.as_mut()?;
        let (forces, done) = flight.step(&self.controller.vehicle().xy, nav, dt_s);
        let Some(fit) = done else {
            self.swing_outcome = SwingOutcome::Turning {
                turned_rad: flight.turned_rad(),
            };
            return Some(forces);
        };
        let hold_m = flight.hold_m();
        self.swing = None;
        let applied = fit.and_then(|(cal, residual_rad)| {
            if let Some(o) = self.onboard.as_mut() {
                o.set_compass_calibration(&cal)?;
            }
            self.compass_cal = cal;
            Ok(SwingOutcome::Accepted { cal, residual_rad })
        });
        self.swing_outcome = applied.unwrap_or_else(SwingOutcome::Refused);
        self.controller.reset();
        self.hold = Some((Reference::Hold { pos_m: hold_m }, now_us));
        None
    }
}
