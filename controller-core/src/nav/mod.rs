//! Navigation: the on-board state estimator.
//!
//! The control laws read a [`NavState`]; no sensor gives one. The [`Estimator`] builds it
//! from what a vehicle of the Observer's class carries:
//!
//! | input | rate | what it fixes |
//! |---|---|---|
//! | IMU ([`ImuSample`]): gyro + accelerometer, body axes | 100 Hz (drives the prediction) | attitude, rates, vertical acceleration |
//! | pressure depth ([`DepthFix`]) | 10 Hz | depth |
//! | compass ([`HeadingFix`]) | 10 Hz | heading |
//! | DVL ([`DvlFix`]): velocity over the bottom, body axes | 5 Hz, optional | velocity, current |
//! | USBL ([`PositionFix`]): north/east, late by its latency | 1 Hz, optional | position, current |
//!
//! It is three filters, because the couplings between them are weak on a slow, passively
//! stable vehicle (roll and pitch stay within a few degrees); the one strong coupling, the
//! heading's into the position, is kept inside one filter:
//!
//! - **tilt** (roll, pitch and their gyro biases): a complementary filter with an integral
//!   term (Mahony's), gyro-propagated through the Euler kinematics and pulled slowly toward the
//!   gravity direction the accelerometer sees (`attitude.rs`);
//! - **vertical** `[z, z_dot, b_a]`: a Kalman filter driven by the accelerometer rotated to the
//!   vertical, updated by the pressure depth (`vertical.rs`);
//! - **horizontal** `[N, E, u_r, v_r, c_N, c_E, psi, b_r, b_c]`: an extended Kalman filter whose prediction is
//!   the vehicle's own horizontal model (eq. (34), `crate::model::xy`) driven by the surge
//!   thrust command through the thrusters' first-order lag: `u_r, v_r` are the velocity
//!   through the water, `c_N, c_E` the ocean current. This is what makes it *model-aided*: with
//!   USBL and no DVL the velocity still comes from the thrust the vehicle is making, and the
//!   current is what the position fixes say the model misses. The heading and the yaw-gyro
//!   bias are propagated with the gyro and updated by the compass, whose own constant bias
//!   `b_c` is a state, fixed by the USBL track against the dead reckoning
//!   (`horizontal.rs`).
//!
//! A USBL fix arrives `latency` after the acoustic ping it measures. It is compared with the
//! estimate *at its time of validity*: the filter keeps a short history of its position
//! estimates (every [`HISTORY_STEP_US`], [`HISTORY_LEN`] entries) minus the corrections
//! applied since, so the innovation is `fix - p_hat(t_fix)`, and the correction is applied
//! to today's state. The displacement over the latency is taken as known up to its variance,
//! which is added to the fix's.
//!
//! Every measurement is checked before it is used: a non-finite or absurd value, a
//! non-positive standard deviation, a time in the future or older than the history is
//! refused with a [`Refusal`] and counted in [`NavHealth`]; the state is unchanged. A fix
//! whose normalized innovation squared exceeds the chi-square gate (99.9 %) is refused as
//! an outlier and counted.
//!
//! `no_std`, `f32`, no allocation, no panics; the history is a `heapless` ring.

mod attitude;
pub mod compass_cal;
mod config;
mod horizontal;
pub mod kf;
pub mod onboard;
pub mod predict;
mod refusal;
mod vertical;

use crate::error::Error;
use crate::math::wrap_angle;
use crate::params::Vehicle;
use crate::state::NavState;
use attitude::Tilt;
use horizontal::Horizontal;
use serde::{Deserialize, Serialize};
use vertical::Vertical;

pub use config::{NavConfig, GRAVITY_M_S2};
pub use horizontal::{CLUSTER_MIN, CLUSTER_WINDOW_US, HISTORY_LEN, HISTORY_STEP_US};
pub use refusal::{Refusal, GATE_CHI2_1DOF, GATE_CHI2_2DOF};

/// Longest IMU interval the prediction integrates (s); a longer gap is refused.
pub const MAX_PREDICT_DT_S: f32 = 0.25;

