//! The tracking laws' internal state (integrators, the feasible heading, the current
//! observer, saturation flags) and the small helpers every law of the folder steps it with
//! (a clean step length, a clamped integrator that freezes under saturation, saturations).

use crate::state::BodyForces;

/// The feasible-heading generator of the XY law (course minus sideslip, with filtered
/// derivatives of the sideslip).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct HeadingRef {
    pub(super) init: bool,
    pub(super) chi: f32,
    pub(super) beta_qs: f32,
    pub(super) beta_qs_dot: f32,
    pub(super) beta: f32,
    pub(super) beta_dot: f32,
    pub(super) beta_ddot: f32,
    /// Direction of the reference motion used at rest: the vector `rest_vec` (of the
    /// velocity, else the acceleration, else the jerk; held when all vanish) when
    /// `rest_from_vec`, else the angle `rest_chi` (rad, the yaw at the start).
    pub(super) rest_chi: f32,
    pub(super) rest_vec: [f32; 2],
    pub(super) rest_from_vec: bool,
    /// The rest law approaches the reference point backwards (hysteresis state).
    pub(super) rest_reverse: bool,
}

/// Internal state of the tracking laws (integrators, filters, saturation flags).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TrackingState {
    /// XY: integral of the origin error (inertial, m s).
    pub(super) xy_int: [f32; 2],
    /// XZ: integral of the x1 error (m s).
    pub(super) xz_int: f32,
    /// Depth: integral of the depth error (m s).
    pub(super) z_int: f32,
    /// The pitch demand was in its limit last step.
    pub(super) pitch_limited: bool,
    /// Last allocation clamped the surge force.
    pub(super) surge_sat: bool,
    /// Last allocation clamped the yaw moment.
    pub(super) yaw_sat: bool,
    /// Last allocation clamped the heave force.
    pub(super) heave_sat: bool,
    pub(super) heading: HeadingRef,
    /// Current observer (XY).
    pub(super) current: CurrentObserver,
    /// Forces the thrusters delivered on the last step.
    pub(super) achieved: BodyForces,
}

/// Disturbance observer of the horizontal body dynamics, read as a constant current.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct CurrentObserver {
    pub(super) init: bool,
    /// Observer states (surge, sway), N.
    pub(super) z: [f32; 2],
    /// Filtered current estimate, inertial `[cx, cy]`, m/s.
    pub(crate) vc: [f32; 2],
    /// Surge force the thrusters deliver (the command through their lag), N.
    pub(super) surge_n: f32,
    /// Time the estimate has learnt (s, weighted by its turn-rate factor; counted up to
    /// `2 CURRENT_SETTLE_S`, where its time constant stops growing).
    pub(super) learned_s: f32,
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
