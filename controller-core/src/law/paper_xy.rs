//! The paper's horizontal-plane (XY) backstepping law, eqs. (37), (39), (43), (46)-(47), (54),
//! (56), as printed except for its sign and index errors (listed below and in
//! `docs/derivation.md`), on the model of [`crate::model::xy`].
//!
//! # Reference state ([`reference_state`])
//! From the body-origin reference `(x_r, y_r)` and its derivatives (`RefSample` indices 0, 1):
//! `u_r = |v_r|` (path speed), `v_r = 0`, `psi_r` = heading of the reference velocity,
//! `r_r = psi_r_dot = (t x a) / u_r`, `u_r_dot = t . a`,
//! `r_r_dot = (t x j - 2 r_r u_r_dot) / u_r`, with `t = (cos psi_r, sin psi_r)`, `a`, `j` the
//! reference acceleration and jerk. For the paper's line `x_r = y_r` this is
//! `psi_r = pi/4`, `r_r = 0`. The heading of a reference at rest is not defined: below
//! [`MIN_HEADING_SPEED_M_S`] the law holds the vehicle's own heading (`psi_r = psi`,
//! `r_r = r_r_dot = 0`). This matters twice on the paper's reference: at the start (the
//! vehicle sits at yaw 0 until the reference speed reaches 1e-6 m/s, at t = 3.8 s; the
//! reference has then moved 1 um) and in the last seconds before `t_f`, where the velocity of
//! the f32 reference polynomial is below its own round-off (about 3e-8 m/s; its sign
//! flips, and a velocity heading would flip by pi). Divisions by `u_r` use a floor of
//! [`MIN_REFERENCE_SPEED_M_S`]. `v_r = 0` is exact on a straight line; on a curved path an
//! unactuated-sway vehicle must sideslip, so `v_r = 0` is then not dynamically feasible (the
//! paper's law is only claimed, and only tested here, on its line).
//!
//! # The law
//! Errors `x_e, y_e, psi_e = wrap(psi - psi_r), u_e, v_e, r_e`; `R_psi = [c -s; s c]`,
//! `delta = (R_psi - R_psi_r) U_r`.
//! ```text
//! (39) (alpha_u, alpha_v) = -R_psi^T (K X_e + delta);  varpi_u = u_e - alpha_u,
//!      varpi_v = v_e - alpha_v;  alpha_u_dot ~ -k (u_e + c delta_1 + s delta_2)
//! (47) rho_v = k (c delta_2 - s delta_1) + (k - beta1) v_e - beta2 |v|v - beta3 u_r r_r
//!              - v_r_dot - beta1 v_r + beta3 r_r (k x_e c + k y_e s + c delta_1 + s delta_2)
//!      alpha_r = -c_r (psi_e - beta3 u varpi_v),  varpi_r = r_e - alpha_r
//! (54) tau_r = -c_1r varpi_r - c_2r varpi_r^3 - c_r ((beta3 u)^2 + 1) r_e
//!              + c_r beta3 u rho_v - c_r beta3^2 u r_r varpi_u
//! (56) f_u = beta3 r_r varpi_v - c_3 varpi_v^2 varpi_u - c_4 varpi_v^4 varpi_u
//! (43) tau_u = -c_1u varpi_u - c_2u varpi_u^3 + alpha_u_dot - x_e c - y_e s + f_u
//! (37) tau_1 = m_11 (tau_u - alpha1 u + alpha2 |u|u + alpha3 v r + u_r_dot)
//!      tau_2 = m_33 (tau_r + gamma1 r + gamma2 |r|r + gamma3 u v + r_r_dot)
//! ```
//! Corrections against the printed paper: (36)-(37) carry a stray factor `u` on the
//! `gamma3` term and write `tau_1`, `tau_2` where the model has `tau_1 / m_11`,
//! `tau_2 / m_33`; (37) is solved for the physical forces. (39), (43), (47), (54), (56) are
//! used as printed (they are mutually consistent; only labels are wrong in the text: `f_w`,
//! `c_1w`, `c_2w` for `f_u`, `c_1u`, `c_2u`). The approximate derivatives of the virtual
//! controls are kept, as printed.
//!
//! `c_3`, `c_4` are not given in the paper; see [`PaperXyGains::PAPER`].