/// One IMU sample: body-axis angular rate and specific force, at `t_us`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImuSample {
    /// Time of the sample (us).
    pub t_us: u64,
    /// Angular rate `[p, q, r]` (rad/s).
    pub gyro_rad_s: [f32; 3],
    /// Specific force `[f_x, f_y, f_z]` (m/s^2; about `[0, 0, -9.81]` at rest, z down).
    pub accel_m_s2: [f32; 3],
}

/// A depth from the pressure sensor.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DepthFix {
    /// Time of validity (us).
    pub t_us: u64,
    /// Depth of the body origin (m, down).
    pub depth_m: f32,
    /// Standard deviation (m).
    pub std_m: f32,
}

/// A compass heading.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HeadingFix {
    /// Time of validity (us).
    pub t_us: u64,
    /// Heading `psi` (rad).
    pub yaw_rad: f32,
    /// Standard deviation (rad).
    pub std_rad: f32,
}

/// A DVL velocity over the bottom, in body axes.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DvlFix {
    /// Time of validity (us).
    pub t_us: u64,
    /// Surge and sway speed over the bottom `[u, v]` (m/s).
    pub velocity_m_s: [f32; 2],
    /// Standard deviation of each component (m/s).
    pub std_m_s: f32,
}

/// An acoustic (USBL) position fix of the body origin.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PositionFix {
    /// Time of validity: when the ping was made, not when the fix arrived (us).
    pub t_us: u64,
    /// North (m).
    pub north_m: f32,
    /// East (m).
    pub east_m: f32,
    /// Standard deviation of each horizontal component (m).
    pub std_m: f32,
}

/// Largest horizontal position standard deviation (m, each axis) at which the estimate is
/// ready for the modes that need a position. A launch point known to half a metre
/// is ready at once; one known to a few metres becomes ready after the first USBL fixes.
pub const POSITION_READY_STD_M: f32 = 1.0;
/// Largest heading standard deviation (rad, 10 degrees) at which the estimate is ready.
pub const HEADING_READY_STD_RAD: f32 = 0.175;

/// A restart keeps what the running estimator learned when it starts within this many
/// standard deviations of the running estimate ([`Estimator::keep_learned`]).
pub const RESTART_AGREE_SIGMAS: f32 = 3.0;

/// Why the estimate is not ready for a mode that needs a position (like ArduSub's "EKF not
/// ready"): the vehicle refuses `Track`, `Hold`, AUTO and GUIDED until it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum NotReady {
    /// The position's standard deviation is above [`POSITION_READY_STD_M`].
    PositionUncertain,
    /// The heading's standard deviation is above [`HEADING_READY_STD_RAD`].
    HeadingUncertain,
}

/// Counters of what the estimator fused and refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NavHealth {
    /// IMU samples integrated.
    pub imu_samples: u32,
    /// Depth fixes fused.
    pub depth_fused: u32,
    /// Compass headings fused.
    pub heading_fused: u32,
    /// DVL velocities fused.
    pub dvl_fused: u32,
    /// USBL fixes fused.
    pub position_fused: u32,
    /// USBL fixes refused by the gate.
    pub position_outliers: u32,
    /// Other measurements refused by the gate.
    pub other_outliers: u32,
    /// Measurements refused as invalid (non-finite, out of range, bad time or accuracy).
    pub invalid: u32,
    /// Filter resets: a depth, compass or DVL sensor's fixes failed the gate
    /// [`RESET_AFTER_REJECTS`] times in a row, so the estimate, not the sensor, is taken to be
    /// wrong and is reset to the fix; or refused USBL fixes formed a consistent cluster
    /// ([`CLUSTER_MIN`] agreeing fixes, the majority of the fixes since the first
    /// of them) and the position moved to the cluster's mean.
    pub resets: u32,
}

/// Consecutive gated fixes of a depth, compass or DVL sensor after which the next one resets
/// its states. USBL fixes reset only as a consistent cluster (`horizontal.rs`): a refused
/// fix is never a reason to jump to it.
pub const RESET_AFTER_REJECTS: u8 = 5;

