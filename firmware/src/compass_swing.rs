//! The compass calibration turn as a flown manoeuvre (issue 26; ArduPilot's
//! `MAV_CMD_DO_START_MAG_CAL`): armed in `Hold` with the on-board estimate ready, the vehicle
//! turns a full circle in place at a yaw rate, holding its depth and, as well as an
//! underactuated vehicle can, its position (the surge thrust takes the along-heading part of
//! the position error; the across part it cannot act on while turning). During the turn the
//! gyro's yaw rate less the estimator's bias at the start (the gyro-propagated heading) and every raw compass
//! reading go to [`CompassSwing`], whose fit (`controller_core::nav::compass_cal`) becomes the
//! calibration in force when it is accepted; a refusal (less than a full circle within the
//! time limit, too few readings, too large a residual, out of range) keeps the old one. The
//! outcome is reported in every `Status` ([`SwingOutcome`]).
//!
//! `no_std`, `f32`, no allocation, no panic path.

use controller_core::math::sin_cos;
use controller_core::nav::compass_cal::{CalRefusal, CompassCalibration, CompassSwing};
use controller_core::params::XyCoeffs;
use controller_core::state::NavState;

/// The turn goes on this far past a full circle, so that the fit (which needs `2 pi` of the
/// gyro's heading change) sees every heading at least once with some margin (rad, 20 deg).
const OVERTURN_RAD: f32 = 0.35;
/// Surge force per metre of along-heading position error (N/m), and its limit (N): a few
/// times the drag of a 0.2 m/s current, small enough that the compass offset that grows with
/// the thrusters' current (2 deg at 10 N in issue 26) varies by well under a degree as the
/// current's push turns with the heading (the fit would take that variation for deviation;
/// measured with a surge of up to 6 N: 1.36 deg of fit error).
const SURGE_N_PER_M: f32 = 2.0;
const SURGE_MAX_N: f32 = 1.5;
/// Yaw rate feedback (1/s) on top of the feed-forward of the drag at the target rate.
const YAW_RATE_GAIN_1_S: f32 = 2.0;

/// A turn's fit: the calibration and its RMS residual (rad), or why it was refused.
pub type SwingFit = Result<(CompassCalibration, f32), CalRefusal>;

/// How the latest calibration turn ended (or that one is flying), reported in `Status`: a
/// wire type, defined with the messages.
pub use protocol::SwingOutcome;

/// A calibration turn in flight.
#[derive(Debug, Clone, Copy)]
pub struct SwingFlight {
    swing: CompassSwing,
    /// Where the turn started (held horizontally), and its depth (held).
    hold_m: [f32; 3],
    yaw_rate_rad_s: f32,
    time_limit_s: f32,
    elapsed_s: f32,
    /// The estimator's bias-corrected yaw rate at the start (rad/s).
    start_r_rad_s: f32,
    /// The gyro bias about `z` held over the turn (rad/s): the first raw rate of the turn less
    /// the estimator's rate at the start. The estimator keeps correcting its own bias from
    /// the compass, so during a slow turn it would follow the very deviation the turn is to
    /// measure (measured: 1.9 deg of fit error at 0.25 rad/s with the estimator's running
    /// rate); what this one is off by (a sample's noise) is constant, and the fit's `d t`
    /// term takes a constant rate error.
    gyro_bias_rad_s: Option<f32>,
    /// Time of the previous IMU sample (us).
    last_imu_us: Option<u64>,
}

impl SwingFlight {
    /// A turn from `nav` at `yaw_rate_rad_s` (either sign), ending with a refusal if not
    /// done within `time_limit_s`. `None` when the rate or the limit is out of range
    /// ([`protocol::limits::compass_turn_in_range`]).
    pub fn new(nav: &NavState, yaw_rate_rad_s: f32, time_limit_s: f32) -> Option<Self> {
        protocol::limits::compass_turn_in_range(yaw_rate_rad_s, time_limit_s).then_some(Self {
            swing: CompassSwing::new(),
            hold_m: [nav.x_m, nav.y_m, nav.z_m],
            yaw_rate_rad_s,
            time_limit_s,
            elapsed_s: 0.0,
            start_r_rad_s: nav.r_rad_s,
            gyro_bias_rad_s: None,
            last_imu_us: None,
        })
    }

    /// Where the turn started: the point held after it.
    pub fn hold_m(&self) -> [f32; 3] {
        self.hold_m
    }

    /// An IMU sample's raw gyro rate about `z` at `t_us`: the heading change integrated
    /// with the bias held (see `gyro_bias_rad_s`). Out of line: it is not part of every
    /// measurement's code path.
    #[inline(never)]
    pub fn imu(&mut self, raw_r_rad_s: f32, t_us: u64) {
        let start_r = self.start_r_rad_s;
        let bias = *self.gyro_bias_rad_s.get_or_insert(raw_r_rad_s - start_r);
        if let Some(last) = self.last_imu_us {
            let dt_s = t_us.saturating_sub(last) as f32 * 1e-6;
            self.swing.rate(raw_r_rad_s - bias, dt_s);
        }
        self.last_imu_us = Some(t_us);
    }

    /// A raw compass reading (before any calibration), made now.
    #[inline(never)]
    pub fn reading(&mut self, yaw_rad: f32) {
        self.swing.reading(yaw_rad);
    }

    /// One control step of `dt_s` on the estimate `nav`: the surge force (N) and yaw moment (N m) that fly the
    /// turn (the depth is held by the law): the moment is the drag's at the target rate
    /// (`m33 (gamma1 r + gamma2 |r| r)`, the model of `v`) plus a rate feedback; the surge
    /// takes the along-heading part of the drift from the start point. `Some(fit)` when the
    /// turn is over (a full circle and the overturn, or the time limit).
    #[inline(never)]
    pub fn step(
        &mut self,
        v: &XyCoeffs,
        nav: &NavState,
        dt_s: f32,
    ) -> ([f32; 2], Option<SwingFit>) {
        self.elapsed_s += dt_s;
        let done = self.swing.turned_rad().abs() >= 2.0 * core::f32::consts::PI + OVERTURN_RAD;
        if done || self.elapsed_s >= self.time_limit_s {
            return ([0.0; 2], Some(self.swing.fit()));
        }
        let (s, c) = sin_cos(nav.yaw_rad);
        let along_m = (self.hold_m[0] - nav.x_m) * c + (self.hold_m[1] - nav.y_m) * s;
        let surge_n = (SURGE_N_PER_M * along_m).clamp(-SURGE_MAX_N, SURGE_MAX_N);
        let r_c = self.yaw_rate_rad_s;
        let yaw_n_m = v.m33
            * (v.gamma1 * r_c
                + v.gamma2 * r_c.abs() * r_c
                + YAW_RATE_GAIN_1_S * (r_c - nav.r_rad_s));
        ([surge_n, yaw_n_m], None)
    }

    /// Heading turned so far (rad).
    pub fn turned_rad(&self) -> f32 {
        self.swing.turned_rad()
    }
}
