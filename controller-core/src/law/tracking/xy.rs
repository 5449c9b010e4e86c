//! XY: hand-position law with the feasible heading (see `docs/tracking.md`).
//!
//! `h = p + eps d(psi)`, `d = (cos, sin)`, `n = (-sin, cos)`. In the body frame
//! `h_ddot = [u_dot - (v + eps r) r, v_dot + eps r_dot + u r]`, with
//! `m11 u_dot = m22 v r - X(u) + tau_1`, `m22 v_dot = -m11 u r - Y(v)`,
//! `m33 r_dot = (m11 - m22) u v - N(r) + tau_2`: both components are set by the inputs
//! (the second through `eps r_dot`), so any desired hand acceleration `a_d` is reached:
//! ```text
//! tau_1 = m11 (b_x + (v + eps r) r) - m22 v r + X(u)
//! tau_2 = m33 (b_y - v_dot - u r) / eps - (m11 - m22) u v + N(r)        b = R(psi)^T a_d
//! a_d   = h_r_ddot - k_d (h_dot - h_r_dot) - k_p sat(h - h_r) - k_i int(p - p_r)
//! h_r   = p_r + eps d(psi_r),  h_r_dot = p_r_dot + eps psi_r_dot n(psi_r),
//! h_r_ddot = p_r_ddot + eps (psi_r_ddot n(psi_r) - psi_r_dot^2 d(psi_r))
//! ```
//! `psi_r = chi - beta` (course minus feasible sideslip); `chi`, `chi_dot`, `chi_ddot` are
//! analytic from the sample, `beta` is the quasi-static sideslip advanced by `T_adv`, and its
//! derivatives are filtered differences (time constant [`DERIV_TAU_S`]).

use super::gains::TrackingGains;
use super::state::{integrate, sat2, CurrentObserver, HeadingRef, TrackingState};
use crate::math::{atan2, clamp, min, sin_cos, sqrt, wrap_angle};
use crate::params::{Vehicle, XyCoeffs};
use crate::reference::feasible::{course_of, sideslip, Course};
use crate::reference::RefSample;
use crate::state::NavState;

/// Time constant of the filtered derivatives of the sideslip (s).
pub const DERIV_TAU_S: f32 = 0.05;

/// One step of a filtered derivative: `d + (raw - d) dt / (tau + dt)` with the raw difference
/// `raw = (x - prev) / dt`, written `d + (x - prev - d dt) k` with `k = 1 / (tau + dt)`
/// computed once for the three filters ([`filt_gain`]); `k = 0` (no valid step) holds `d`.
#[inline(always)]
fn filt(prev: f32, d: f32, x: f32, dt: f32, k: f32) -> f32 {
    d + (x - prev - d * dt) * k
}

/// `1 / (DERIV_TAU_S + dt)` for a clean `dt > 0`, else 0 (the filters hold).
#[inline(always)]
fn filt_gain(dt: f32) -> f32 {
    if dt > 0.0 {
        1.0 / (DERIV_TAU_S + dt)
    } else {
        0.0
    }
}

