//! The paper's vertical-plane (XZ) backstepping law, eqs. (6), (9), (12), (15), (22), (24),
//! as printed except for its sign and index errors (listed below and in
//! `docs/derivation.md`). It works on the transformed model of eq. (3) (see
//! [`crate::model::xz`]): the point `(x1, z1)` at `alpha = J_y / a_uq` below the body origin,
//! `u1 = u + alpha q`.
//!
//! # Reference state ([`reference_state`])
//! The paper gives a reference for the position only (`x_r = z_r = p(t)`, taken for the body
//! origin). Its law also needs `theta_r, u_1r, w_r, q_r`. We use the level-attitude reference
//! the paper's figures imply (pitch error around zero): `theta_r = 0`, `q_r = 0`, and the body
//! velocities of the reference point at that attitude, `u_r = x_r_dot`, `w_r = z_r_dot`, so
//! `u_1r = u_r + alpha q_r = x_r_dot`; the transformed point of the reference pose is
//! `x_1r = x_r + alpha sin(theta_r) = x_r`, `z_1r = z_r + alpha cos(theta_r) = z_r + alpha`.
//! Feed-forward derivatives: `u_1r_dot = x_r_ddot`, `w_r_dot = z_r_ddot`, `q_r_dot = 0`.
//! This reference is kinematically exact; it is not an equilibrium of the dynamics: with
//! `q = 0` and `theta = 0` the transformed point decelerates at `a7 w u1` (the Munk moment,
//! -0.54 m/s^2 at the paper's peak speed `u = w = 0.5 m/s`), which only a pitch of about
//! `asin(-(Z_wdot - X_udot) u w / (z_g W)) = -0.055 rad` cancels. The law counts that in its
//! disturbance `xi`.
//!
//! # The law
//! Errors `x1e, z1e, theta_e = wrap(theta - theta_r), u1e, w_e, q_e`;
//! `R_theta = [c s; -s c]`, `gamma = (R_theta - R_theta_r) U_r`, `U_r = (u_1r, w_r)`.
//! ```text
//! (9)  (alpha_u1, alpha_w) = -R_theta^T (K X_e + gamma)                [gamma sign corrected]
//!      nu_u1 = u1e - alpha_u1,  nu_w = w_e - alpha_w
//!      alpha_w_dot ~ -k (w_e + s gamma_1 + c gamma_2)                   [paper's approximation]
//!      alpha_u1_dot ~ -k (u1e + c gamma_1 - s gamma_2)
//! (8)  xi = a2 |u|u + a1 u_1r + a3 q_r + a4 q|q| + a5 sin(theta) + a6 w_r q_r + a7 u_1r w_r
//!           - u_1r_dot
//! (15) rho = (a6 q_r + a7 u_1r) alpha_w + (a1 + k) u1e + a7 w u1e + xi + k (c gamma_1 - s gamma_2)
//!      alpha_q = -c_q ((a3 + a6 w) nu_u1 + theta_e),  nu_q = q_e - alpha_q
//! (22) tau_q = -c_1q nu_q - c_2q nu_q^3 - c_q ((a3 + a6 w)^2 + 1) q_e - c_q (a3 + a6 w) rho
//!              - c_q (a3 + a6 w) (a6 q_r + a7 u_1r) nu_w
//! (24) f_w = -nu_u1 (a6 q_r + a7 u_1r) - c_1 nu_u1^2 nu_w - c_2 nu_u1^4 nu_w
//! (12) tau_w = -c_1w nu_w - c_2w nu_w^3 - k (w_e + s gamma_1 + c gamma_2)
//!              - (x1e s + z1e c) + f_w
//! (6)  tau_3 = m_z (tau_w - b1 w - b2 |w|w - b3 cos(theta) - b4 u q - b5 q^2 + w_r_dot)
//!      tau_1 = (tau_q + q_r_dot - d1 u - d2 |u|u - d3 q - d4 q|q| - d5 sin(theta) - d6 w q
//!               - d7 w u) / d_tau,     d_tau = -a_uq / delta
//! ```
//! Corrections against the printed paper: the sign of `gamma` in (9); in (15) the signs of the
//! `k u1e` and `k (c gamma_1 - s gamma_2)` terms (the printed ones contradict the paper's own
//! `alpha_w_dot` in (12) and its XY twin (47)) and the `a7 w u1e` term the printed expansion of
//! `rho` loses; in (6) the gain of `tau_1` (`-delta / a_uq`, printed `alpha delta`), `d4` for
//! the printed `a4` in the `q|q|` term, and the `d_i`/`b4` multiplying the physical `u` (the
//! printed `u1` comes from the wrong sign of `u1`). The approximate derivatives of the virtual
//! controls (rotation and reference-derivative terms dropped) and the cross terms
//! `-(a3 + a6 w) nu_u1 - theta_e` that a complete backstepping step 4 would add to `tau_q` are
//! kept as printed: this is the paper's law, to be judged, not repaired.
//!
//! `c_1`, `c_2` are not given in the paper; see [`PaperXzGains::PAPER`].

