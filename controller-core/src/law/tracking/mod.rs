//! Laws that really track (issue 3), in the vertical plane, the horizontal plane and 3-D.
//!
//! - [`step_xz`]: a cascade on the transformed point `x1 = x + alpha sin(theta)` of
//!   `MODEL_NOTES` section 3, whose acceleration is set by the pitch (`u1_dot = F_q / a_uq`,
//!   independent of `tau_1`): x1 error -> desired x1 acceleration (PID) -> pitch demand
//!   `theta_d` (exact inverse of the dominant term `-g sin(theta) cos(theta)`, smoothly limited
//!   to `pitch_max_rad`) with analytic first and second derivatives -> pitch-rate loop ->
//!   `tau_1` through the coupled mass matrix (`q_dot = q_dot_0 - (a_uq / delta) tau_1`).
//!   Depth by the heave force ([`depth`]); yaw held at 0 on the 6-DOF plant.
//! - [`step_xy`]: the "hand position" `h = p + eps (cos psi, sin psi)`, fully actuated for
//!   `eps > 0`, is feedback-linearized (`tau_1`, `tau_2` give any hand acceleration); the
//!   hand reference is the origin reference shifted by `eps` along the *feasible* heading
//!   (course minus the sideslip the sway dynamics need, [`crate::reference::feasible`]), so
//!   when the hand tracks, the internal yaw dynamics (stable when moving forward with
//!   `Y_v eps > (m11 - m22) U`) bring the origin onto its reference. The integral acts on the
//!   *origin* error, so a current or a model error that leaves the heading off the computed
//!   feasible heading is still removed at the origin.
//! - [`step_3d`]: the XY law plus the depth law; pitch and roll are left to their restoring
//!   moments.
//!
//! Saturation awareness: position errors entering the PD terms are limited
//! (`error_limit_m`), the pitch demand is limited, every integrator is clamped and frozen while
//! its actuator is saturated (from [`TrackingState::on_allocation`]; integration that shrinks
//! the integrator is still allowed), so nothing winds up and recovery is smooth.
//!
//! Design notes, equations and measured numbers: `docs/tracking.md`.

mod depth;
mod xy;
mod xz;

use super::LawOutput;
use crate::error::{positive, Error};
use crate::params::Vehicle;
use crate::reference::RefSample;
use crate::state::{BodyForces, NavState, TrackingErrors};
use serde::{Deserialize, Serialize};

pub use depth::depth;

/// Gains of the tracking laws. Every value must be finite and positive.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TrackingGains {
    /// XY: distance `eps` of the hand point ahead of the origin (m). The yaw dynamics are
    /// stable for `eps > (m11 - m22) U / Y_v` (0.28 U for the Observer, `U` relative to the
    /// water); smaller `eps` shrinks the origin error a heading error causes. 0.2 m covers
    /// about 1 m/s (measured).
    pub hand_m: f32,
    /// XY: hand position gain (1/s^2).
    pub xy_kp: f32,
    /// XY: hand velocity gain (1/s).
    pub xy_kd: f32,
    /// XY: integral gain on the origin error (1/s^3).
    pub xy_ki: f32,
    /// XZ: position gain of the x1 loop (1/s^2).
    pub xz_kp: f32,
    /// XZ: velocity gain of the x1 loop (1/s).
    pub xz_kd: f32,
    /// XZ: integral gain of the x1 loop (1/s^3).
    pub xz_ki: f32,
    /// XZ: pitch gain (1/s^2).
    pub pitch_kp: f32,
    /// XZ: pitch-rate gain (1/s).
    pub pitch_kd: f32,
    /// XZ: largest pitch demand (rad, < 0.7).
    pub pitch_max_rad: f32,
    /// Depth: position gain (1/s^2).
    pub depth_kp: f32,
    /// Depth: velocity gain (1/s).
    pub depth_kd: f32,
    /// Depth: integral gain (1/s^3).
    pub depth_ki: f32,
    /// XZ on the 6-DOF plant: yaw-hold gain (1/s^2).
    pub yaw_kp: f32,
    /// XZ on the 6-DOF plant: yaw-rate gain (1/s).
    pub yaw_kd: f32,
    /// Largest position error fed to the PD terms (m); bounds the virtual controls.
    pub error_limit_m: f32,
    /// Largest acceleration an integrator may contribute (m/s^2).
    pub integral_limit_m_s2: f32,
    /// XY: bandwidth of the disturbance observer read as a current (rad/s); 0 turns it off.
    /// Must be >= 0. Measured effect in `docs/tracking.md`.
    pub current_observer_rad_s: f32,
}

impl TrackingGains {
    /// The documented defaults (`docs/tracking.md`).
    pub const DEFAULT: Self = Self {
        hand_m: 0.2,
        xy_kp: 1.0,
        xy_kd: 2.0,
        xy_ki: 0.15,
        xz_kp: 3.0,
        xz_kd: 3.0,
        xz_ki: 1.0,
        pitch_kp: 9.0,
        pitch_kd: 6.0,
        pitch_max_rad: 0.35,
        depth_kp: 3.0,
        depth_kd: 3.0,
        depth_ki: 1.0,
        yaw_kp: 4.0,
        yaw_kd: 4.0,
        error_limit_m: 0.5,
        integral_limit_m_s2: 1.0,
        current_observer_rad_s: 1.0,
    };

