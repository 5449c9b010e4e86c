//! The compass calibration turn as a flown manoeuvre (issue 26; ArduPilot's
//! `MAV_CMD_DO_START_MAG_CAL`): armed in `Hold` with the on-board estimate ready, the vehicle
//! turns a full circle in place at a yaw rate, holding its depth and, as well as an
//! underactuated vehicle can, its position (the surge thrust takes the along-heading part of
//! the position error; the across part it cannot act on while turning). During the turn the
//! estimator's bias-corrected yaw rate (the gyro-propagated heading) and every raw compass
//! reading go to [`CompassSwing`], whose fit (`controller_core::nav::compass_cal`) becomes the
//! calibration in force when it is accepted; a refusal (less than a full circle within the
//! time limit, too few readings, too large a residual, out of range) keeps the old one. The
//! outcome is reported in every `Status` ([`SwingOutcome`]).
//!
//! `no_std`, `f32`, no allocation, no panic path.

use controller_core::law::pilot::Sticks;
use controller_core::math::sin_cos;
use controller_core::nav::compass_cal::{CalRefusal, CompassCalibration, CompassSwing};
use controller_core::state::NavState;
use serde::{Deserialize, Serialize};

/// The turn goes on this far past a full circle, so that the fit (which needs `2 pi` of the
/// gyro's heading change) sees every heading at least once with some margin (rad, 20 deg).
const OVERTURN_RAD: f32 = 0.35;
/// Surge stick per metre of along-heading position error (1/m), and its limit.
const SURGE_PER_M: f32 = 0.3;
const SURGE_MAX: f32 = 0.15;
/// Yaw stick: feed-forward per rad/s of the target rate and feedback per rad/s of rate error.
const YAW_FF_PER_RAD_S: f32 = 0.4;
const YAW_FB_PER_RAD_S: f32 = 0.8;
const YAW_MAX: f32 = 0.5;
/// Slowest and fastest yaw rate accepted (rad/s): slower than 0.05 a turn takes over two
/// minutes; faster than 0.6 the compass (10 Hz) sees too few headings per cycle.
pub const RATE_MIN_RAD_S: f32 = 0.05;
/// See [`RATE_MIN_RAD_S`].
pub const RATE_MAX_RAD_S: f32 = 0.6;
/// Longest time limit accepted (s).
pub const TIME_LIMIT_MAX_S: f32 = 600.0;

/// A turn's fit: the calibration and its RMS residual (rad), or why it was refused.
pub type SwingFit = Result<(CompassCalibration, f32), CalRefusal>;

/// How the latest calibration turn ended (or that one is flying), reported in `Status`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub enum SwingOutcome {
    /// None flown since boot.
    #[default]
    None,
    /// Turning now: the heading turned so far (rad).
    Turning {
        /// Heading turned (rad, the gyro's).
        turned_rad: f32,
    },
    /// Accepted: the calibration now in force and the fit's RMS residual (rad).
    Accepted {
        /// The fitted deviation, in force.
        cal: CompassCalibration,
        /// RMS residual of the fit (rad).
        residual_rad: f32,
    },
    /// Refused: why; the calibration in force did not change.
    Refused(CalRefusal),
    /// Stopped before its end (disarmed, a mode change, the estimator stopped); the
    /// calibration in force did not change.
    Aborted,
}

/// A calibration turn in flight.
#[derive(Debug, Clone, Copy)]
pub struct SwingFlight {
    swing: CompassSwing,
    /// Where the turn started (held horizontally), and its depth (held).
    hold_m: [f32; 3],
    yaw_rate_rad_s: f32,
    time_limit_s: f32,
    elapsed_s: f32,
}

impl SwingFlight {
    /// A turn from `nav` at `yaw_rate_rad_s` (either sign), ending with a refusal if not
    /// done within `time_limit_s`. `None` when the rate or the limit is out of range.
    pub fn new(nav: &NavState, yaw_rate_rad_s: f32, time_limit_s: f32) -> Option<Self> {
        let rate_ok = (RATE_MIN_RAD_S..=RATE_MAX_RAD_S).contains(&yaw_rate_rad_s.abs());
        let limit_ok = time_limit_s > 0.0 && time_limit_s <= TIME_LIMIT_MAX_S;
        (rate_ok && limit_ok).then_some(Self {
            swing: CompassSwing::new(),
            hold_m: [nav.x_m, nav.y_m, nav.z_m],
            yaw_rate_rad_s,
            time_limit_s,
            elapsed_s: 0.0,
        })
    }

    /// Where the turn started: the point held after it.
    pub fn hold_m(&self) -> [f32; 3] {
        self.hold_m
    }

    /// A raw compass reading (before any calibration), made now.
    pub fn reading(&mut self, yaw_rad: f32) {
        self.swing.reading(yaw_rad);
    }

    /// One control step of `dt_s` on the estimate `nav`: the heading change integrated from
    /// its bias-corrected yaw rate, and the pilot's sticks that fly the turn (depth held by
    /// the law). `Some(outcome)` when the turn is over (a full circle and the overturn, or
    /// the time limit): the fit, accepted or refused.
    pub fn step(&mut self, nav: &NavState, dt_s: f32) -> (Sticks, Option<SwingFit>) {
        self.swing.rate(nav.r_rad_s, dt_s);
        self.elapsed_s += dt_s;
        let done = self.swing.turned_rad().abs() >= 2.0 * core::f32::consts::PI + OVERTURN_RAD;
        if done || self.elapsed_s >= self.time_limit_s {
            return (Sticks::default(), Some(self.swing.fit()));
        }
        let (s, c) = sin_cos(nav.yaw_rad);
        let along_m = (self.hold_m[0] - nav.x_m) * c + (self.hold_m[1] - nav.y_m) * s;
        let yaw = YAW_FF_PER_RAD_S * self.yaw_rate_rad_s
            + YAW_FB_PER_RAD_S * (self.yaw_rate_rad_s - nav.r_rad_s);
        let sticks = Sticks {
            surge: (SURGE_PER_M * along_m).clamp(-SURGE_MAX, SURGE_MAX),
            yaw: yaw.clamp(-YAW_MAX, YAW_MAX),
            heave: 0.0,
        };
        (sticks, None)
    }

    /// Heading turned so far (rad).
    pub fn turned_rad(&self) -> f32 {
        self.swing.turned_rad()
    }
}