/// Consecutive gate failures of each sensor.
#[derive(Debug, Clone, Copy, Default)]
struct Streaks {
    depth: u8,
    heading: u8,
    dvl: u8,
}

/// Apply the gate's verdict with recovery: after [`RESET_AFTER_REJECTS`] outliers in a row,
/// `reset` runs instead and the fix counts as fused.
fn gated(
    streak: &mut u8,
    resets: &mut u32,
    fused: Result<(), Refusal>,
    reset: impl FnOnce(),
) -> Result<(), Refusal> {
    match fused {
        Err(Refusal::Outlier) if *streak + 1 >= RESET_AFTER_REJECTS => {
            reset();
            *streak = 0;
            *resets += 1;
            Ok(())
        }
        Err(Refusal::Outlier) => {
            *streak += 1;
            Err(Refusal::Outlier)
        }
        other => {
            if other.is_ok() {
                *streak = 0;
            }
            other
        }
    }
}

/// Largest |north|, |east| and depth accepted (m).
const MAX_POSITION_M: f32 = 10_000.0;
/// Largest speed accepted from a DVL (m/s).
const MAX_SPEED_M_S: f32 = 10.0;
/// Largest angular rate accepted from the gyro (rad/s; the ICM-42688-P's 2000 dps range).
const MAX_RATE_RAD_S: f32 = 35.0;
/// Largest specific force accepted from the accelerometer (m/s^2; 16 g).
const MAX_ACCEL_M_S2: f32 = 157.0;
/// Largest standard deviation accepted with a fix (in its unit).
const MAX_STD: f32 = 1.0e3;
/// A time of validity may be this far after the last IMU sample (us): one sample's jitter.
const FUTURE_TOLERANCE_US: u64 = 20_000;

/// The estimator: four filters, the thrust the thrusters are making, and the counters.
#[derive(Debug, Clone)]
pub struct Estimator {
    vehicle: Vehicle,
    cfg: NavConfig,
    t_us: u64,
    tilt: Tilt,
    vertical: Vertical,
    horizontal: Horizontal,
    /// Thrust `[F1x, F2x, F3z]` after the thrusters' lag (N).
    thrust_n: [f32; 3],
    /// Bias-corrected body rates `[p, q, r]` of the last sample.
    rates_rad_s: [f32; 3],
    health: NavHealth,
    streaks: Streaks,
}

impl Estimator {
    /// An estimator at `initial` (the launch point, known to the configured uncertainty) at
    /// time `t_us`. Fails if the configuration or `initial` is not valid.
    pub fn new(
        vehicle: Vehicle,
        cfg: NavConfig,
        initial: &NavState,
        t_us: u64,
    ) -> Result<Self, Error> {
        let cfg = cfg.validate()?;
        if !initial.is_finite() {
            return Err(Error::NonFinite("initial navigation state"));
        }
        Ok(Self {
            vehicle,
            cfg,
            t_us,
            tilt: Tilt::new(initial.roll_rad, initial.pitch_rad),
            vertical: Vertical::new(initial, &cfg),
            horizontal: Horizontal::new(initial, &cfg, t_us),
            thrust_n: [0.0; 3],
            rates_rad_s: [initial.p_rad_s, initial.q_rad_s, initial.r_rad_s],
            health: NavHealth::default(),
            streaks: Streaks::default(),
        })
    }

    /// Keep what `from`, the estimator this one replaces, learned of the instruments and
    /// the water: the gyro biases, the accelerometer's, the compass's and the current, with
    /// their variances. The position, depth, heading and velocities stay this one's start
    /// (an EKF's position and heading reset, as ArduPilot's resets keep the bias states).
    /// Only when this one starts where `from` agrees it is (within three standard deviations
    /// of both horizontally): a start elsewhere says `from` went wrong, and what it learned
    /// is not trusted either. Whether it was kept.
    pub fn keep_learned(&mut self, from: &Estimator) -> bool {
        let [[a_nn, _], [_, a_ee]] = self.horizontal.position_covariance();
        let [[b_nn, _], [_, b_ee]] = from.horizontal.position_covariance();
        let [an, ae] = self.horizontal.position();
        let [bn, be] = from.horizontal.position();
        let off2 = (an - bn) * (an - bn) + (ae - be) * (ae - be);
        let var = a_nn.max(a_ee) + b_nn.max(b_ee);
        // A NaN compares false: not kept.
        let agrees = off2 <= RESTART_AGREE_SIGMAS * RESTART_AGREE_SIGMAS * var;
        if !agrees {
            return false;
        }
        self.tilt.keep_learned(&from.tilt);
        self.vertical.keep_learned(&from.vertical);
        self.horizontal.keep_learned(&from.horizontal);
        true
    }