use super::LawOutput;
use crate::error::{positive, Error};
use crate::math::{sin_cos, sq_signed, wrap_angle};
use crate::model::xz::{pos_floor, to_transformed_with};
use crate::params::Vehicle;
use crate::reference::RefSample;
use crate::state::{BodyForces, TrackingErrors, XzState};
use serde::{Deserialize, Serialize};

/// Gains of the paper's XZ law.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PaperXzGains {
    /// `k` of eq. (9).
    pub k: f32,
    /// `c_1w` of eq. (12).
    pub c1w: f32,
    /// `c_2w` of eq. (12).
    pub c2w: f32,
    /// `c_1q` of eq. (22).
    pub c1q: f32,
    /// `c_2q` of eq. (22).
    pub c2q: f32,
    /// `c_q` of step 3.
    pub cq: f32,
    /// `c_1` of eq. (24) (not given in the paper).
    pub c1: f32,
    /// `c_2` of eq. (24) (not given in the paper).
    pub c2: f32,
}

impl PaperXzGains {
    /// The paper's gains (Section IV: `k = 0.1`, `c_1w = c_2w = 10`, `c_1q = c_2q = 1`,
    /// `c_q = 10`) plus `c_1 = c_2 = 1`, which the paper does not give. Its Young-inequality
    /// argument only asks `c_1` to be "large" next to a sum of unspecified `epsilon_i`; 1 keeps
    /// the `nu_u1^2 nu_w` damping of (24) on the scale of `c_1q`. The choice does not change
    /// the verdict: on the paper's reference the law diverges for `c_1 = c_2` in
    /// {0.1, 1, 10, 100} (`tests/paper_closed_loop.rs`).
    pub const PAPER: Self = Self {
        k: 0.1,
        c1w: 10.0,
        c2w: 10.0,
        c1q: 1.0,
        c2q: 1.0,
        cq: 10.0,
        c1: 1.0,
        c2: 1.0,
    };

    /// Refuse non-finite or non-positive gains.
    pub fn validate(&self) -> Result<(), Error> {
        for (n, v) in [
            ("k", self.k),
            ("c1w", self.c1w),
            ("c2w", self.c2w),
            ("c1q", self.c1q),
            ("c2q", self.c2q),
            ("cq", self.cq),
            ("c1", self.c1),
            ("c2", self.c2),
        ] {
            positive(n, v)?;
        }
        Ok(())
    }
}

impl Default for PaperXzGains {
    fn default() -> Self {
        Self::PAPER
    }
}

/// The reference state of the vertical plane derived from a [`RefSample`] (see the module
/// docs): the body-origin reference, the level attitude, and the transformed point.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct XzReference {
    /// `x_r` (body origin).
    pub x_m: f32,
    /// `z_r` (body origin).
    pub z_m: f32,
    /// `theta_r` (0: level).
    pub pitch_rad: f32,
    /// `u_r`.
    pub u_m_s: f32,
    /// `w_r`.
    pub w_m_s: f32,
    /// `q_r`.
    pub q_rad_s: f32,
    /// `x_1r = x_r + alpha sin(theta_r)`.
    pub x1_m: f32,
    /// `z_1r = z_r + alpha cos(theta_r)`.
    pub z1_m: f32,
    /// `u_1r = u_r + alpha q_r`.
    pub u1_m_s: f32,
    /// `u_1r_dot`.
    pub u1_dot_m_s2: f32,
    /// `w_r_dot`.
    pub w_dot_m_s2: f32,
    /// `q_r_dot`.
    pub q_dot_rad_s2: f32,
}

