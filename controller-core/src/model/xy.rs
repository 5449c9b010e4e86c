//! Horizontal-plane (XY) model: paper eq. (34), reduced as in `MODEL_NOTES` section 4 (roll
//! not modelled, so the 6-DOF cross terms `J_y m_y + a_uq a_vp` of the paper drop out), in the
//! paper's notation of eq. (36) without its stray `u` factor.
//!
//! ```text
//! x_dot = cos(psi) u - sin(psi) v,   y_dot = sin(psi) u + cos(psi) v,   psi_dot = r
//! m_11 u_dot = m_22 v r - (X_u + X_uu|u|) u + tau_1
//! m_22 v_dot = -m_11 u r - (Y_v + Y_vv|v|) v
//! m_33 r_dot = (m_11 - m_22) u v - (N_r + N_rr|r|) r + tau_2
//! ```
//! i.e. `u_dot = alpha1 u - alpha2 |u| u - alpha3 v r + tau_1 / m_11`,
//! `v_dot = -beta1 v - beta2 |v| v - beta3 u r`,
//! `r_dot = -gamma1 r - gamma2 |r| r - gamma3 u v + tau_2 / m_33`, with the coefficients of
//! [`crate::params::XyCoeffs`]. `tau_1 = F1x + F2x`, `tau_2 = l (F1x - F2x)`; sway is not
//! actuated.

use super::xz::pos_floor;
use crate::math::{sin_cos, sq_signed};
use crate::params::Vehicle;
use crate::state::{BodyForces, XyState};

/// Time derivative of `s` under the generalized forces `f` (`surge_n` = `tau_1`,
/// `yaw_n_m` = `tau_2`; `heave_n` is ignored).
pub fn derivative(v: &Vehicle, s: &XyState, f: &BodyForces) -> XyState {
    let c = &v.xy;
    let (u, vv, r) = (s.u_m_s, s.v_m_s, s.r_rad_s);
    let (sp, cp) = sin_cos(s.yaw_rad);
    XyState {
        x_m: cp * u - sp * vv,
        y_m: sp * u + cp * vv,
        yaw_rad: r,
        u_m_s: c.alpha1 * u - c.alpha2 * sq_signed(u) - c.alpha3 * vv * r
            + f.surge_n / pos_floor(c.m11),
        v_m_s: -c.beta1 * vv - c.beta2 * sq_signed(vv) - c.beta3 * u * r,
        r_rad_s: -c.gamma1 * r - c.gamma2 * sq_signed(r) - c.gamma3 * u * vv
            + f.yaw_n_m / pos_floor(c.m33),
    }
}

