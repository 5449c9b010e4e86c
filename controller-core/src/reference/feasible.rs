//! Orientation and body velocities consistent with a reference for the body origin.
//!
//! **Horizontal plane.** The path's course `chi = atan2(y_dot, x_dot)`, speed `U`, and their
//! rates follow from the sample's velocity, acceleration and jerk. The vehicle cannot push
//! sideways, so to move along the path its heading must differ from the course by the
//! sideslip `beta` (`psi = chi - beta`, `u = U cos beta`, `v = U sin beta`) that the sway
//! equation `m22 v_dot = -m11 u r - (Y_v + Y_vv |v|) v` allows. Written in `beta` with
//! `r = chi_dot - beta_dot`:
//! ```text
//! (m11 - m22) U cos(beta) beta_dot = g(beta) := m11 U chi_dot cos(beta) + m22 U_dot sin(beta)
//!                                              + (Y_v + Y_vv U |sin beta|) U sin(beta)
//! ```
//! Forward in time this is unstable (`dg/dbeta > 0`, `m11 > m22`): the only bounded solution
//! stays near the slow manifold `g(beta) = 0`. [`sideslip`] solves `g(beta_qs) = 0` (Newton,
//! floored derivative) and reports the time advance `T_adv = (m11 - m22) cos(beta) / g'`
//! of the first-order correction `beta ~ beta_qs + T_adv beta_qs_dot`, which the law applies.
//! Exact on circles and lines at constant speed; during speed ramps and curvature changes the
//! residual is second order in the rates.
//!
//! **Vertical plane.** With the CG below the CB, a surge acceleration `a` in steady
//! conditions needs the pitch `theta = -asin(a / g)` (`u1_dot = -g sin(theta)`, MODEL_NOTES
//! section 3): [`pitch_for_accel`].

use crate::math::{asin, atan2, clamp_keep_nan, max, sin_cos, sqrt};
use crate::params::{XyCoeffs, XzCoeffs};
use crate::reference::RefSample;

/// Below this horizontal speed the course and its rates are not computed from the sample.
pub const SPEED_FLOOR_M_S: f32 = 1.0e-6;

/// Largest sideslip the solver returns (rad). Near pi / 2: in a current the water-relative
/// course can turn fast while the water-relative speed is low (a lawnmower turn whose course
/// passes the current's direction), and `g(beta) = 0` then has its root far from 0 (the
/// sideslip of a steady turn, `tan beta ~ m11 chi_dot / Y_v`, does not shrink with the speed);
/// a clamp at 0.8 rad there steered a heading the sway dynamics could not follow
/// (docs/tracking.md).
pub const SIDESLIP_MAX_RAD: f32 = 1.5;

/// Course of the horizontal reference velocity, with speed and rates.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Course {
    /// Course `chi` (rad).
    pub chi_rad: f32,
    /// `chi_dot`.
    pub chi_dot: f32,
    /// `chi_ddot`.
    pub chi_ddot: f32,
    /// Horizontal speed `U`.
    pub speed_m_s: f32,
    /// `U_dot`.
    pub speed_dot: f32,
}

/// Course of the sample's horizontal velocity, or `None` below [`SPEED_FLOOR_M_S`] (the caller
/// holds its previous course then).
pub fn course(r: &RefSample) -> Option<Course> {
    course_in_water(r, [0.0, 0.0])
}

/// Course of the velocity relative to water moving at the constant inertial current
/// `current_m_s` (`[cx, cy]`): the heading and sideslip a vehicle needs follow the
/// water-relative motion. `None` below [`SPEED_FLOOR_M_S`].
pub fn course_in_water(r: &RefSample, current_m_s: [f32; 2]) -> Option<Course> {
    let [vx, vy, _] = r.vel_m_s;
    let [cx, cy] = current_m_s;
    let (vx, vy) = (vx - cx, vy - cy);
    course_of(r, vx, vy, vx * vx + vy * vy)
}