    /// Refuse non-finite or non-positive gains, and a pitch limit at or beyond 0.7 rad (the
    /// inverse of `sin(2 theta)` needs `|theta| < pi / 4`).
    pub fn validate(&self) -> Result<(), Error> {
        for (n, v) in [
            ("hand_m", self.hand_m),
            ("xy_kp", self.xy_kp),
            ("xy_kd", self.xy_kd),
            ("xy_ki", self.xy_ki),
            ("xz_kp", self.xz_kp),
            ("xz_kd", self.xz_kd),
            ("xz_ki", self.xz_ki),
            ("pitch_kp", self.pitch_kp),
            ("pitch_kd", self.pitch_kd),
            ("pitch_max_rad", self.pitch_max_rad),
            ("depth_kp", self.depth_kp),
            ("depth_kd", self.depth_kd),
            ("depth_ki", self.depth_ki),
            ("yaw_kp", self.yaw_kp),
            ("yaw_kd", self.yaw_kd),
            ("error_limit_m", self.error_limit_m),
            ("integral_limit_m_s2", self.integral_limit_m_s2),
        ] {
            positive(n, v)?;
        }
        crate::error::non_negative("current_observer_rad_s", self.current_observer_rad_s)?;
        if self.pitch_max_rad >= 0.7 {
            return Err(Error::OutOfRange("pitch_max_rad"));
        }
        Ok(())
    }
}

impl Default for TrackingGains {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The feasible-heading generator of the XY law (course minus sideslip, with filtered
/// derivatives of the sideslip).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct HeadingRef {
    init: bool,
    chi: f32,
    beta_qs: f32,
    beta_qs_dot: f32,
    beta: f32,
    beta_dot: f32,
    beta_ddot: f32,
    /// Direction of the reference motion used at rest: the vector `rest_vec` (of the
    /// velocity, else the acceleration, else the jerk; held when all vanish) when
    /// `rest_from_vec`, else the angle `rest_chi` (rad, the yaw at the start).
    rest_chi: f32,
    rest_vec: [f32; 2],
    rest_from_vec: bool,
    /// The rest law approaches the reference point backwards (hysteresis state).
    rest_reverse: bool,
}

/// Internal state of the tracking laws (integrators, filters, saturation flags).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TrackingState {
    /// XY: integral of the origin error (inertial, m s).
    xy_int: [f32; 2],
    /// XZ: integral of the x1 error (m s).
    xz_int: f32,
    /// Depth: integral of the depth error (m s).
    z_int: f32,
    /// The pitch demand was in its limit last step.
    pitch_limited: bool,
    /// Last allocation clamped the surge force.
    surge_sat: bool,
    /// Last allocation clamped the yaw moment.
    yaw_sat: bool,
    /// Last allocation clamped the heave force.
    heave_sat: bool,
    heading: HeadingRef,
    /// Current observer (XY).
    current: CurrentObserver,
    /// Forces the thrusters delivered on the last step.
    achieved: BodyForces,
}

/// Disturbance observer of the horizontal body dynamics, read as a constant current.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct CurrentObserver {
    init: bool,
    /// Observer states (surge, sway), N.
    z: [f32; 2],
    /// Filtered current estimate, inertial `[cx, cy]`, m/s.
    pub(crate) vc: [f32; 2],
    /// Surge force the thrusters deliver (the command through their lag), N.
    surge_n: f32,
    /// Time the estimate has learnt (s, weighted by its turn-rate factor; counted up to
    /// `2 CURRENT_SETTLE_S`, where its time constant stops growing).
    learned_s: f32,
}

impl TrackingState {
    /// Tell the law what the thrusters really delivered (anti-windup): a channel whose
    /// achieved force differs from the request is saturated, and the integrators it feeds stop
    /// growing on the next step.
    pub fn on_allocation(&mut self, requested: &BodyForces, achieved: &BodyForces) {
        // Off by more than the tolerance, or NaN (the comparison is false then).
        let off = |r: f32, a: f32| {
            let within = (r - a).abs() <= 1e-3 * (1.0 + r.abs());
            !within
        };
        self.surge_sat = off(requested.surge_n, achieved.surge_n);
        self.yaw_sat = off(requested.yaw_n_m, achieved.yaw_n_m);
        self.heave_sat = off(requested.heave_n, achieved.heave_n);
        self.achieved = *achieved;
    }

    /// Integrator values `[xy_x, xy_y, xz, z]` (m s), for logs and tests.
    pub fn integrators(&self) -> [f32; 4] {
        [self.xy_int[0], self.xy_int[1], self.xz_int, self.z_int]
    }

    /// The XY law's feasible heading as `[course, sideslip]` (rad; `psi_r = course -
    /// sideslip`), for logs and the development probe.
    pub fn feasible_heading_rad(&self) -> [f32; 2] {
        [self.heading.chi, self.heading.beta]
    }

