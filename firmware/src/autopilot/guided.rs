//! GUIDED (ArduSub's mode 4): the vehicle holds where the mode was entered (or where it
//! armed) with the 3-D tracking law, goes to each target the surface sends
//! (`Command::GuidedTarget`) and holds it there. A target is a point to hold, reached by the
//! law as a step: the same flight as HOLD's, on another point.
//!
//! Guards, as HOLD's: entered only with a fresh navigation state and the on-board estimate
//! ready; a target only armed and in GUIDED, within a mission's limits and above the depth
//! limit; the failsafes and the depth cap act as in every mode. A stick off centre stops the
//! go-to: the vehicle holds where it is (ArduSub gives its pilot the vehicle back the same
//! way), and a new target is needed to go on.

use super::{Autopilot, STICK_CENTRED};
use crate::protocol::limits::check_mission_item;
use crate::protocol::{ManualThrust, Mode, NackReason};
use controller_core::reference::{Bounds, Reference};

impl Autopilot {
    /// Take a GUIDED target: armed (`NotArmed`) in GUIDED (`NotInGuided`), finite
    /// (`NonFinite`), within a mission's range and depth (`OutOfRange`), above the depth
    /// limit (`DepthLimit`). Flown from `now_us`; on `Err` nothing changed.
    pub(super) fn guided_target(&mut self, now_us: u64, pos_m: [f32; 3]) -> Result<(), NackReason> {
        if self.mode != Mode::Guided {
            return Err(NackReason::NotInGuided);
        }
        if !self.armed {
            return Err(NackReason::NotArmed);
        }
        // One waypoint of a one-point mission, at the slowest speed checked (the speed is
        // not flown: the law goes to a hold point).
        check_mission_item(0, 1, pos_m, 1.0)?;
        let r = Reference::Hold { pos_m };
        r.check_bounds(&Bounds::VEHICLE).map_err(NackReason::from)?;
        self.check_reference_depth(&r)?;
        self.hold = Some((r, now_us));
        Ok(())
    }

    /// The pilot's input in GUIDED: a stick off centre (once the sticks were seen at centre,
    /// [`Self::sticks_may_act`]) stops the go-to where the vehicle is.
    pub(super) fn guided_sticks(&mut self, now_us: u64, m: &ManualThrust) {
        if self.mode != Mode::Guided || !self.armed {
            return;
        }
        let m = self.sticks_may_act(*m);
        if [m.surge, m.yaw, m.heave]
            .iter()
            .any(|v| v.abs() > STICK_CENTRED)
        {
            let s = self.nav_state();
            let here_m = [s.x_m, s.y_m, s.z_m];
            self.hold = Some((Reference::Hold { pos_m: here_m }, now_us));
        }
    }

    /// The point GUIDED holds or goes to now (`None` outside GUIDED or disarmed).
    pub fn guided_point(&self) -> Option<[f32; 3]> {
        match (self.mode, self.armed, &self.hold) {
            (Mode::Guided, true, Some((Reference::Hold { pos_m }, _))) => Some(*pos_m),
            _ => None,
        }
    }
}