/// [`course_in_water`] from the water-relative velocity `(vx, vy)` and its squared norm `u2`
/// (the law has them already).
#[inline]
pub(crate) fn course_of(r: &RefSample, vx: f32, vy: f32, u2: f32) -> Option<Course> {
    // `u < SPEED_FLOOR_M_S` (or NaN) decided on `u2`: no square root when it is `None`.
    if u2 >= SPEED_FLOOR_M_S * SPEED_FLOOR_M_S {
        let [ax, ay, _] = r.acc_m_s2;
        let [jx, jy, _] = r.jerk_m_s3;
        let u = sqrt(u2);
        let cross = vx * ay - vy * ax;
        let dot = vx * ax + vy * ay;
        let chi_dot = cross / u2;
        // d/dt (v x a) = v x j
        let chi_ddot = (vx * jy - vy * jx) / u2 - 2.0 * chi_dot * dot / u2;
        Some(Course {
            chi_rad: atan2(vy, vx),
            chi_dot,
            chi_ddot,
            speed_m_s: u,
            speed_dot: dot / u,
        })
    } else {
        None
    }
}

/// Quasi-static sideslip and its time advance.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Sideslip {
    /// `beta_qs` solving `g(beta) = 0` (rad), `psi = chi - beta`.
    pub beta_rad: f32,
    /// `T_adv` (s) of the first-order correction `beta = beta_qs + T_adv beta_qs_dot`.
    pub advance_s: f32,
}

/// The constants of `g(beta) / (m22 U)` for one course, and its Newton step.
struct SlipEquation<'a> {
    xy: &'a XyCoeffs,
    u: f32,
    /// `beta3 chi_dot`.
    k: f32,
    /// `U_dot / U`.
    rate: f32,
    /// Lower bound of the derivative (keeps the step finite and in the right direction).
    floor: f32,
}

impl<'a> SlipEquation<'a> {
    /// `None` below the speed floor (or NaN).
    #[inline(always)]
    fn of(xy: &'a XyCoeffs, c: &Course) -> Option<Self> {
        let u = c.speed_m_s;
        // Below the floor or NaN: one comparison (false for NaN).
        if u >= SPEED_FLOOR_M_S {
            Some(Self {
                xy,
                u,
                k: xy.beta3 * c.chi_dot,
                rate: c.speed_dot / u,
                floor: 0.5 * xy.beta1 + 1.0e-3,
            })
        } else {
            None
        }
    }

    /// The start of a cold solve: the root of `g` linearized at 0.
    #[inline(always)]
    fn linear_root(&self) -> f32 {
        -self.k / max(self.rate + self.xy.beta1, self.floor)
    }

    /// One Newton step from `b`: `b` is clamped to +-[`SIDESLIP_MAX_RAD`] (a NaN kept) and its
    /// sine and cosine taken. Returns
    /// the next iterate, the cosine of the clamped `b`, the floored derivative there and
    /// whether the floor was used (the derivative was below it, or NaN).
    #[inline(always)]
    fn newton(&self, b: f32) -> (f32, f32, f32, bool) {
        let xy = self.xy;
        let bc = clamp_keep_nan(b, -SIDESLIP_MAX_RAD, SIDESLIP_MAX_RAD);
        let (s, co) = sin_cos(bc);
        let g = self.k * co + self.rate * s + (xy.beta1 + xy.beta2 * self.u * s.abs()) * s;
        let (d, floored) = self.deriv(s, co);
        (bc - g / d, co, d, floored)
    }

    /// `g'` at the angle of sine `s` and cosine `co`, floored; and whether the floor was
    /// used (the derivative was below it, or NaN).
    #[inline(always)]
    fn deriv(&self, s: f32, co: f32) -> (f32, bool) {
        let xy = self.xy;
        let d = -self.k * s + self.rate * co + (xy.beta1 + 2.0 * xy.beta2 * self.u * s.abs()) * co;
        // `f32::max` would be a call of `fmaxf`; this gives the same value (NaN: the floor).
        if d > self.floor {
            (d, false)
        } else {
            (self.floor, true)
        }
    }

    /// `T_adv = (m11 - m22) cos(beta) / g'(beta)`, with `(m11 - m22) / m22 = beta3 - 1`.
    #[inline(always)]
    fn advance(&self, co: f32, d: f32) -> f32 {
        (self.xy.beta3 - 1.0) * co / d
    }
}

/// `b` and `advance`, each replaced by 0 when not finite.
#[inline(always)]
fn finite_slip(b: f32, advance: f32) -> Sideslip {
    let ok = |x: f32| if x.is_finite() { x } else { 0.0 };
    Sideslip {
        beta_rad: ok(b),
        advance_s: ok(advance),
    }
}