    /// The XY law's current estimate `[cx, cy]` (inertial, m/s).
    pub fn current_estimate_m_s(&self) -> [f32; 2] {
        self.current.vc
    }
}

/// A usable step length: non-finite or non-positive gives 0 (integrators and filters hold),
/// and it is capped at 1 s.
#[inline]
pub(crate) fn clean_dt(dt_s: f32) -> f32 {
    if dt_s.is_finite() && dt_s > 0.0 {
        crate::math::min(dt_s, 1.0)
    } else {
        0.0
    }
}

/// Integrate `e` into `i` over `dt` unless `frozen`; integration that shrinks `|i|` is always
/// allowed. The result is clamped to `+-limit`.
#[inline]
pub(crate) fn integrate(i: f32, e: f32, dt: f32, frozen: bool, limit: f32) -> f32 {
    let next = i + e * dt;
    let next = if frozen && next.abs() > i.abs() {
        i
    } else {
        next
    };
    let next = crate::math::clamp(next, -limit, limit);
    if next.is_finite() {
        next
    } else {
        0.0
    }
}

/// Limit a scalar error to `+-l`.
#[inline]
pub(crate) fn sat(e: f32, l: f32) -> f32 {
    if e.is_nan() {
        0.0
    } else {
        crate::math::clamp(e, -l, l)
    }
}

/// Scale a 2-vector so that its norm is at most `l` (direction kept).
#[inline]
pub(crate) fn sat2(x: f32, y: f32, l: f32) -> (f32, f32) {
    let n2 = x * x + y * y;
    if n2 <= l * l {
        // Within the limit (and finite): no root needed.
        return (x, y);
    }
    let n = crate::math::sqrt(n2);
    if n.is_finite() {
        let k = l / n;
        (x * k, y * k)
    } else {
        (0.0, 0.0)
    }
}

/// XZ tracking step: x by pitch (cascade on the transformed point), depth by heave, yaw held
/// at 0. Errors: `x`, `z` of the origin and the pitch error against the steady pitch of the
/// reference acceleration (`y`, yaw: 0).
pub fn step_xz(
    v: &Vehicle,
    g: &TrackingGains,
    st: &mut TrackingState,
    nav: &NavState,
    r: &RefSample,
    dt_s: f32,
) -> LawOutput {
    let dt = clean_dt(dt_s);
    let pitch_sc = crate::math::sin_cos(nav.pitch_rad);
    let (heave_n, ez) = depth::depth_with(v, g, st, nav, r, dt, pitch_sc);
    let (surge_n, pitch_err) = xz::surge(v, g, st, nav, r, heave_n, dt, pitch_sc);
    let yaw_n_m = xz::yaw_hold(v, g, nav);
    let [xr, _, _] = r.pos_m;
    LawOutput {
        forces: BodyForces {
            surge_n,
            yaw_n_m,
            heave_n,
        },
        errors: TrackingErrors {
            x_m: nav.x_m - xr,
            y_m: 0.0,
            z_m: ez,
            pitch_rad: pitch_err,
            yaw_rad: 0.0,
        },
    }
}

/// XY tracking step (hand position with feasible heading); no heave force. Errors: `x`, `y`
/// of the origin and the yaw error against the feasible heading (`z`, pitch: 0).
pub fn step_xy(
    v: &Vehicle,
    g: &TrackingGains,
    st: &mut TrackingState,
    nav: &NavState,
    r: &RefSample,
    dt_s: f32,
) -> LawOutput {
    let dt = clean_dt(dt_s);
    let (surge_n, yaw_n_m, ex, ey, eyaw) = xy::hand(v, g, st, nav, r, dt);
    LawOutput {
        forces: BodyForces {
            surge_n,
            yaw_n_m,
            heave_n: 0.0,
        },
        errors: TrackingErrors {
            x_m: ex,
            y_m: ey,
            z_m: 0.0,
            pitch_rad: 0.0,
            yaw_rad: eyaw,
        },
    }
}

/// 3-D tracking step: the XY law plus the depth law; pitch and roll left to their restoring
/// moments. Errors: `x`, `y`, `z` of the origin and the yaw error.
pub fn step_3d(
    v: &Vehicle,
    g: &TrackingGains,
    st: &mut TrackingState,
    nav: &NavState,
    r: &RefSample,
    dt_s: f32,
) -> LawOutput {
    let dt = clean_dt(dt_s);
    let (heave_n, ez) = depth(v, g, st, nav, r, dt);
    let (surge_n, yaw_n_m, ex, ey, eyaw) = xy::hand(v, g, st, nav, r, dt);
    LawOutput {
        forces: BodyForces {
            surge_n,
            yaw_n_m,
            heave_n,
        },
        errors: TrackingErrors {
            x_m: ex,
            y_m: ey,
            z_m: ez,
            pitch_rad: 0.0,
            yaw_rad: eyaw,
        },
    }
}

#[cfg(test)]
mod tests;
