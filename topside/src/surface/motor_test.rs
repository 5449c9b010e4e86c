//! The motor test from a ground station: `MAV_CMD_DO_MOTOR_TEST` (QGroundControl's Motors
//! page, MAVProxy's `motortest`) read as ArduSub reads it (`ArduSub/motors.cpp`) and sent to
//! the vehicle as the tether's `MotorTest`:
//!
//! | param | meaning | taken |
//! |---|---|---|
//! | 1 | motor | 1 port horizontal (`F1x`), 2 starboard horizontal (`F2x`), 3 vertical (`F3z`) |
//! | 2 | throttle type | 0 percent (0-100, 50 neutral: ArduSub maps it onto 1100-1900 us), 1 PWM (1100-1900 us); 2 pilot and 3 compass are refused, as ArduSub refuses the pilot's |
//! | 3 | throttle | in the type's range; outside it refused (not clipped) |
//! | 4 | timeout (s) | 0 (or more than 0.5) is ArduSub's keep-alive, 0.5 s; less shortens it |
//! | 5 | motor count | 0 or 1: one thruster at a time |
//! | 6 | test order | 0 (default) or 2 (board order: the motor number is the output) |
//!
//! The vehicle takes it only armed (ArduSub: "Arm motors before testing motors") and runs the
//! thruster for the window; a station sends it again within the window to go on. At the
//! window's end the vehicle disarms, as ArduSub does ("Motor test timed out!"), and every
//! station is told. A station not in control is refused by the commander as for any command.

use super::topside::Topside;
use anyhow::Result;
use mavlink::dialects::ardupilotmega::{MavCmd, MavResult, MavSeverity};
use protocol::{Command, MotorTest};

/// ArduSub's keep-alive: a test not renewed within it ends (s).
pub const KEEP_ALIVE_S: f32 = MotorTest::MAX_WINDOW_MS as f32 / 1000.0;

/// The thrusters as a ground station numbers them (from 1).
const MOTORS: [&str; 3] = ["port horizontal", "starboard horizontal", "vertical"];

/// `MAV_CMD_DO_MOTOR_TEST`'s parameters 1-6.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotorTestParams {
    /// Motor number (from 1).
    pub motor: f32,
    /// `MOTOR_TEST_THROTTLE_TYPE`.
    pub throttle_type: f32,
    /// Throttle, in the type's unit.
    pub throttle: f32,
    /// Timeout (s).
    pub timeout_s: f32,
    /// Motors to test in sequence.
    pub motor_count: f32,
    /// `MOTOR_TEST_ORDER`.
    pub order: f32,
}

/// A whole number within `lo..=hi`.
fn whole_in(v: f32, lo: f32, hi: f32) -> bool {
    v.is_finite() && v.fract() == 0.0 && (lo..=hi).contains(&v)
}

/// The tether's request for `p`, or why it is refused (in words, with the range allowed).
pub fn request_of(p: &MotorTestParams) -> Result<MotorTest, String> {
    let pre = "Motor test refused";
    if !whole_in(p.motor, 1.0, 3.0) {
        return Err(format!(
            "{pre}: motor {} does not exist (1 port, 2 starboard, 3 vertical)",
            p.motor
        ));
    }
    if !(p.order == 0.0 || p.order == 2.0) {
        return Err(format!(
            "{pre}: test order {} is not offered (0 default or 2 board order)",
            p.order
        ));
    }
    if !(p.motor_count == 0.0 || p.motor_count == 1.0) {
        return Err(format!(
            "{pre}: motor count {}: one thruster at a time (0 or 1)",
            p.motor_count
        ));
    }
    let (lo, hi) = (
        f32::from(MotorTest::MIN_PULSE_US),
        f32::from(MotorTest::MAX_PULSE_US),
    );
    let pulse_us = if p.throttle_type == 0.0 {
        if !(p.throttle.is_finite() && (0.0..=100.0).contains(&p.throttle)) {
            return Err(format!(
                "{pre}: throttle {} % outside 0-100 (50 is neutral)",
                p.throttle
            ));
        }
        lo + p.throttle / 100.0 * (hi - lo)
    } else if p.throttle_type == 1.0 {
        if !(p.throttle.is_finite() && (lo..=hi).contains(&p.throttle)) {
            return Err(format!(
                "{pre}: PWM {} us outside {lo:.0}-{hi:.0} us",
                p.throttle
            ));
        }
        p.throttle
    } else {
        return Err(format!(
            "{pre}: throttle type {} is not offered (0 percent, 1 PWM)",
            p.throttle_type
        ));
    };
    if !(p.timeout_s.is_finite() && p.timeout_s >= 0.0) {
        return Err(format!(
            "{pre}: timeout {} s must be 0 or more (0 is {KEEP_ALIVE_S} s)",
            p.timeout_s
        ));
    }
    let window_s = if p.timeout_s == 0.0 {
        KEEP_ALIVE_S
    } else {
        p.timeout_s.min(KEEP_ALIVE_S)
    };
    Ok(MotorTest {
        thruster: p.motor as u8 - 1,
        pulse_us: pulse_us.round() as u16,
        window_ms: ((window_s * 1000.0).round() as u16).max(1),
    })
}