/// Kinetic energy `(m_11 u^2 + m_22 v^2 + m_33 r^2) / 2`. Its rate is `u tau_1 + r tau_2`
/// minus the drag dissipation: the Coriolis and Munk terms do no work.
pub fn kinetic_energy(v: &Vehicle, s: &XyState) -> f32 {
    let c = &v.xy;
    0.5 * (c.m11 * s.u_m_s * s.u_m_s + c.m22 * s.v_m_s * s.v_m_s + c.m33 * s.r_rad_s * s.r_rad_s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::State6;
    use proptest::prelude::*;

    fn state() -> impl Strategy<Value = XyState> {
        (
            -50.0f32..50.0,
            -50.0f32..50.0,
            -10.0f32..10.0,
            -2.0f32..2.0,
            -2.0f32..2.0,
            -3.0f32..3.0,
        )
            .prop_map(|(x, y, p, u, v, r)| XyState::from_array([x, y, p, u, v, r]))
    }

    fn forces() -> impl Strategy<Value = BodyForces> {
        (-40.0f32..40.0, -5.0f32..5.0).prop_map(|(s, y)| BodyForces {
            surge_n: s,
            yaw_n_m: y,
            heave_n: 0.0,
        })
    }

    proptest! {
        /// Power balance: d/dt of the kinetic energy is the thrust power minus the drag
        /// dissipation (so the Coriolis/Munk signs of section 4 are mutually consistent).
        #[test]
        fn power_balance(s in state(), f in forces()) {
            let v = Vehicle::observer();
            let p = v.params();
            let c = &v.xy;
            let d = derivative(&v, &s, &f);
            let (u, vv, r) = (s.u_m_s, s.v_m_s, s.r_rad_s);
            let t_dot = c.m11 * u * d.u_m_s + c.m22 * vv * d.v_m_s + c.m33 * r * d.r_rad_s;
            let diss = (p.x_u + p.x_uu * u.abs()) * u * u
                + (p.y_v + p.y_vv * vv.abs()) * vv * vv
                + (p.n_r + p.n_rr * r.abs()) * r * r;
            let power = u * f.surge_n + r * f.yaw_n_m - diss;
            prop_assert!((t_dot - power).abs() < 1e-3 * (1.0 + power.abs() + diss));
        }

        /// The inertial speed equals the body speed, and the kinematics rotate with psi.
        #[test]
        fn kinematics_are_a_rotation(s in state(), f in forces()) {
            let v = Vehicle::observer();
            let d = derivative(&v, &s, &f);
            let sp2 = d.x_m * d.x_m + d.y_m * d.y_m;
            let sb2 = s.u_m_s * s.u_m_s + s.v_m_s * s.v_m_s;
            prop_assert!((sp2 - sb2).abs() < 1e-4 * (1.0 + sb2));
            prop_assert_eq!(d.yaw_rad, s.r_rad_s);
        }

        /// Body-frame dynamics do not depend on position or heading.
        #[test]
        fn dynamics_invariant_to_pose(s in state(), f in forces(), dx in -10.0f32..10.0, dpsi in -3.0f32..3.0) {
            let v = Vehicle::observer();
            let a = derivative(&v, &s, &f);
            let moved = XyState { x_m: s.x_m + dx, y_m: s.y_m - dx, yaw_rad: s.yaw_rad + dpsi, ..s };
            let b = derivative(&v, &moved, &f);
            prop_assert_eq!((a.u_m_s, a.v_m_s, a.r_rad_s), (b.u_m_s, b.v_m_s, b.r_rad_s));
        }

        /// Port/starboard mirror symmetry: (v, r, psi, tau_2) -> -(v, r, psi, tau_2) mirrors
        /// the motion (y_dot, v_dot, r_dot flip sign; x_dot, u_dot do not).
        #[test]
        fn mirror_symmetry(s in state(), f in forces()) {
            let v = Vehicle::observer();
            let a = derivative(&v, &s, &f);
            let ms = XyState { y_m: -s.y_m, yaw_rad: -s.yaw_rad, v_m_s: -s.v_m_s, r_rad_s: -s.r_rad_s, ..s };
            let mf = BodyForces { yaw_n_m: -f.yaw_n_m, ..f };
            let b = derivative(&v, &ms, &mf);
            prop_assert!((a.x_m - b.x_m).abs() < 1e-5 && (a.y_m + b.y_m).abs() < 1e-5);
            prop_assert!((a.u_m_s - b.u_m_s).abs() < 1e-5);
            prop_assert!((a.v_m_s + b.v_m_s).abs() < 1e-5 && (a.r_rad_s + b.r_rad_s).abs() < 1e-5);
        }

        /// Sway is not actuated: neither tau_1 nor tau_2 appears in v_dot.
        #[test]
        fn sway_is_unactuated(s in state(), f in forces(), g in forces()) {
            let v = Vehicle::observer();
            prop_assert_eq!(derivative(&v, &s, &f).v_m_s, derivative(&v, &s, &g).v_m_s);
        }
    }

    #[test]
    fn straight_run_reaches_the_drag_balanced_speed() {
        // 10 N of surge thrust: X_u u + X_uu u^2 = 10 => u = 1.3944 m/s.
        let v = Vehicle::observer();
        let p = v.params();
        let f = BodyForces {
            surge_n: 10.0,
            ..BodyForces::default()
        };
        let mut s = XyState {
            yaw_rad: 0.3,
            ..XyState::default()
        };
        for _ in 0..60_000 {
            s = crate::model::rk4_step(|x| derivative(&v, x, &f), &s, 1e-3);
        }
        let u_ss = (-p.x_u + (p.x_u * p.x_u + 4.0 * p.x_uu * 10.0).sqrt()) / (2.0 * p.x_uu);
        assert!((s.u_m_s - u_ss).abs() < 1e-4, "{} vs {u_ss}", s.u_m_s);
        assert!(s.v_m_s.abs() < 1e-6 && s.r_rad_s.abs() < 1e-6);
        assert!((s.y_m / s.x_m - 0.3f32.tan()).abs() < 1e-4);
        assert!(kinetic_energy(&v, &s) > 0.0);
    }

    #[test]
    fn turning_makes_outward_sway() {
        // Turning to starboard (r > 0) at forward speed: v_dot = -beta3 u r < 0 (the vehicle
        // skids outward, to port in body axes).
        let v = Vehicle::observer();
        let s = XyState {
            u_m_s: 1.0,
            r_rad_s: 0.5,
            ..XyState::default()
        };
        assert!(derivative(&v, &s, &BodyForces::default()).v_m_s < 0.0);
    }
}