use super::LawOutput;
use crate::error::{positive, Error};
use crate::math::{atan2, max, sin_cos, sq_signed, sqrt, wrap_angle};
use crate::params::Vehicle;
use crate::reference::RefSample;
use crate::state::{BodyForces, TrackingErrors, XyState};
use serde::{Deserialize, Serialize};

/// Gains of the paper's XY law.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PaperXyGains {
    /// `k` of eq. (39).
    pub k: f32,
    /// `c_1u` of eq. (43).
    pub c1u: f32,
    /// `c_2u` of eq. (43).
    pub c2u: f32,
    /// `c_1r` of eq. (54).
    pub c1r: f32,
    /// `c_2r` of eq. (54).
    pub c2r: f32,
    /// `c_r` of step 3.
    pub cr: f32,
    /// `c_3` of eq. (56) (not given in the paper).
    pub c3: f32,
    /// `c_4` of eq. (56) (not given in the paper).
    pub c4: f32,
}

impl PaperXyGains {
    /// The paper's gains (Section IV: `k = 0.1`, `c_1u = c_2u = 10`, `c_1r = c_2r = 1`,
    /// `c_r = 10`) plus `c_3 = c_4 = 1`, which the paper does not give (its argument asks
    /// `c_3` "large"). On the paper's straight line `varpi_v` stays near zero and the result
    /// is the same for `c_3 = c_4` in {0.1, 1, 10, 100} (`tests/paper_closed_loop.rs`).
    pub const PAPER: Self = Self {
        k: 0.1,
        c1u: 10.0,
        c2u: 10.0,
        c1r: 1.0,
        c2r: 1.0,
        cr: 10.0,
        c3: 1.0,
        c4: 1.0,
    };

    /// Refuse non-finite or non-positive gains.
    pub fn validate(&self) -> Result<(), Error> {
        for (n, v) in [
            ("k", self.k),
            ("c1u", self.c1u),
            ("c2u", self.c2u),
            ("c1r", self.c1r),
            ("c2r", self.c2r),
            ("cr", self.cr),
            ("c3", self.c3),
            ("c4", self.c4),
        ] {
            positive(n, v)?;
        }
        Ok(())
    }
}

impl Default for PaperXyGains {
    fn default() -> Self {
        Self::PAPER
    }
}

/// Reference speed below which the divisions by `u_r` are floored.
pub const MIN_REFERENCE_SPEED_M_S: f32 = 1e-3;

/// Reference speed below which the reference heading is taken as undefined (module docs).
pub const MIN_HEADING_SPEED_M_S: f32 = 1e-6;

/// The reference state of the horizontal plane derived from a [`RefSample`] (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct XyReference {
    /// `x_r`.
    pub x_m: f32,
    /// `y_r`.
    pub y_m: f32,
    /// `psi_r`.
    pub yaw_rad: f32,
    /// `u_r` (path speed).
    pub u_m_s: f32,
    /// `v_r` (0).
    pub v_m_s: f32,
    /// `r_r`.
    pub r_rad_s: f32,
    /// `u_r_dot`.
    pub u_dot_m_s2: f32,
    /// `v_r_dot` (0).
    pub v_dot_m_s2: f32,
    /// `r_r_dot`.
    pub r_dot_rad_s2: f32,
}

/// The reference state for the horizontal plane; `yaw_now_rad` is the vehicle's heading, used
/// only when the reference does not define one (module docs).
pub fn reference_state(r: &RefSample, yaw_now_rad: f32) -> XyReference {
    reference_state_sin_cos(r, yaw_now_rad).0
}