/// The level-attitude reference state for the vertical plane (module docs). `RefSample`
/// index 0 is x, index 2 is z.
pub fn reference_state(v: &Vehicle, r: &RefSample) -> XzReference {
    let [x_r, _, z_r] = r.pos_m;
    let [xd, _, zd] = r.vel_m_s;
    let [xdd, _, zdd] = r.acc_m_s2;
    let theta_r = 0.0f32;
    let q_r = 0.0f32;
    let (s, c) = sin_cos(theta_r);
    // Body velocities of the reference point at the attitude theta_r: R_theta_r^T (x_dot, z_dot)
    // with R_theta = [c s; -s c]. At theta_r = 0 they are the inertial velocities.
    let u_r = c * xd - s * zd;
    let w_r = s * xd + c * zd;
    let a = v.xz.alpha;
    XzReference {
        x_m: x_r,
        z_m: z_r,
        pitch_rad: theta_r,
        u_m_s: u_r,
        w_m_s: w_r,
        q_rad_s: q_r,
        x1_m: x_r + a * s,
        z1_m: z_r + a * c,
        u1_m_s: u_r + a * q_r,
        u1_dot_m_s2: c * xdd - s * zdd,
        w_dot_m_s2: s * xdd + c * zdd,
        q_dot_rad_s2: 0.0,
    }
}

/// Intermediate quantities of one step, for logs and tests.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PaperXzInternals {
    /// `x1 - x_1r`.
    pub x1e_m: f32,
    /// `z1 - z_1r`.
    pub z1e_m: f32,
    /// Virtual controls `(alpha_u1, alpha_w)` of eq. (9).
    pub alpha_u1_m_s: f32,
    /// See `alpha_u1_m_s`.
    pub alpha_w_m_s: f32,
    /// `nu_u1 = u1e - alpha_u1`.
    pub nu_u1_m_s: f32,
    /// `nu_w = w_e - alpha_w`.
    pub nu_w_m_s: f32,
    /// Virtual pitch rate `alpha_q` (step 3).
    pub alpha_q_rad_s: f32,
    /// `nu_q = q_e - alpha_q`.
    pub nu_q_rad_s: f32,
    /// New control `tau_w = w_e_dot` (eq. 12).
    pub tau_w_m_s2: f32,
    /// New control `tau_q = q_e_dot` (eq. 22).
    pub tau_q_rad_s2: f32,
}

/// One step of the paper's XZ law: generalized forces `tau_1` (surge) and `tau_3` (heave)
/// for the navigation state `s` and the reference sample `r`, plus the body-origin tracking
/// errors. Pure, no allocation, no panics; non-finite inputs give non-finite forces, which
/// the allocation maps to zero thrust.
pub fn step(v: &Vehicle, g: &PaperXzGains, s: &XzState, r: &RefSample) -> LawOutput {
    step_with_internals(v, g, s, r).0
}