/// Solve `g(beta) = 0` for the course `c` (see the module docs): three Newton steps from the
/// root of `g` linearized at 0, each iterate clamped to +-[`SIDESLIP_MAX_RAD`]. The law solves
/// it in full every step: a warm start from the last step would save instructions, not
/// accuracy.
pub fn sideslip(xy: &XyCoeffs, c: &Course) -> Sideslip {
    let Some(eq) = SlipEquation::of(xy, c) else {
        return Sideslip::default();
    };
    let mut b = eq.linear_root();
    for _ in 0..3 {
        b = eq.newton(b).0;
    }
    let b = clamp_keep_nan(b, -SIDESLIP_MAX_RAD, SIDESLIP_MAX_RAD);
    let (s, co) = sin_cos(b);
    finite_slip(b, eq.advance(co, eq.deriv(s, co).0))
}

/// Feasible pitch of an XZ reference, with two derivatives.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PitchRef {
    /// `theta_r` (rad).
    pub theta_rad: f32,
    /// `theta_r_dot`.
    pub theta_dot: f32,
    /// `theta_r_ddot` (the reference's snap is not available and taken as 0).
    pub theta_ddot: f32,
    /// Munk term of the surge-point acceleration along the reference, `k_m u_r w_r`
    /// (m/s^2), and its first two derivatives (the laws use them as the feedforward of the
    /// derivatives of their model term `h`).
    pub munk_m_s2: [f32; 3],
}

/// Pitch that lets the vehicle follow the XZ reference in quasi-steady motion
/// (`q ~ 0`): from `u1_dot = F_q / a_uq = -g sin(theta) - k_m u w` (pitch drag dropped,
/// `k_m = (Z_wdot - X_udot) / a_uq`, the Munk moment) and `u1_dot ~ x_ddot`:
/// `sin(theta_r) = -(x_r_ddot + k_m u_r w_r) / g`, with the body velocities
/// `u_r = c x_dot - s z_dot`, `w_r = s x_dot + c z_dot` (one fixed-point pass from
/// `theta = 0`). Diving forward at 0.5 m/s in both axes needs about -0.055 rad.
/// Derivatives with `theta` frozen in the rotation (first order).
pub fn pitch_xz(xz: &XzCoeffs, zx_kg: f32, gravity_m_s2: f32, r: &RefSample) -> PitchRef {
    pitch_xz_sc(xz, zx_kg, gravity_m_s2, r).0
}

/// [`pitch_xz`] and the sine and cosine of its `theta_rad` (the XZ law needs them too). The
/// fixed-point map contracts by about `2 k_m |v|^2 / g` (0.03 at 0.5 m/s): three passes from
/// `theta = 0` leave about `3e-5` of the pitch.
#[inline]
pub(crate) fn pitch_xz_sc(
    xz: &XzCoeffs,
    zx_kg: f32,
    gravity_m_s2: f32,
    r: &RefSample,
) -> (PitchRef, (f32, f32)) {
    let [vx, _, vz] = r.vel_m_s;
    let [ax, _, az] = r.acc_m_s2;
    let [jx, _, jz] = r.jerk_m_s3;
    let km = zx_kg / xz.a_uq;
    let g = gravity_m_s2;
    let solve = |s: f32, c: f32| {
        let cs = c * s;
        let c2 = c * c - s * s;
        let pw = cs * (vx * vx - vz * vz) + c2 * vx * vz;
        let arg = -(ax + km * pw) / g;
        (arg, cs, c2)
    };
    let mut sc = (0.0, 1.0);
    for _ in 0..2 {
        sc = sin_cos(asin(solve(sc.0, sc.1).0));
    }
    let (arg, cs, c2) = solve(sc.0, sc.1);
    // `asin` clamps its argument, so `th` is always finite (`ok(th) == th` below).
    let th = asin(arg);
    let sc_th = sin_cos(th);
    let cth = max(sc_th.1, 0.5);
    let pw1 = 2.0 * cs * (vx * ax - vz * az) + c2 * (ax * vz + vx * az);
    let pw2 = 2.0 * cs * (ax * ax + vx * jx - az * az - vz * jz)
        + c2 * (jx * vz + 2.0 * ax * az + vx * jz);
    let th1 = -(jx + km * pw1) / (g * cth);
    let th2 = -(km * pw2) / (g * cth);
    let pw = cs * (vx * vx - vz * vz) + c2 * vx * vz;
    let (m0, m1, m2) = (km * pw, km * pw1, km * pw2);
    let ok = |x: f32| if x.is_finite() { x } else { 0.0 };
    let pr = PitchRef {
        theta_rad: ok(th),
        theta_dot: ok(th1),
        theta_ddot: ok(th2),
        munk_m_s2: [ok(m0), ok(m1), ok(m2)],
    };
    (pr, sc_th)
}

