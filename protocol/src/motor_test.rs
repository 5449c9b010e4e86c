//! The motor test (version 8): one thruster at a set pulse for a short window, as ArduSub's
//! `MAV_CMD_DO_MOTOR_TEST` drives it. Each request runs the thruster for at most
//! [`MotorTest::MAX_WINDOW_MS`] (ArduSub's keep-alive: the station sends again to go on);
//! the vehicle takes it only armed, and the test ends at the window's end (the vehicle then
//! disarms, as ArduSub does), on any other command, on a lost heartbeat or a disarm.

use serde::{Deserialize, Serialize};

/// One motor test request.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct MotorTest {
    /// The thruster, in the tether's order: 0 the left horizontal (`F1x`), 1 the right
    /// horizontal (`F2x`), 2 the vertical (`F3z`).
    pub thruster: u8,
    /// Pulse width sent to that thruster's ESC (microseconds, within
    /// [`MotorTest::MIN_PULSE_US`]..=[`MotorTest::MAX_PULSE_US`]); the others are neutral.
    pub pulse_us: u16,
    /// How long this request runs the thruster (ms, 1..=[`MotorTest::MAX_WINDOW_MS`]).
    pub window_ms: u16,
}

impl MotorTest {
    /// Thrusters on the vehicle.
    pub const THRUSTERS: u8 = 3;
    /// Shortest pulse (full reverse): the ESC's range.
    pub const MIN_PULSE_US: u16 = 1100;
    /// Longest pulse (full forward): the ESC's range.
    pub const MAX_PULSE_US: u16 = 1900;
    /// Longest window of one request: ArduSub's keep-alive (a test not renewed within
    /// 0.5 s times out).
    pub const MAX_WINDOW_MS: u16 = 500;

    /// True when the thruster exists, the pulse is within the ESC's range and the window
    /// within 1..=[`Self::MAX_WINDOW_MS`] (the vehicle refuses anything else `OutOfRange`).
    pub fn is_valid(&self) -> bool {
        self.thruster < Self::THRUSTERS
            && (Self::MIN_PULSE_US..=Self::MAX_PULSE_US).contains(&self.pulse_us)
            && (1..=Self::MAX_WINDOW_MS).contains(&self.window_ms)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_request_out_of_range_is_refused() {
        let good = MotorTest {
            thruster: 2,
            pulse_us: 1600,
            window_ms: 500,
        };
        assert!(good.is_valid());
        for bad in [
            MotorTest {
                thruster: 3,
                ..good
            },
            MotorTest {
                pulse_us: 1099,
                ..good
            },
            MotorTest {
                pulse_us: 1901,
                ..good
            },
            MotorTest {
                window_ms: 0,
                ..good
            },
            MotorTest {
                window_ms: 501,
                ..good
            },
        ] {
            assert!(!bad.is_valid(), "{bad:?}");
        }
    }
}