impl HeadingRef {
    /// Advance the generator with the water-relative course `course` (`None` below the speed
    /// floor) and the direction of the reference motion `rest_dir` (see
    /// [`rest_direction`]); `dt` must be clean ([`super::state::clean_dt`]).
    /// Returns `(psi_r, psi_r_dot, psi_r_ddot)`.
    pub(crate) fn update(
        &mut self,
        xy: &XyCoeffs,
        course: Option<Course>,
        rest_dir: Option<[f32; 2]>,
        yaw: f32,
        dt: f32,
    ) -> (f32, f32, f32) {
        let (chi, chi1, chi2, bqs, adv) = match course {
            Some(c) => {
                let s = sideslip(xy, &c);
                (c.chi_rad, c.chi_dot, c.chi_ddot, s.beta_rad, s.advance_s)
            }
            None => (if self.init { self.chi } else { yaw }, 0.0, 0.0, 0.0, 0.0),
        };
        if !self.init {
            *self = HeadingRef {
                init: true,
                chi,
                beta_qs: bqs,
                beta_qs_dot: 0.0,
                beta: bqs,
                beta_dot: 0.0,
                beta_ddot: 0.0,
                rest_chi: yaw,
                rest_vec: [0.0, 0.0],
                rest_from_vec: false,
                rest_reverse: false,
            };
        }
        if let Some(d) = rest_dir {
            // The vector; its angle is taken when the rest law uses it.
            self.rest_vec = d;
            self.rest_from_vec = true;
        }
        let k = filt_gain(dt);
        self.beta_qs_dot = filt(self.beta_qs, self.beta_qs_dot, bqs, dt, k);
        self.beta_qs = bqs;
        let beta = bqs + adv * self.beta_qs_dot;
        let beta_dot = filt(self.beta, self.beta_dot, beta, dt, k);
        self.beta_ddot = filt(self.beta_dot, self.beta_ddot, beta_dot, dt, k);
        self.beta_dot = beta_dot;
        self.beta = beta;
        self.chi = chi;
        let ok = |x: f32| if x.is_finite() { x } else { 0.0 };
        let (b0, b1, b2) = (ok(self.beta), ok(self.beta_dot), ok(self.beta_ddot));
        (wrap_angle(chi - b0), chi1 - b1, chi2 - b2)
    }

    /// Direction of the reference motion used at rest (rad): of the velocity, else the
    /// acceleration, else the jerk (the last one seen); at the very start the vehicle's yaw.
    /// The arctangent is taken only here, when the rest law needs it.
    fn rest_chi(&self) -> f32 {
        if self.rest_from_vec {
            let [x, y] = self.rest_vec;
            atan2(y, x)
        } else {
            self.rest_chi
        }
    }
}

/// Direction vector of the horizontal reference motion from the lowest non-vanishing
/// derivative (velocity, acceleration, jerk): a reference starting from rest moves first along
/// its acceleration and jerk. `None` when all vanish. (Norms compared squared: no root.)
fn rest_direction(r: &RefSample) -> Option<[f32; 2]> {
    let usable = |v: &[f32; 3]| {
        let [x, y, _] = *v;
        let n2 = x * x + y * y;
        n2 > REST_DIRECTION_FLOOR * REST_DIRECTION_FLOOR && n2.is_finite()
    };
    let pick = if usable(&r.vel_m_s) {
        &r.vel_m_s
    } else if usable(&r.acc_m_s2) {
        &r.acc_m_s2
    } else if usable(&r.jerk_m_s3) {
        &r.jerk_m_s3
    } else {
        return None;
    };
    let [x, y, _] = *pick;
    Some([x, y])
}

/// Below this norm a derivative of the reference gives no direction.
pub const REST_DIRECTION_FLOOR: f32 = 1.0e-12;

/// Reference speed (m/s) below which the XY law is entirely the rest law.
pub const REST_SPEED_LO_M_S: f32 = 0.01;

/// Reference speed (m/s) above which the XY law is entirely the hand law.
pub const REST_SPEED_HI_M_S: f32 = 0.08;

/// Origin error (m) below which the rest law points the heading along the path.
pub const REST_LOS_NEAR_M: f32 = 0.05;

/// Origin error (m) above which the rest law points the heading at the reference point.
pub const REST_LOS_FAR_M: f32 = 0.2;

/// Hysteresis (rad) of the rest law's choice between approaching forwards and backwards.
pub const REST_REVERSE_HYST_RAD: f32 = 0.2;

/// In a current: the hand distance per unit of water-relative reference speed (s), at least
/// [`HAND_MIN_M`] and at most the gain `hand_m`. The yaw dynamics need `eps > 0.28 U`.
pub const HAND_PER_WATER_SPEED_S: f32 = 0.8;

/// In a current: the smallest hand distance (m).
pub const HAND_MIN_M: f32 = 0.05;

/// In a current: water-relative reference speed (m/s) below which its course is not used
/// (held).
pub const WATER_COURSE_FLOOR_M_S: f32 = 0.02;

/// Time constant (s) with which the origin integrator bleeds at rest.
pub const REST_BLEED_S: f32 = 10.0;