/// [`reference_state`] and `(sin, cos)` of its heading, so a step computes them once.
#[inline]
fn reference_state_sin_cos(r: &RefSample, yaw_now_rad: f32) -> (XyReference, (f32, f32)) {
    let [x_r, y_r, _] = r.pos_m;
    let [xd, yd, _] = r.vel_m_s;
    let [xdd, ydd, _] = r.acc_m_s2;
    let [xddd, yddd, _] = r.jerk_m_s3;
    let speed = sqrt(xd * xd + yd * yd);
    let defined = speed > MIN_HEADING_SPEED_M_S;
    let psi_r = if defined {
        atan2(yd, xd)
    } else {
        wrap_angle(yaw_now_rad)
    };
    let (sp, cp) = sin_cos(psi_r);
    let inv_speed = 1.0 / max(speed, MIN_REFERENCE_SPEED_M_S);
    let u_dot = cp * xdd + sp * ydd;
    let (r_r, r_dot) = if defined {
        let r_r = (cp * ydd - sp * xdd) * inv_speed;
        (r_r, (cp * yddd - sp * xddd - 2.0 * r_r * u_dot) * inv_speed)
    } else {
        (0.0, 0.0)
    };
    let rf = XyReference {
        x_m: x_r,
        y_m: y_r,
        yaw_rad: psi_r,
        u_m_s: speed,
        v_m_s: 0.0,
        r_rad_s: r_r,
        u_dot_m_s2: u_dot,
        v_dot_m_s2: 0.0,
        r_dot_rad_s2: r_dot,
    };
    (rf, (sp, cp))
}

/// Intermediate quantities of one step, for logs and tests.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PaperXyInternals {
    /// Virtual controls `(alpha_u, alpha_v)` of eq. (39).
    pub alpha_u_m_s: f32,
    /// See `alpha_u_m_s`.
    pub alpha_v_m_s: f32,
    /// `varpi_u = u_e - alpha_u`.
    pub varpi_u_m_s: f32,
    /// `varpi_v = v_e - alpha_v`.
    pub varpi_v_m_s: f32,
    /// Virtual yaw rate `alpha_r` (step 3).
    pub alpha_r_rad_s: f32,
    /// `varpi_r = r_e - alpha_r`.
    pub varpi_r_rad_s: f32,
    /// `rho_v` of eq. (47).
    pub rho_v: f32,
    /// New control `tau_u = u_e_dot` (eq. 43).
    pub tau_u_m_s2: f32,
    /// New control `tau_r = r_e_dot` (eq. 54).
    pub tau_r_rad_s2: f32,
}

/// One step of the paper's XY law: generalized forces `tau_1` (surge) and `tau_2` (yaw
/// moment) for the navigation state `s` and the reference sample `r`, plus the body-origin
/// tracking errors. Pure, no allocation, no panics.
pub fn step(v: &Vehicle, g: &PaperXyGains, s: &XyState, r: &RefSample) -> LawOutput {
    step_with_internals(v, g, s, r).0
}