/// Steady pitch for a surge acceleration `accel_m_s2`: `-asin(a / g)` (argument clamped).
pub fn pitch_for_accel(accel_m_s2: f32, gravity_m_s2: f32) -> f32 {
    -asin(accel_m_s2 / gravity_m_s2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::Vehicle;
    use crate::reference::Reference;

    /// On a steady circle the sideslip satisfies the steady sway equation
    /// `m11 u r + (Y_v + Y_vv |v|) v = 0` with `r = U / R`, and the vehicle points inward.
    #[test]
    fn circle_sideslip_solves_steady_sway() {
        let v = Vehicle::observer();
        let p = v.params();
        let r = Reference::Circle {
            center_m: [0.0, 5.0, 0.0],
            radius_m: 5.0,
            speed_m_s: 0.25,
        };
        let c = course(&r.sample(60.0)).unwrap();
        assert!((c.chi_dot - 0.05).abs() < 1e-5);
        let s = sideslip(&v.xy, &c);
        let (sb, cb) = crate::math::sin_cos(s.beta_rad);
        let (u, vv) = (0.25 * cb, 0.25 * sb);
        let res = v.xy.m11 * u * 0.05 + (p.y_v + p.y_vv * vv.abs()) * vv;
        assert!(res.abs() < 1e-5, "residual {res}");
        assert!(s.beta_rad < -0.1 && s.beta_rad > -0.3, "{s:?}");
    }

    #[test]
    fn straight_line_has_no_sideslip_and_course_is_heading() {
        let v = Vehicle::observer();
        let r = Reference::Line {
            start_m: [0.0; 3],
            heading_rad: 2.0,
            speed_m_s: 0.5,
        };
        let c = course(&r.sample(20.0)).unwrap();
        assert!((c.chi_rad - 2.0).abs() < 1e-6);
        assert_eq!(sideslip(&v.xy, &c).beta_rad, 0.0);
        assert!(course(&r.sample(0.0)).is_none());
    }

    /// Three passes from 0 solve the pitch's fixed-point equation
    /// `sin(theta) = -(x_r_ddot + k_m u_r w_r) / g` along the paper reference.
    #[test]
    fn the_feasible_pitch_solves_its_equation() {
        let v = Vehicle::observer();
        let p = v.params();
        let zx = p.z_wdot_kg - p.x_udot_kg;
        let km = zx / v.xz.a_uq;
        let r = crate::reference::PaperPolynomial::PAPER;
        let mut worst = 0.0f32;
        for i in 0..12_000 {
            let rs = r.sample(i as f32 * 0.01);
            let pr = pitch_xz(&v.xz, zx, p.gravity_m_s2, &rs);
            let (s, c) = sin_cos(pr.theta_rad);
            let [vx, _, vz] = rs.vel_m_s;
            let pw = c * s * (vx * vx - vz * vz) + (c * c - s * s) * vx * vz;
            let arg = -(rs.acc_m_s2[0] + km * pw) / p.gravity_m_s2;
            worst = worst.max((s - arg).abs());
        }
        assert!(worst < 1e-6, "{worst}");
    }

    #[test]
    fn xz_pitch_includes_the_munk_moment() {
        let v = Vehicle::observer();
        let p = v.params();
        let r = crate::reference::PaperPolynomial::PAPER.sample(50.0);
        let pr = pitch_xz(&v.xz, p.z_wdot_kg - p.x_udot_kg, p.gravity_m_s2, &r);
        // 0.5 m/s forward and down at zero acceleration: about -0.055 rad.
        assert!((pr.theta_rad + 0.055).abs() < 0.003, "{pr:?}");
        assert!((pitch_for_accel(0.981, 9.81) + 0.100_167).abs() < 1e-5);
    }
}