/// [`smoothstep`] of `sqrt(x2)`, the root taken only between `lo` and `hi` (`lo >= 0`).
#[inline]
fn smoothstep_sq(x2: f32, lo: f32, hi: f32) -> f32 {
    if x2 >= hi * hi {
        1.0
    } else if x2 > lo * lo {
        smoothstep(sqrt(x2), lo, hi)
    } else {
        // At or below `lo`, or NaN (as `smoothstep` of a NaN).
        0.0
    }
}

/// `0` below `lo`, `1` above `hi`, cubic smoothstep between (C1).
fn smoothstep(x: f32, lo: f32, hi: f32) -> f32 {
    let w = hi - lo;
    if w.is_nan() || w <= 0.0 || !x.is_finite() {
        return if x >= hi { 1.0 } else { 0.0 };
    }
    let s = clamp((x - lo) / w, 0.0, 1.0);
    s * s * (3.0 - 2.0 * s)
}

/// Below this estimated current (m/s) the estimate is not used; it is blended in linearly up
/// to twice this value (model errors of the planar inversion on the 6-DOF vehicle must not
/// read as a current).
pub const CURRENT_DEADZONE_M_S: f32 = 0.01;

/// Turn rate (rad/s) at which the current estimate learns at half its rate.
pub const CURRENT_TURN_RATE_RAD_S: f32 = 0.2;

/// Time constant of the low-pass on the current estimate at the start (s).
pub const CURRENT_TAU_S: f32 = 5.0;

/// Time constant of the low-pass on the current estimate once it has settled (s): the
/// current is taken as constant over minutes, and a slower estimate no longer reads the
/// vehicle's own weather-vane swing as a change of the current (with 5 s throughout, the two
/// kept each other going in a hold: +-0.15 rad without end).
pub const CURRENT_TAU_SETTLED_S: f32 = 20.0;

/// Learning time (s, weighted by the turn-rate factor): for the first `CURRENT_SETTLE_S` the
/// estimate learns with [`CURRENT_TAU_S`], over the next `CURRENT_SETTLE_S` its time constant
/// grows linearly to [`CURRENT_TAU_SETTLED_S`].
pub const CURRENT_SETTLE_S: f32 = 30.0;

/// Solve `(k1 + k2 |x|) x = f` for `x` (odd, monotonic) in closed form (one square root).
fn inv_drag(k1: f32, k2: f32, f: f32) -> f32 {
    let a = f.abs();
    let x = if k2 > 0.0 {
        (-k1 + crate::math::sqrt(k1 * k1 + 4.0 * k2 * a)) / (2.0 * k2)
    } else if k1 > 0.0 {
        a / k1
    } else {
        0.0
    };
    if x.is_finite() {
        x.copysign(f)
    } else {
        0.0
    }
}