    /// Time of the last IMU sample (us).
    pub fn time_us(&self) -> u64 {
        self.t_us
    }

    /// Counters.
    pub fn health(&self) -> NavHealth {
        self.health
    }

    /// The configuration in force.
    pub fn config(&self) -> &NavConfig {
        &self.cfg
    }

    /// Propagate to the IMU sample's time with the sample and the thruster commands
    /// `[F1x, F2x, F3z]` (N) held since the last sample.
    pub fn predict(&mut self, imu: &ImuSample, thrust_cmd_n: [f32; 3]) -> Result<(), Refusal> {
        let r = self.check_imu(imu, thrust_cmd_n);
        self.count(r, |h| h.imu_samples += 1);
        r?;
        let dt = (imu.t_us - self.t_us) as f32 * 1.0e-6;
        self.t_us = imu.t_us;
        // The thrusters' first-order lag (exact discretization would need exp; dt << T).
        let tau = self.vehicle.params().thruster_time_constant_s;
        let a = dt / (tau + dt);
        for (f, c) in self.thrust_n.iter_mut().zip(thrust_cmd_n) {
            *f += a * (c - *f);
        }
        let [p_m, q_m, r_m] = imu.gyro_rad_s;
        let (bp, bq) = self.tilt.bias();
        let (p, q) = (p_m - bp, q_m - bq);
        let r = r_m - self.horizontal.gyro_bias_r();
        self.rates_rad_s = [p, q, r];
        self.tilt.predict(&self.cfg, [p, q, r], imu.accel_m_s2, dt);
        let (roll, pitch) = self.tilt.angles();
        self.vertical
            .predict(&self.cfg, roll, pitch, imu.accel_m_s2, dt);
        let surge_n = self.thrust_n[0] + self.thrust_n[1];
        self.horizontal.predict(
            &self.vehicle,
            &self.cfg,
            (roll, pitch, q),
            r_m,
            surge_n,
            dt,
            self.t_us,
        );
        Ok(())
    }

    fn check_imu(&self, imu: &ImuSample, thrust_cmd_n: [f32; 3]) -> Result<(), Refusal> {
        let values = imu
            .gyro_rad_s
            .iter()
            .chain(&imu.accel_m_s2)
            .chain(&thrust_cmd_n);
        for v in values {
            if !v.is_finite() {
                return Err(Refusal::NonFinite);
            }
        }
        if imu.gyro_rad_s.iter().any(|w| w.abs() > MAX_RATE_RAD_S)
            || imu.accel_m_s2.iter().any(|a| a.abs() > MAX_ACCEL_M_S2)
        {
            return Err(Refusal::OutOfRange);
        }
        if imu.t_us <= self.t_us {
            return Err(Refusal::TooOld);
        }
        if (imu.t_us - self.t_us) as f32 * 1.0e-6 > MAX_PREDICT_DT_S {
            return Err(Refusal::ImuGap);
        }
        Ok(())
    }

    /// After an IMU gap (the sample was refused with [`Refusal::ImuGap`]): restart the
    /// prediction at `t_us` without integrating the gap. The covariance grows by the gap's
    /// process noise through the next fixes' gates being wider; the firmware raises its
    /// sensor failsafe on the gap itself.
    pub fn resume_at(&mut self, t_us: u64) {
        if t_us > self.t_us {
            self.t_us = t_us;
        }
    }