/// [`step`], also returning its intermediate quantities.
pub fn step_with_internals(
    v: &Vehicle,
    g: &PaperXyGains,
    s: &XyState,
    r: &RefSample,
) -> (LawOutput, PaperXyInternals) {
    let c = &v.xy;
    let (rf, (spr, cpr)) = reference_state_sin_cos(r, s.yaw_rad);
    let k = g.k;
    let (sp, cp) = sin_cos(s.yaw_rad);
    let (u, vv, rr_now) = (s.u_m_s, s.v_m_s, s.r_rad_s);
    let (ur, vr, rr) = (rf.u_m_s, rf.v_m_s, rf.r_rad_s);

    let xe = s.x_m - rf.x_m;
    let ye = s.y_m - rf.y_m;
    let psi_e = wrap_angle(s.yaw_rad - rf.yaw_rad);
    let ue = u - ur;
    let ve = vv - vr;
    let re = rr_now - rr;

    // delta = (R_psi - R_psi_r) U_r, R_psi = [c -s; s c]   (eq. 35)
    let d1 = (cp - cpr) * ur + (-sp + spr) * vr;
    let d2 = (sp - spr) * ur + (cp - cpr) * vr;
    let rx1 = cp * xe + sp * ye;
    let rx2 = -sp * xe + cp * ye;
    let rd1 = cp * d1 + sp * d2;
    let rd2 = -sp * d1 + cp * d2;

    // (39)
    let al_u = -k * rx1 - rd1;
    let al_v = -k * rx2 - rd2;
    let al_u_dot = -k * (ue + rd1);
    let w_u = ue - al_u;
    let w_v = ve - al_v;

    // (47)
    let rho_v = k * rd2 + (k - c.beta1) * ve
        - c.beta2 * sq_signed(vv)
        - c.beta3 * ur * rr
        - rf.v_dot_m_s2
        - c.beta1 * vr
        + c.beta3 * rr * (k * rx1 + rd1);

    // Step 3 and (54).
    let b3u = c.beta3 * u;
    let al_r = -g.cr * (psi_e - b3u * w_v);
    let w_r = re - al_r;
    let tau_r = -g.c1r * w_r - g.c2r * w_r * w_r * w_r - g.cr * (b3u * b3u + 1.0) * re
        + g.cr * b3u * rho_v
        - g.cr * c.beta3 * b3u * rr * w_u;

    // (56) and (43).
    let w_v2 = w_v * w_v;
    let f_u = c.beta3 * rr * w_v - g.c3 * w_v2 * w_u - g.c4 * w_v2 * w_v2 * w_u;
    let tau_u = -g.c1u * w_u - g.c2u * w_u * w_u * w_u + al_u_dot - rx1 + f_u;

    // (37) solved for the physical forces.
    let tau_1 = c.m11
        * (tau_u - c.alpha1 * u + c.alpha2 * sq_signed(u) + c.alpha3 * vv * rr_now + rf.u_dot_m_s2);
    let tau_2 = c.m33
        * (tau_r
            + c.gamma1 * rr_now
            + c.gamma2 * sq_signed(rr_now)
            + c.gamma3 * u * vv
            + rf.r_dot_rad_s2);

    let out = LawOutput {
        forces: BodyForces {
            surge_n: tau_1,
            yaw_n_m: tau_2,
            heave_n: 0.0,
        },
        errors: TrackingErrors {
            x_m: xe,
            y_m: ye,
            z_m: 0.0,
            pitch_rad: 0.0,
            yaw_rad: psi_e,
        },
    };
    let internals = PaperXyInternals {
        alpha_u_m_s: al_u,
        alpha_v_m_s: al_v,
        varpi_u_m_s: w_u,
        varpi_v_m_s: w_v,
        alpha_r_rad_s: al_r,
        varpi_r_rad_s: w_r,
        rho_v,
        tau_u_m_s2: tau_u,
        tau_r_rad_s2: tau_r,
    };
    (out, internals)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::xy::derivative;
    use crate::reference::PaperPolynomial;
    use core::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI, TAU};
    use proptest::prelude::*;

    fn state() -> impl Strategy<Value = XyState> {
        (
            -2.0f32..12.0,
            -2.0f32..12.0,
            -PI..PI,
            -0.5f32..0.5,
            -0.5f32..0.5,
            -0.5f32..0.5,
        )
            .prop_map(|(x_m, y_m, yaw_rad, u_m_s, v_m_s, r_rad_s)| XyState {
                x_m,
                y_m,
                yaw_rad,
                u_m_s,
                v_m_s,
                r_rad_s,
            })
    }

    /// A horizontal circle of radius `rad` at angular rate `om`, at time `t`.
    fn circle(rad: f32, om: f32, t: f32) -> RefSample {
        let (s, c) = sin_cos(om * t);
        RefSample {
            t_s: t,
            pos_m: [rad * c, rad * s, 0.0],
            vel_m_s: [-rad * om * s, rad * om * c, 0.0],
            acc_m_s2: [-rad * om * om * c, -rad * om * om * s, 0.0],
            jerk_m_s3: [rad * om * om * om * s, -rad * om * om * om * c, 0.0],
        }
    }

    proptest! {
        /// Eq. (37) solved for the physical forces: with them, u_e_dot = tau_u and
        /// r_e_dot = tau_r exactly (the stray `u` of (36) and the m_11, m_33 scalings fixed).
        #[test]
        fn force_inversion_is_exact(s in state(), t in 0.0f32..120.0, circ in proptest::bool::ANY) {
            let v = Vehicle::observer();
            let r = if circ { circle(5.0, 0.05, t) } else { PaperPolynomial::PAPER.sample(t) };
            let (out, int) = step_with_internals(&v, &PaperXyGains::PAPER, &s, &r);
            let rf = reference_state(&r, s.yaw_rad);
            let d = derivative(&v, &s, &out.forces);
            let ue_dot = d.u_m_s - rf.u_dot_m_s2;
            let re_dot = d.r_rad_s - rf.r_dot_rad_s2;
            let tol = |x: f32, f: f32| 1e-5 * (1.0 + x.abs()) + 2e-6 * f.abs();
            prop_assert!((ue_dot - int.tau_u_m_s2).abs() < tol(int.tau_u_m_s2, out.forces.surge_n));
            prop_assert!((re_dot - int.tau_r_rad_s2).abs() < tol(int.tau_r_rad_s2, out.forces.yaw_n_m / v.xy.m33));
        }

        /// Eq. (39): with the body velocities on the virtual controls, X_e_dot = -K X_e.
        #[test]
        fn virtual_controls_make_the_position_error_decay(s in state(), t in 0.0f32..60.0, circ in proptest::bool::ANY) {
            let v = Vehicle::observer();
            let g = PaperXyGains::PAPER;
            let r = if circ { circle(5.0, 0.05, t) } else { PaperPolynomial::PAPER.sample(t + 10.0) };
            let rf = reference_state(&r, s.yaw_rad);
            let (out, int) = step_with_internals(&v, &g, &s, &r);
            let s2 = XyState {
                u_m_s: rf.u_m_s + int.alpha_u_m_s,
                v_m_s: rf.v_m_s + int.alpha_v_m_s,
                ..s
            };
            let d = derivative(&v, &s2, &BodyForces::default());
            let [xd, yd, _] = r.vel_m_s;
            let (xe, ye) = (out.errors.x_m, out.errors.y_m);
            prop_assert!((d.x_m - xd + g.k * xe).abs() < 2e-5 * (1.0 + xe.abs()));
            prop_assert!((d.y_m - yd + g.k * ye).abs() < 2e-5 * (1.0 + ye.abs()));
        }

        /// A heading 2 pi away is the same heading.
        #[test]
        fn yaw_error_is_wrapped(s in state(), t in 5.0f32..95.0) {
            let v = Vehicle::observer();
            let r = PaperPolynomial::PAPER.sample(t);
            let a = step(&v, &PaperXyGains::PAPER, &s, &r);
            let b = step(&v, &PaperXyGains::PAPER, &XyState { yaw_rad: s.yaw_rad + TAU, ..s }, &r);
            prop_assert!(a.errors.yaw_rad.abs() <= PI);
            prop_assert!((a.errors.yaw_rad - b.errors.yaw_rad).abs() < 1e-5);
            prop_assert!((a.forces.yaw_n_m - b.forces.yaw_n_m).abs() < 1e-3 * (1.0 + a.forces.yaw_n_m.abs()));
        }
    }

    #[test]
    fn paper_line_reference_state() {
        for t in [5.0f32, 30.0, 50.0, 90.0] {
            let r = PaperPolynomial::PAPER.sample(t);
            let rf = reference_state(&r, 1.0);
            assert!((rf.yaw_rad - FRAC_PI_4).abs() < 1e-6);
            assert!(rf.r_rad_s.abs() < 1e-8);
            assert!(rf.r_dot_rad_s2.abs() < 1e-7, "{}", rf.r_dot_rad_s2);
            assert_eq!(rf.v_m_s, 0.0);
            let [xd, _, _] = r.vel_m_s;
            assert!((rf.u_m_s - core::f32::consts::SQRT_2 * xd).abs() < 1e-6);
        }
        // At rest (t <= 0, t >= t_f): the vehicle's own heading is held.
        for t in [0.0f32, 100.0, 150.0] {
            let rf = reference_state(&PaperPolynomial::PAPER.sample(t), 1.0);
            assert_eq!((rf.yaw_rad, rf.u_m_s, rf.r_rad_s), (1.0, 0.0, 0.0));
        }
    }

    #[test]
    fn circle_reference_state() {
        let (rad, om) = (5.0f32, 0.05f32);
        for t in [0.0f32, 10.0, 40.0, 100.0] {
            let rf = reference_state(&circle(rad, om, t), 0.0);
            assert!(wrap_angle(rf.yaw_rad - (om * t + FRAC_PI_2)).abs() < 1e-5);
            assert!((rf.u_m_s - rad * om).abs() < 1e-6);
            assert!((rf.r_rad_s - om).abs() < 1e-5);
            assert!(rf.u_dot_m_s2.abs() < 1e-6 && rf.r_dot_rad_s2.abs() < 1e-5);
        }
    }

    #[test]
    fn on_the_reference_at_rest_needs_no_force() {
        let v = Vehicle::observer();
        let out = step(
            &v,
            &PaperXyGains::PAPER,
            &XyState::default(),
            &PaperPolynomial::PAPER.sample(0.0),
        );
        assert_eq!(out.forces, BodyForces::default());
    }
}