impl CurrentObserver {
    /// One step of the observer. The surge and sway momenta `m11 u`, `m22 v` obey
    /// `m11 u_dot = m22 v r - X(u) + tau_1 + d_x`, `m22 v_dot = -m11 u r - Y(v) + d_y`; the
    /// observer `d_hat = z + L M nu`, `z_dot = -L (d_hat + f_model + tau)` gives
    /// `d_hat_dot = L (d - d_hat)` without differentiating the velocity. A current `c_b`
    /// (body) makes `d = D(nu) - D(nu - c_b) + (m11 - m22) r [c_by, c_bx]` (drag on the
    /// water-relative velocity, and the added mass of the current turning in the body
    /// frame), solved per axis for `c_b` with the last estimate in the turning term, rotated
    /// to the inertial frame and low-passed ([`CURRENT_TAU_S`], slowing to
    /// [`CURRENT_TAU_SETTLED_S`] once learnt).
    pub(crate) fn update(
        &mut self,
        v: &Vehicle,
        nav: &NavState,
        achieved: &crate::state::BodyForces,
        (s, c): (f32, f32),
        gain_rad_s: f32,
        dt: f32,
    ) {
        if gain_rad_s <= 0.0 || gain_rad_s.is_nan() {
            *self = Self::default();
            return;
        }
        let p = v.params();
        let xy = &v.xy;
        let (u, vv, r) = (nav.u_m_s, nav.v_m_s, nav.r_rad_s);
        let l = gain_rad_s;
        let mx = xy.m11 * u;
        let my = xy.m22 * vv;
        if !self.init {
            self.init = true;
            self.z = [-l * mx, -l * my];
        }
        let xd = (p.x_u + p.x_uu * u.abs()) * u;
        let yd = (p.y_v + p.y_vv * vv.abs()) * vv;
        // The thrusters deliver the commanded surge force through their first-order lag.
        let lag = p.thruster_time_constant_s;
        self.surge_n += (achieved.surge_n - self.surge_n) * dt / (lag + dt);
        let fx = xy.m22 * vv * r - xd + self.surge_n;
        let fy = -xy.m11 * u * r - yd;
        let [zx, zy] = self.z;
        let dx = zx + l * mx;
        let dy = zy + l * my;
        let zx = zx - dt * l * (dx + fx);
        let zy = zy - dt * l * (dy + fy);
        // d = D(nu) - D(nu - c)  =>  nu - c = D^-1(D(nu) - d).
        // The turning current's added-mass force (`k r c_b`, `k = m11 - m22`) with the last
        // estimate in the body frame.
        let k = xy.m11 - xy.m22;
        let [vx, vy] = self.vc;
        let pbx = c * vx + s * vy;
        let pby = -s * vx + c * vy;
        let cbx = u - inv_drag(p.x_u, p.x_uu, xd - dx + k * r * pby);
        let cby = vv - inv_drag(p.y_v, p.y_vv, yd - dy + k * r * pbx);
        let cx = c * cbx - s * cby;
        let cy = s * cbx + c * cby;
        // Turning fast, the model's errors (thruster lag, roll, the turning current) read as
        // a current: the estimate learns mostly from straight motion.
        let turn = r / CURRENT_TURN_RATE_RAD_S;
        let weight = 1.0 / (1.0 + turn * turn);
        let settled = clamp(self.learned_s / CURRENT_SETTLE_S - 1.0, 0.0, 1.0);
        let tau = CURRENT_TAU_S + settled * (CURRENT_TAU_SETTLED_S - CURRENT_TAU_S);
        let k = dt * weight / (tau + dt);
        let nvx = vx + k * (cx - vx);
        let nvy = vy + k * (cy - vy);
        let fin = |a: f32| if a.is_finite() { a } else { 0.0 };
        self.z = [fin(zx), fin(zy)];
        self.vc = [fin(nvx), fin(nvy)];
        // Counted up to where the time constant stops growing.
        self.learned_s = min(fin(self.learned_s + dt * weight), 2.0 * CURRENT_SETTLE_S);
    }
}