/// [`step`], also returning its intermediate quantities.
pub fn step_with_internals(
    v: &Vehicle,
    g: &PaperXzGains,
    s: &XzState,
    r: &RefSample,
) -> (LawOutput, PaperXzInternals) {
    let c = &v.xz;
    let rf = reference_state(v, r);
    let k = g.k;
    let (sth, cth) = sin_cos(s.pitch_rad);
    let (sr, cr) = sin_cos(rf.pitch_rad);
    let t = to_transformed_with(v, s, (sth, cth));
    let (u, w, q) = (s.u_m_s, s.w_m_s, s.q_rad_s);

    // Errors of the transformed point and velocities.
    let x1e = t.x1_m - rf.x1_m;
    let z1e = t.z1_m - rf.z1_m;
    let th_e = wrap_angle(s.pitch_rad - rf.pitch_rad);
    let u1e = t.u1_m_s - rf.u1_m_s;
    let we = w - rf.w_m_s;
    let qe = q - rf.q_rad_s;
    let (u1r, wr, qr) = (rf.u1_m_s, rf.w_m_s, rf.q_rad_s);

    // gamma = (R_theta - R_theta_r) U_r, R_theta = [c s; -s c]   (eq. 4)
    let g1 = (cth - cr) * u1r + (sth - sr) * wr;
    let g2 = -(sth - sr) * u1r + (cth - cr) * wr;
    // R_theta^T X_e and R_theta^T gamma.
    let rx1 = cth * x1e - sth * z1e;
    let rx2 = sth * x1e + cth * z1e;
    let rg1 = cth * g1 - sth * g2;
    let rg2 = sth * g1 + cth * g2;

    // (9), gamma sign corrected: (alpha_u1, alpha_w) = -R^T (K X_e + gamma).
    let al_u1 = -k * rx1 - rg1;
    let al_w = -k * rx2 - rg2;
    let nu_u1 = u1e - al_u1;
    let nu_w = we - al_w;
    // The paper's approximate derivative of alpha_w (12).
    let al_w_dot = -k * (we + rg2);

    // (8) xi and (15) rho, corrected.
    let xi = c.a2 * sq_signed(u)
        + c.a1 * u1r
        + c.a3 * qr
        + c.a4 * sq_signed(q)
        + c.a5 * sth
        + c.a6 * wr * qr
        + c.a7 * u1r * wr
        - rf.u1_dot_m_s2;
    let cpl = c.a6 * qr + c.a7 * u1r;
    let rho = cpl * al_w + (c.a1 + k) * u1e + c.a7 * w * u1e + xi + k * rg1;

    // Step 3: virtual pitch rate; step 4 (22).
    let coup = c.a3 + c.a6 * w;
    let al_q = -g.cq * (coup * nu_u1 + th_e);
    let nu_q = qe - al_q;
    let tau_q = -g.c1q * nu_q
        - g.c2q * nu_q * nu_q * nu_q
        - g.cq * (coup * coup + 1.0) * qe
        - g.cq * coup * rho
        - g.cq * coup * cpl * nu_w;

    // (24) and (12).
    let nu_u1_2 = nu_u1 * nu_u1;
    let f_w = -nu_u1 * cpl - g.c1 * nu_u1_2 * nu_w - g.c2 * nu_u1_2 * nu_u1_2 * nu_w;
    let tau_w = -g.c1w * nu_w - g.c2w * nu_w * nu_w * nu_w + al_w_dot - rx2 + f_w;

    // (6): back to the physical forces.
    let tau_3 = c.m_z
        * (tau_w - c.b1 * w - c.b2 * sq_signed(w) - c.b3 * cth - c.b4 * u * q - c.b5 * q * q
            + rf.w_dot_m_s2);
    let q_dot_wanted = tau_q + rf.q_dot_rad_s2
        - c.d1 * u
        - c.d2 * sq_signed(u)
        - c.d3 * q
        - c.d4 * sq_signed(q)
        - c.d5 * sth
        - c.d6 * w * q
        - c.d7 * w * u;
    // 1 / d_tau = -delta / a_uq; a_uq = m z_g > 0 for a validated vehicle, floored anyway.
    let tau_1 = -c.delta / pos_floor(c.a_uq) * q_dot_wanted;

    let out = LawOutput {
        forces: BodyForces {
            surge_n: tau_1,
            yaw_n_m: 0.0,
            heave_n: tau_3,
        },
        errors: TrackingErrors {
            x_m: s.x_m - rf.x_m,
            y_m: 0.0,
            z_m: s.z_m - rf.z_m,
            pitch_rad: th_e,
            yaw_rad: 0.0,
        },
    };
    let internals = PaperXzInternals {
        x1e_m: x1e,
        z1e_m: z1e,
        alpha_u1_m_s: al_u1,
        alpha_w_m_s: al_w,
        nu_u1_m_s: nu_u1,
        nu_w_m_s: nu_w,
        alpha_q_rad_s: al_q,
        nu_q_rad_s: nu_q,
        tau_w_m_s2: tau_w,
        tau_q_rad_s2: tau_q,
    };
    (out, internals)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::xz::derivative;
    use crate::params::VehicleParams;
    use crate::reference::PaperPolynomial;
    use proptest::prelude::*;

    fn state() -> impl Strategy<Value = XzState> {
        (
            -2.0f32..12.0,
            -2.0f32..12.0,
            -0.6f32..0.6,
            -0.5f32..0.5,
            -0.5f32..0.5,
            -0.5f32..0.5,
        )
            .prop_map(|(x_m, z_m, pitch_rad, u_m_s, w_m_s, q_rad_s)| XzState {
                x_m,
                z_m,
                pitch_rad,
                u_m_s,
                w_m_s,
                q_rad_s,
            })
    }

    proptest! {
        /// Eq. (6) inverts the model exactly: with the law's forces, w_e_dot = tau_w and
        /// q_e_dot = tau_q (this is what fixes the tau_1 gain -delta/a_uq and the d_i on u).
        #[test]
        fn force_inversion_is_exact(s in state(), t in 0.0f32..120.0) {
            let v = Vehicle::observer();
            let r = PaperPolynomial::PAPER.sample(t);
            let (out, int) = step_with_internals(&v, &PaperXzGains::PAPER, &s, &r);
            let rf = reference_state(&v, &r);
            let d = derivative(&v, &s, &out.forces);
            let we_dot = d.w_m_s - rf.w_dot_m_s2;
            let qe_dot = d.q_rad_s - rf.q_dot_rad_s2;
            let tol = |x: f32, f: f32| 1e-5 * (1.0 + x.abs()) + 2e-6 * f.abs();
            prop_assert!((we_dot - int.tau_w_m_s2).abs() < tol(int.tau_w_m_s2, out.forces.heave_n),
                "{} vs {}", we_dot, int.tau_w_m_s2);
            prop_assert!((qe_dot - int.tau_q_rad_s2).abs() < tol(int.tau_q_rad_s2, out.forces.surge_n),
                "{} vs {}", qe_dot, int.tau_q_rad_s2);
        }

        /// Eq. (9) corrected: if the velocities equal the virtual controls, the transformed
        /// point error decays as X_e_dot = -K X_e, at any attitude (the printed sign of gamma
        /// fails this as soon as theta != theta_r and the reference moves).
        #[test]
        fn virtual_controls_make_the_position_error_decay(s in state(), t in 10.0f32..90.0) {
            let v = Vehicle::observer();
            let g = PaperXzGains::PAPER;
            let r = PaperPolynomial::PAPER.sample(t);
            let rf = reference_state(&v, &r);
            let (_, int) = step_with_internals(&v, &g, &s, &r);
            // Put the velocities on the virtual controls: u1 = u1r + alpha_u1, w = wr + alpha_w.
            let u1 = rf.u1_m_s + int.alpha_u1_m_s;
            let w = rf.w_m_s + int.alpha_w_m_s;
            let s2 = XzState { u_m_s: u1 - v.xz.alpha * s.q_rad_s, w_m_s: w, ..s };
            let (_, int2) = step_with_internals(&v, &g, &s2, &r);
            prop_assert!(int2.nu_u1_m_s.abs() < 1e-5 && int2.nu_w_m_s.abs() < 1e-5);
            let m = crate::model::xz::map_derivative(&v, &s2, &derivative(&v, &s2, &BodyForces::default()));
            let [xd, _, zd] = r.vel_m_s;
            // x_1r = x_r, z_1r = z_r + alpha at theta_r = 0.
            let x1e_dot = m.x1_m - xd;
            let z1e_dot = m.z1_m - zd;
            prop_assert!((x1e_dot + g.k * int.x1e_m).abs() < 2e-5 * (1.0 + int.x1e_m.abs()));
            prop_assert!((z1e_dot + g.k * int.z1e_m).abs() < 2e-5 * (1.0 + int.z1e_m.abs()));
        }
    }

    #[test]
    fn at_rest_on_the_reference_needs_no_force_but_the_trim() {
        let r = PaperPolynomial::PAPER.sample(0.0);
        let v = Vehicle::observer();
        let out = step(&v, &PaperXzGains::PAPER, &XzState::default(), &r);
        assert_eq!(out.forces, BodyForces::default());
        assert_eq!(out.errors, TrackingErrors::default());
        // 2 N positively buoyant: the law holds depth with 2 N down (z is down).
        let mut p = VehicleParams::OBSERVER;
        p.buoyancy_offset_n = 2.0;
        let v = p.validate().unwrap();
        let out = step(&v, &PaperXzGains::PAPER, &XzState::default(), &r);
        assert!((out.forces.heave_n - 2.0).abs() < 1e-5, "{:?}", out.forces);
        assert!(out.forces.surge_n.abs() < 1e-5);
    }

    #[test]
    fn errors_are_body_origin_minus_reference_and_wrapped() {
        let v = Vehicle::observer();
        let r = PaperPolynomial::PAPER.sample(50.0); // x_r = z_r = 5 m
        let s = XzState {
            x_m: 5.5,
            z_m: 4.0,
            pitch_rad: 0.1 + core::f32::consts::TAU,
            ..XzState::default()
        };
        let e = step(&v, &PaperXzGains::PAPER, &s, &r).errors;
        assert!((e.x_m - 0.5).abs() < 1e-5 && (e.z_m + 1.0).abs() < 1e-5);
        assert!((e.pitch_rad - 0.1).abs() < 1e-5);
    }

    #[test]
    fn level_reference_state_of_the_paper_polynomial() {
        let v = Vehicle::observer();
        let r = PaperPolynomial::PAPER.sample(50.0);
        let rf = reference_state(&v, &r);
        assert_eq!(rf.pitch_rad, 0.0);
        assert_eq!(rf.q_rad_s, 0.0);
        let [xd, _, zd] = r.vel_m_s;
        assert_eq!((rf.u_m_s, rf.w_m_s, rf.u1_m_s), (xd, zd, xd));
        assert!((rf.z1_m - (5.0 + v.xz.alpha)).abs() < 1e-5);
        assert_eq!(rf.x1_m, rf.x_m);
    }
}
