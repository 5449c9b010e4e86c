//! The motor test (ArduSub's `MAV_CMD_DO_MOTOR_TEST`, `ArduSub/motors.cpp`): one thruster at
//! the pulse asked for, the others neutral, for the request's window (at most 0.5 s,
//! ArduSub's keep-alive; a station sends again to go on).
//!
//! - Taken only armed (`NotArmed`, ArduSub's "Arm motors before testing motors"), in any mode;
//!   a pulse outside the ESC's range (and the vehicle's PWM map) or a window outside
//!   1..=500 ms is refused `OutOfRange`; the test in force, if any, then goes on unchanged.
//! - Ends at the window's end with a disarm (ArduSub's `verify_motor_test`: a test that is
//!   not renewed disarms the vehicle), and without one on any other command the vehicle takes
//!   (a centred stick, a heartbeat, navigation and sensor input excepted), on a change of
//!   mode by a failsafe, on a lost heartbeat (neutral at once), on a disarm, on a new surface
//!   session. Arming starts without one, and a restart boots without one.
//! - The depth limit's cap applies to the vertical thruster's pulse as to every output.

use super::{Autopilot, MotorTestRun, StepOutput};
use crate::protocol::{Command, ManualThrust, MotorTest, NackReason};
use controller_core::alloc::Allocation;
use controller_core::state::BodyForces;

/// Does the vehicle taking `cmd` end a motor test? Everything but the keep-alives, the
/// navigation and sensor inputs, a centred stick and the test itself.
fn ends_motor_test(cmd: &Command) -> bool {
    let centred = |m: &ManualThrust| {
        [m.surge, m.yaw, m.heave]
            .iter()
            .all(|v| v.abs() <= super::STICK_CENTRED)
    };
    match cmd {
        Command::Heartbeat { .. }
        | Command::Nav(_)
        | Command::Step { .. }
        | Command::MotorTest(_) => false,
        Command::Imu(_)
        | Command::Pressure { .. }
        | Command::UsblFix(_)
        | Command::DvlFix(_)
        | Command::Compass(_) => false,
        Command::ManualThrust(m) => !centred(m),
        _ => true,
    }
}

impl Autopilot {
    /// A motor test request received at `now_us` (validated; on `Err` the test in force, if
    /// any, goes on unchanged).
    pub(super) fn start_motor_test(
        &mut self,
        now_us: u64,
        test: &MotorTest,
    ) -> Result<(), NackReason> {
        if !self.armed {
            return Err(NackReason::NotArmed);
        }
        let pwm = self.controller.pwm_map();
        let pulse = f32::from(test.pulse_us);
        if !test.is_valid() || pulse < pwm.min_us || pulse > pwm.max_us {
            return Err(NackReason::OutOfRange);
        }
        self.abort_swing();
        self.abort_ident(super::IdentAbort::ModeChange);
        self.motor_test = Some(MotorTestRun {
            test: *test,
            until_us: now_us.saturating_add(u64::from(test.window_ms) * 1000),
            mode: self.mode,
        });
        Ok(())
    }

    /// After a command was taken: one that is not part of the test ends it.
    pub(super) fn after_command(&mut self, cmd: &Command) {
        if ends_motor_test(cmd) {
            self.motor_test = None;
        }
    }

    /// The motor test in force, if any: its request.
    pub fn motor_test(&self) -> Option<MotorTest> {
        self.motor_test.map(|r| r.test)
    }

    /// The step of a motor test in force (armed, heartbeat fresh: checked by the caller):
    /// its thruster at its pulse, the others neutral; at its end, or when a failsafe changed
    /// the mode, the test ends (the former with a disarm) and `None` lets the step go on.
    pub(super) fn motor_test_step(&mut self, now_us: u64, faults: u16) -> Option<StepOutput> {
        let run = self.motor_test?;
        if run.mode != self.mode {
            self.motor_test = None;
            return None;
        }
        if now_us >= run.until_us {
            self.motor_test = None;
            self.disarm();
            return Some(self.neutral(faults));
        }
        let pwm = self.controller.pwm_map();
        let pulse = f32::from(run.test.pulse_us);
        let mut out = self.neutral(faults);
        let mut thrust_n = [0.0f32; 3];
        if let (Some(p), Some(f)) = (
            out.pulse_us.get_mut(usize::from(run.test.thruster)),
            thrust_n.get_mut(usize::from(run.test.thruster)),
        ) {
            *p = pulse;
            *f = pwm.thrust_n(pulse);
        }
        let [f1, f2, f3] = thrust_n;
        let achieved = BodyForces {
            surge_n: f1 + f2,
            yaw_n_m: self.controller.limits().lever_arm_m * (f1 - f2),
            heave_n: f3,
        };
        out.requested = achieved;
        out.allocation = Allocation {
            thrust_n,
            achieved,
            saturated: false,
        };
        Some(out)
    }
}