/// `(tau_1, tau_2, x - x_r, y - y_r, wrapped yaw error)`.
pub fn hand(
    v: &Vehicle,
    g: &TrackingGains,
    st: &mut TrackingState,
    nav: &NavState,
    r: &RefSample,
    dt: f32,
) -> (f32, f32, f32, f32, f32) {
    let p = v.params();
    let xy = &v.xy;
    let mut eps = g.hand_m;
    let (s, c) = sin_cos(nav.yaw_rad);
    let achieved = st.achieved;
    st.current
        .update(v, nav, &achieved, (s, c), g.current_observer_rad_s, dt);
    let [ccx, ccy] = st.current.vc;
    // blend = clamp((|c| - dz) / dz, 0, 1): the root only between dz and 2 dz.
    let n2 = ccx * ccx + ccy * ccy;
    let dz = CURRENT_DEADZONE_M_S;
    let blend = if n2 <= dz * dz {
        0.0
    } else if n2 >= 4.0 * dz * dz {
        1.0
    } else {
        // NaN gives 0 (the lower bound).
        clamp((sqrt(n2) - dz) / dz, 0.0, 1.0)
    };
    let vc_used = [blend * ccx, blend * ccy];
    // In a current the reference is flown relative to the water (see below).
    let in_current = blend > 0.0;
    let [vx, vy, _] = r.vel_m_s;
    // Weight of the hand law (1) against the rest law (0), from the reference speed relative
    // to the water (the estimated current; over ground in still water): the hand law steers
    // the heading only through the motion through the water (its yaw dynamics have
    // stiffness `Y_v U`, time constant `eps / U`), so where the water-relative speed is low
    // (at rest; holding a point is not: there the water flows past) the heading is steered
    // directly. Without the current observer a current cannot be told from rest, and the
    // hand law is used throughout.
    let (wx, wy) = (vx - vc_used[0], vy - vc_used[1]);
    let w2 = wx * wx + wy * wy;
    let sigma = if g.current_observer_rad_s > 0.0 {
        smoothstep_sq(w2, REST_SPEED_LO_M_S, REST_SPEED_HI_M_S)
    } else {
        1.0
    };
    // In a current the course relative to the water is held below a floor: there its
    // direction is the estimate's noise (the vehicle drifts with the water and any heading
    // is feasible), and the rest law keeps the heading instead of chasing it.
    let usable = !in_current || w2 >= WATER_COURSE_FLOOR_M_S * WATER_COURSE_FLOOR_M_S;
    let course = if usable {
        course_of(r, wx, wy, w2)
    } else {
        None
    };
    let rest_dir = if !in_current {
        rest_direction(r)
    } else if usable {
        Some([wx, wy])
    } else {
        None
    };
    let (psi_r, psi_r1, psi_r2) = st.heading.update(xy, course, rest_dir, nav.yaw_rad, dt);
    if in_current {
        // The heading follows the feasible heading with the time constant `eps / U` (yaw
        // dynamics above): slow water lets the hand come closer to the origin.
        eps = clamp(HAND_PER_WATER_SPEED_S * sqrt(w2), HAND_MIN_M, eps);
    }
    // Current in the body frame, for the drag on the water-relative velocity.
    let [ux, uy] = vc_used;
    let vcb_x = c * ux + s * uy;
    let vcb_y = -s * ux + c * uy;
    let (u, vv, rr) = (nav.u_m_s, nav.v_m_s, nav.r_rad_s);
    let vs = vv + eps * rr;
    // Hand point and its velocity (inertial).
    let hx = nav.x_m + eps * c;
    let hy = nav.y_m + eps * s;
    let hx1 = c * u - s * vs;
    let hy1 = s * u + c * vs;
    // Hand reference.
    let [px, py, _] = r.pos_m;
    let [ax, ay, _] = r.acc_m_s2;
    let (sr, cr) = sin_cos(psi_r);
    let hrx = px + eps * cr;
    let hry = py + eps * sr;
    let hrx1 = vx - eps * psi_r1 * sr;
    let hry1 = vy + eps * psi_r1 * cr;
    let w2 = psi_r1 * psi_r1;
    let hrx2 = ax - eps * (psi_r2 * sr + w2 * cr);
    let hry2 = ay + eps * (psi_r2 * cr - w2 * sr);
    let (ex, ey) = sat2(hx - hrx, hy - hry, g.error_limit_m);
    // Integral on the origin error.
    let eox = nav.x_m - px;
    let eoy = nav.y_m - py;
    let (ix_e, iy_e) = sat2(eox, eoy, g.error_limit_m);
    let frozen = st.surge_sat || st.yaw_sat;
    let limit = g.integral_limit_m_s2 / g.xy_ki;
    let [ix, iy] = st.xy_int;
    // At rest the integrator does not integrate (the vehicle cannot act sideways: it would wind
    // up) and bleeds, so a value learnt while moving does not hold the vehicle off its point.
    let bleed = (1.0 - sigma) / REST_BLEED_S;
    st.xy_int = [
        integrate(ix, sigma * ix_e - bleed * ix, dt, frozen, limit),
        integrate(iy, sigma * iy_e - bleed * iy, dt, frozen, limit),
    ];
    let [ix, iy] = st.xy_int;
    let adx = hrx2 - g.xy_kd * (hx1 - hrx1) - g.xy_kp * ex - g.xy_ki * ix;
    let ady = hry2 - g.xy_kd * (hy1 - hry1) - g.xy_kp * ey - g.xy_ki * iy;
    let bx = c * adx + s * ady;
    let by = -s * adx + c * ady;
    // Model inversion.
    let (ur, vr) = (u - vcb_x, vv - vcb_y);
    let xd = (p.x_u + p.x_uu * ur.abs()) * ur;
    let yd = (p.y_v + p.y_vv * vr.abs()) * vr;
    let nd = (p.n_r + p.n_rr * rr.abs()) * rr;
    // In a current: the added mass of the current turning in the body frame, and the Munk
    // moment of the water-relative velocity (zero terms in still water).
    let km = xy.m11 - xy.m22;
    let (turn_x, turn_y) = (km * rr * vcb_y, km * rr * vcb_x);
    let munk = km * ur * vr;
    let vdot = (-xy.m11 * u * rr + turn_y - yd) / xy.m22;
    let tau1 = xy.m11 * (bx + vs * rr) - xy.m22 * vv * rr - turn_x + xd;
    let tau2 = xy.m33 * (by - vdot - u * rr) / eps - munk + nd;
    if sigma >= 1.0 {
        return (tau1, tau2, eox, eoy, wrap_angle(nav.yaw_rad - psi_r));
    }
    // Rest law: surge on the origin error along the body axis, heading by a PD. The heading
    // points at the reference point when the origin is far from it, else along the path's
    // course (Brockett: the sideways error of a vehicle at rest is not removed smoothly; it is
    // removed by the hand law once the reference moves).
    let ox1 = c * u - s * vv;
    let oy1 = s * u + c * vv;
    let aox = ax - g.xy_kd * (ox1 - vx) - g.xy_kp * ix_e - g.xy_ki * ix;
    let aoy = ay - g.xy_kd * (oy1 - vy) - g.xy_kp * iy_e - g.xy_ki * iy;
    let box_ = c * aox + s * aoy;
    let tau1_rest = xy.m11 * (box_ + vv * rr) - xy.m22 * vv * rr - turn_x + xd;
    // Near the point the heading is the path's direction; in a current the feasible heading
    // relative to the water (weather-vaning when holding a point: into the current), with
    // its rates as feedforward.
    let (chi0, ff1, ff2) = if in_current {
        (psi_r, psi_r1, psi_r2)
    } else {
        (st.heading.rest_chi(), 0.0, 0.0)
    };
    let dist = sqrt(eox * eox + eoy * eoy);
    let w_los = smoothstep(dist, REST_LOS_NEAR_M, REST_LOS_FAR_M);
    let los = if dist > 0.0 { atan2(-eoy, -eox) } else { chi0 };
    // The line of sight or its opposite (approach backwards), whichever is nearer the course,
    // with hysteresis so that a point abeam does not make the choice chatter.
    let d_los = wrap_angle(los - chi0);
    let half = core::f32::consts::FRAC_PI_2;
    let rev = &mut st.heading.rest_reverse;
    if d_los.abs() > half + REST_REVERSE_HYST_RAD {
        *rev = true;
    } else if d_los.abs() < half - REST_REVERSE_HYST_RAD {
        *rev = false;
    }
    let d_axis = if *rev {
        wrap_angle(d_los - core::f32::consts::PI)
    } else {
        d_los
    };
    let psi_rest = chi0 + w_los * d_axis;
    let e_psi = wrap_angle(nav.yaw_rad - psi_rest);
    let (ff1, ff2) = ((1.0 - w_los) * ff1, (1.0 - w_los) * ff2);
    let tau2_rest = xy.m33 * (ff2 - g.yaw_kp * e_psi - g.yaw_kd * (rr - ff1)) - munk + nd;
    let k = 1.0 - sigma;
    let e_yaw = wrap_angle(nav.yaw_rad - (psi_r + k * wrap_angle(psi_rest - psi_r)));
    (
        sigma * tau1 + k * tau1_rest,
        sigma * tau2 + k * tau2_rest,
        eox,
        eoy,
        e_yaw,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Observer's surge drag: `X_u`, `X_uu`.
    const K1: f32 = 0.9613;
    const K2: f32 = 4.4674;

    fn drag(x: f32) -> f32 {
        (K1 + K2 * x.abs()) * x
    }

    #[test]
    fn inv_drag_solves_the_drag_equation() {
        for i in -150..=150 {
            let x = i as f32 * 0.01;
            assert!((inv_drag(K1, K2, drag(x)) - x).abs() < 2e-6, "{x}");
        }
        assert_eq!(inv_drag(0.0, 0.0, 3.0), 0.0);
        assert_eq!(inv_drag(K1, K2, f32::NAN), 0.0);
    }
}