    /// Check a time of validity against the estimator's time and its history.
    fn check_time(&self, t_us: u64) -> Result<(), Refusal> {
        if t_us > self.t_us.saturating_add(FUTURE_TOLERANCE_US) {
            Err(Refusal::InFuture)
        } else if t_us < self.horizontal.oldest_us() {
            Err(Refusal::TooOld)
        } else {
            Ok(())
        }
    }

    fn count(&mut self, r: Result<(), Refusal>, on_ok: impl FnOnce(&mut NavHealth)) {
        match r {
            Ok(()) => on_ok(&mut self.health),
            Err(Refusal::Outlier) => self.health.other_outliers += 1,
            Err(_) => self.health.invalid += 1,
        }
    }

    /// Fuse a pressure depth.
    pub fn fuse_depth(&mut self, m: &DepthFix) -> Result<(), Refusal> {
        let r = check_std(m.std_m)
            .and_then(|()| check_value(m.depth_m, -MAX_POSITION_M, MAX_POSITION_M))
            .and_then(|()| self.check_time(m.t_us))
            .and_then(|()| {
                let v = &mut self.vertical;
                let fused = v.fuse_depth(m.depth_m, m.std_m);
                gated(
                    &mut self.streaks.depth,
                    &mut self.health.resets,
                    fused,
                    || v.reset_depth(m.depth_m, m.std_m),
                )
            });
        self.count(r, |h| h.depth_fused += 1);
        r
    }

    /// Fuse a compass heading.
    pub fn fuse_heading(&mut self, m: &HeadingFix) -> Result<(), Refusal> {
        let r = check_std(m.std_rad)
            .and_then(|()| check_value(m.yaw_rad, -10.0, 10.0))
            .and_then(|()| self.check_time(m.t_us))
            .and_then(|()| {
                let h = &mut self.horizontal;
                let fused = h.fuse_heading(m.yaw_rad, m.std_rad);
                gated(
                    &mut self.streaks.heading,
                    &mut self.health.resets,
                    fused,
                    || h.reset_heading(m.yaw_rad, m.std_rad),
                )
            });
        self.count(r, |h| h.heading_fused += 1);
        r
    }

    /// Fuse a DVL velocity over the bottom.
    pub fn fuse_dvl(&mut self, m: &DvlFix) -> Result<(), Refusal> {
        let [u, v] = m.velocity_m_s;
        let r = check_std(m.std_m_s)
            .and_then(|()| check_value(u, -MAX_SPEED_M_S, MAX_SPEED_M_S))
            .and_then(|()| check_value(v, -MAX_SPEED_M_S, MAX_SPEED_M_S))
            .and_then(|()| self.check_time(m.t_us))
            .and_then(|()| {
                let h = &mut self.horizontal;
                let fused = h.fuse_dvl([u, v], m.std_m_s);
                gated(
                    &mut self.streaks.dvl,
                    &mut self.health.resets,
                    fused,
                    || h.reset_velocity([u, v], m.std_m_s),
                )
            });
        self.count(r, |h| h.dvl_fused += 1);
        r
    }

    /// Fuse a USBL fix at its time of validity.
    pub fn fuse_position(&mut self, m: &PositionFix) -> Result<(), Refusal> {
        let r = check_std(m.std_m)
            .and_then(|()| check_value(m.north_m, -MAX_POSITION_M, MAX_POSITION_M))
            .and_then(|()| check_value(m.east_m, -MAX_POSITION_M, MAX_POSITION_M))
            .and_then(|()| self.check_time(m.t_us))
            .and_then(|()| {
                let now = self.t_us;
                let fix = [m.north_m, m.east_m];
                let moved = self
                    .horizontal
                    .fuse_position_or_cluster(m.t_us, now, fix, m.std_m)?;
                if moved {
                    self.health.resets += 1;
                }
                Ok(())
            });
        match r {
            Ok(()) => self.health.position_fused += 1,
            Err(Refusal::Outlier) => self.health.position_outliers += 1,
            Err(_) => self.health.invalid += 1,
        }
        r
    }