impl Topside {
    /// `MAV_CMD_DO_MOTOR_TEST` from `station`: checked here (the reason in words), then the
    /// vehicle's own check (armed); `COMMAND_ACK` accepted or denied with a `STATUSTEXT`.
    pub(super) fn motor_test(
        &mut self,
        station: super::transport::StationId,
        p: &MotorTestParams,
    ) -> Result<()> {
        let cmd = MavCmd::MAV_CMD_DO_MOTOR_TEST;
        let test = match request_of(p) {
            Ok(t) => t,
            Err(why) => return self.refuse(station, cmd, &why),
        };
        // A renewal of the test in force leaves the outputs as they are: the pulse widths
        // reported since stay shown.
        let renewal = self
            .motor_test_until
            .is_some_and(|(_, t)| (t.thruster, t.pulse_us) == (test.thruster, test.pulse_us));
        let hidden = self.v.frames_before_pulses;
        match self.v.command(&Command::MotorTest(test))? {
            Ok(()) => {
                if renewal {
                    self.v.frames_before_pulses = hidden;
                }
                let until = self.v.t_s + f64::from(test.window_ms) * 1e-3;
                self.motor_test_until = Some((until, test));
                if !renewal {
                    let name = MOTORS.get(usize::from(test.thruster)).unwrap_or(&"");
                    let text = format!(
                        "Motor test: motor {} ({name}) at {} us for {:.1} s; send again within it to go on",
                        test.thruster + 1,
                        test.pulse_us,
                        f32::from(test.window_ms) / 1000.0
                    );
                    self.gcs.text(MavSeverity::MAV_SEVERITY_INFO, &text)?;
                }
                self.gcs.ack(station, cmd, MavResult::MAV_RESULT_ACCEPTED)
            }
            Err(why) => self.refuse(station, cmd, &format!("Motor test refused: {why}")),
        }
    }

    /// After each control period: a motor test whose window passed is over; the vehicle
    /// disarmed then (ArduSub's end of a test) is said to every station.
    pub(super) fn poll_motor_test(&mut self) -> Result<()> {
        let Some((until, _)) = self.motor_test_until else {
            return Ok(());
        };
        // A margin of a few periods for the vehicle's telemetry to show the end.
        if self.v.t_s < until + 5.0 * self.v.period_s {
            return Ok(());
        }
        self.motor_test_until = None;
        if !self.v.tel.armed {
            self.gcs.text(
                MavSeverity::MAV_SEVERITY_WARNING,
                "Motor test timed out: the vehicle disarmed (as ArduSub does; arm to test again)",
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(motor: f32, throttle_type: f32, throttle: f32, timeout_s: f32) -> MotorTestParams {
        MotorTestParams {
            motor,
            throttle_type,
            throttle,
            timeout_s,
            motor_count: 0.0,
            order: 0.0,
        }
    }

    #[test]
    fn percent_and_pwm_are_read_as_ardusub_reads_them() {
        let t = request_of(&params(1.0, 0.0, 50.0, 0.0));
        assert_eq!(
            t,
            Ok(MotorTest {
                thruster: 0,
                pulse_us: 1500,
                window_ms: 500
            })
        );
        let t = request_of(&params(3.0, 0.0, 100.0, 0.2));
        assert_eq!(
            t.map(|t| (t.thruster, t.pulse_us, t.window_ms)),
            Ok((2, 1900, 200))
        );
        let t = request_of(&params(2.0, 1.0, 1620.0, 3.0));
        assert_eq!(
            t.map(|t| (t.thruster, t.pulse_us, t.window_ms)),
            Ok((1, 1620, 500))
        );
    }

    #[test]
    fn a_bad_request_is_refused_in_words_with_the_range() {
        let board = MotorTestParams {
            order: 2.0,
            motor_count: 1.0,
            ..params(1.0, 1.0, 1600.0, 0.0)
        };
        assert!(request_of(&board).is_ok());
        for (p, says) in [
            (
                params(0.0, 1.0, 1600.0, 0.0),
                "1 port, 2 starboard, 3 vertical",
            ),
            (params(4.0, 1.0, 1600.0, 0.0), "motor 4 does not exist"),
            (params(1.5, 1.0, 1600.0, 0.0), "motor 1.5"),
            (params(f32::NAN, 1.0, 1600.0, 0.0), "motor NaN"),
            (params(1.0, 1.0, 2000.0, 0.0), "1100-1900 us"),
            (params(1.0, 1.0, f32::NAN, 0.0), "PWM NaN"),
            (params(1.0, 0.0, 101.0, 0.0), "outside 0-100"),
            (params(1.0, 0.0, -1.0, 0.0), "outside 0-100"),
            (
                params(1.0, 2.0, 50.0, 0.0),
                "throttle type 2 is not offered",
            ),
            (params(1.0, 1.0, 1600.0, -1.0), "must be 0 or more"),
            (
                MotorTestParams {
                    motor_count: 3.0,
                    ..board
                },
                "one thruster at a time",
            ),
            (
                MotorTestParams {
                    order: 1.0,
                    ..board
                },
                "test order 1",
            ),
        ] {
            let why = request_of(&p).err().unwrap_or_default();
            assert!(why.starts_with("Motor test refused: "), "{why}");
            assert!(why.contains(says), "{p:?}: {why}");
        }
    }
}