    /// The state the laws read: position, attitude, velocity over the ground in body axes
    /// (through-the-water velocity plus the current), bias-corrected rates.
    pub fn state(&self) -> NavState {
        let (roll, pitch) = self.tilt.angles();
        let yaw = wrap_angle(self.horizontal.yaw());
        let [n, e] = self.horizontal.position();
        let [u, v] = self.horizontal.velocity_over_ground();
        let z = self.vertical.depth();
        let z_dot = self.vertical.depth_rate();
        // Body heave from the vertical rate: z_dot = -s_theta u + c_theta s_phi v + c_theta c_phi w.
        let (sr, cr) = crate::math::sin_cos(roll);
        let (sp, cp) = crate::math::sin_cos(pitch);
        let den = cp * cr;
        let w = if den > 0.1 {
            (z_dot + sp * u - cp * sr * v) / den
        } else {
            z_dot
        };
        let [p, q, r] = self.rates_rad_s;
        NavState {
            x_m: n,
            y_m: e,
            z_m: z,
            roll_rad: roll,
            pitch_rad: pitch,
            yaw_rad: yaw,
            u_m_s: u,
            v_m_s: v,
            w_m_s: w,
            p_rad_s: p,
            q_rad_s: q,
            r_rad_s: r,
        }
    }

    /// Covariance of the position `[N, E, z]` (m^2); the horizontal and vertical filters are
    /// independent, so the cross terms with depth are zero.
    pub fn position_covariance(&self) -> [[f32; 3]; 3] {
        let [[nn, ne], [en, ee]] = self.horizontal.position_covariance();
        let zz = self.vertical.depth_variance();
        [[nn, ne, 0.0], [en, ee, 0.0], [0.0, 0.0, zz]]
    }

    /// The estimated ocean current `[north, east]` (m/s).
    pub fn current_m_s(&self) -> [f32; 2] {
        self.horizontal.current()
    }

    /// The compass's bias as estimated (rad: the compass reads the heading plus this) and
    /// its standard deviation (rad).
    pub fn compass_bias_rad(&self) -> (f32, f32) {
        let (b, var) = self.horizontal.compass_bias();
        (b, crate::math::sqrt(var))
    }

    /// Move the compass bias estimate by `d_rad` (a new compass calibration changed what the
    /// corrected readings carry; `OnboardNav::set_compass_calibration`). The heading, the
    /// covariance and the other states stay; the compass's gate streak restarts.
    pub fn shift_compass_bias(&mut self, d_rad: f32) {
        if d_rad.is_finite() {
            self.horizontal.shift_compass_bias(d_rad);
            self.streaks.heading = 0;
        }
    }

    /// Standard deviation of the heading (rad).
    pub fn heading_std_rad(&self) -> f32 {
        crate::math::sqrt(self.horizontal.yaw_variance())
    }

    /// Is the estimate good enough for a mode that needs a position? Its horizontal
    /// standard deviation must be within [`POSITION_READY_STD_M`] on both axes and its
    /// heading's within [`HEADING_READY_STD_RAD`]; otherwise the reason. A NaN covariance is
    /// never ready.
    pub fn position_ready(&self) -> Result<(), NotReady> {
        // A NaN compares false: never within.
        let within = |var: f32, std: f32| var <= std * std;
        let [[nn, _], [_, ee]] = self.horizontal.position_covariance();
        if !(within(nn, POSITION_READY_STD_M) && within(ee, POSITION_READY_STD_M)) {
            Err(NotReady::PositionUncertain)
        } else if !within(self.horizontal.yaw_variance(), HEADING_READY_STD_RAD) {
            Err(NotReady::HeadingUncertain)
        } else {
            Ok(())
        }
    }
}

fn check_std(std: f32) -> Result<(), Refusal> {
    if !std.is_finite() {
        Err(Refusal::NonFinite)
    } else if !(std > 0.0 && std <= MAX_STD) {
        Err(Refusal::BadAccuracy)
    } else {
        Ok(())
    }
}

fn check_value(v: f32, lo: f32, hi: f32) -> Result<(), Refusal> {
    if !v.is_finite() {
        Err(Refusal::NonFinite)
    } else if v < lo || v > hi {
        Err(Refusal::OutOfRange)
    } else {
        Ok(())
    }
}
