//! Vertical-plane (XZ) model: paper eqs. (1)-(2) in physical coordinates and eq. (3) in
//! transformed coordinates, both with the paper's sign and index errors corrected
//! (`MODEL_NOTES` section 3; the full list is in `docs/derivation.md`).
//!
//! # Physical model, eqs. (1)-(2) corrected
//! Body origin at the centre of buoyancy (the paper says "centre of mass G"; its own mass
//! matrix puts the origin at the CB, with the CG at `(0, 0, z_g)` below it). Inertial z down.
//! ```text
//! x_dot = cos(theta) u + sin(theta) w,   z_dot = -sin(theta) u + cos(theta) w,   theta_dot = q
//!
//! [m_x  a_uq] [u_dot]   [F_u]   F_u = -(X_u + X_uu|u|) u - m_z w q - (W - B) sin(theta) + tau_1
//! [a_uq J_y ] [q_dot] = [F_q]   F_q = -(M_q + M_qq|q|) q - a_uq w q - (Z_wdot - X_udot) u w
//!                                     - z_g W sin(theta)
//! m_z w_dot = -(Z_w + Z_ww|w|) w + (W - B) cos(theta) + m_x u q + a_uq q^2 + tau_3
//! ```
//! solved exactly with the inverse of the 2x2 mass matrix (determinant `delta`). The horizontal
//! thrusters act through the CB height and the vertical thruster on the body z axis, so the
//! thrusters make no pitch moment.
//!
//! # Transformation, section II-B corrected
//! The point of the body z axis at `alpha = J_y / a_uq` below the origin:
//! ```text
//! x1 = x + alpha sin(theta),   z1 = z + alpha cos(theta),   u1 = u + alpha q
//! ```
//! (the paper prints `u1 = u - alpha q`, which contradicts its own kinematics). Dividing the
//! second row of the mass-matrix equation by `a_uq` gives `u_dot + alpha q_dot = F_q / a_uq`,
//! so `u1_dot = F_q / a_uq` does not contain `tau_1`.
//!
//! # Transformed model, eq. (3) corrected
//! ```text
//! x1_dot = cos(theta) u1 + sin(theta) w,   z1_dot = -sin(theta) u1 + cos(theta) w
//! u1_dot = a1 u1 + a2 |u| u + a3 q + a4 q|q| + a5 sin(theta) + a6 w q + a7 w u1
//! w_dot  = b1 w + b2 |w| w + b3 cos(theta) + b4 u q + b5 q^2 + tau_3 / m_z
//! q_dot  = d1 u + d2 |u| u + d3 q + d4 q|q| + d5 sin(theta) + d6 w q + d7 w u + d_tau tau_1
//! ```
//! with `u = u1 - alpha q` the physical surge speed, and the coefficients of
//! [`crate::params::XzCoeffs`] (`a1 = a2 = 0`, `a5 = -g`, `d_tau = -a_uq / delta`).

use crate::math::{sin_cos, sq_signed};
use crate::params::Vehicle;
use crate::state::{BodyForces, XzState};

/// State in the transformed coordinates of section II-B (corrected).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct XzTransformedState {
    /// `x1 = x + alpha sin(theta)`.
    pub x1_m: f32,
    /// `z1 = z + alpha cos(theta)`.
    pub z1_m: f32,
    /// Pitch `theta` (unchanged).
    pub pitch_rad: f32,
    /// `u1 = u + alpha q`.
    pub u1_m_s: f32,
    /// Heave `w` (unchanged).
    pub w_m_s: f32,
    /// Pitch rate `q` (unchanged).
    pub q_rad_s: f32,
}

/// A denominator that is a positive physical constant (validated in [`crate::params`]):
/// never let it reach zero or go negative, whatever a caller did to the public coefficients.
#[inline(always)]
pub(crate) fn pos_floor(x: f32) -> f32 {
    crate::math::max(x, f32::MIN_POSITIVE)
}

/// Physical model, eqs. (1)-(2) corrected: the time derivative of `s` under the generalized
/// forces `f` (`surge_n` = `tau_1`, `heave_n` = `tau_3`; `yaw_n_m` is ignored).
pub fn derivative(v: &Vehicle, s: &XzState, f: &BodyForces) -> XzState {
    let c = &v.xz;
    let p = v.params();
    let (u, w, q) = (s.u_m_s, s.w_m_s, s.q_rad_s);
    let (sth, cth) = sin_cos(s.pitch_rad);
    let w_minus_b = c.weight_n - c.buoyancy_n;
    let zx = p.z_wdot_kg - p.x_udot_kg;
    let f_u = -p.x_u * u - p.x_uu * sq_signed(u) - c.m_z * w * q - w_minus_b * sth + f.surge_n;
    let f_q = -p.m_q * q
        - p.m_qq * sq_signed(q)
        - c.a_uq * w * q
        - zx * u * w
        - p.z_g_m * c.weight_n * sth;
    let inv_delta = 1.0 / pos_floor(c.delta);
    let u_dot = (c.j_y * f_u - c.a_uq * f_q) * inv_delta;
    let q_dot = (c.m_x * f_q - c.a_uq * f_u) * inv_delta;
    let w_dot = (-p.z_w * w - p.z_ww * sq_signed(w)
        + w_minus_b * cth
        + c.m_x * u * q
        + c.a_uq * q * q
        + f.heave_n)
        / pos_floor(c.m_z);
    XzState {
        x_m: cth * u + sth * w,
        z_m: -sth * u + cth * w,
        pitch_rad: q,
        u_m_s: u_dot,
        w_m_s: w_dot,
        q_rad_s: q_dot,
    }
}

/// Physical -> transformed coordinates.
pub fn to_transformed(v: &Vehicle, s: &XzState) -> XzTransformedState {
    to_transformed_with(v, s, sin_cos(s.pitch_rad))
}

/// [`to_transformed`] with `(sin, cos)` of `s.pitch_rad` already computed by the caller.
#[inline]
pub(crate) fn to_transformed_with(
    v: &Vehicle,
    s: &XzState,
    (sth, cth): (f32, f32),
) -> XzTransformedState {
    let a = v.xz.alpha;
    XzTransformedState {
        x1_m: s.x_m + a * sth,
        z1_m: s.z_m + a * cth,
        pitch_rad: s.pitch_rad,
        u1_m_s: s.u_m_s + a * s.q_rad_s,
        w_m_s: s.w_m_s,
        q_rad_s: s.q_rad_s,
    }
}

/// Transformed -> physical coordinates (inverse of [`to_transformed`]).
pub fn from_transformed(v: &Vehicle, t: &XzTransformedState) -> XzState {
    let a = v.xz.alpha;
    let (sth, cth) = sin_cos(t.pitch_rad);
    XzState {
        x_m: t.x1_m - a * sth,
        z_m: t.z1_m - a * cth,
        pitch_rad: t.pitch_rad,
        u_m_s: t.u1_m_s - a * t.q_rad_s,
        w_m_s: t.w_m_s,
        q_rad_s: t.q_rad_s,
    }
}

/// The rates of the transformed coordinates, given the physical state `s` and its derivative
/// `ds` (the chain rule through [`to_transformed`]):
/// `x1_dot = x_dot + alpha cos(theta) q`, `z1_dot = z_dot - alpha sin(theta) q`,
/// `u1_dot = u_dot + alpha q_dot`.
pub fn map_derivative(v: &Vehicle, s: &XzState, ds: &XzState) -> XzTransformedState {
    let a = v.xz.alpha;
    let (sth, cth) = sin_cos(s.pitch_rad);
    XzTransformedState {
        x1_m: ds.x_m + a * cth * ds.pitch_rad,
        z1_m: ds.z_m - a * sth * ds.pitch_rad,
        pitch_rad: ds.pitch_rad,
        u1_m_s: ds.u_m_s + a * ds.q_rad_s,
        w_m_s: ds.w_m_s,
        q_rad_s: ds.q_rad_s,
    }
}

/// Transformed model, eq. (3) corrected, written with the `a_i`, `b_i`, `d_i` of
/// [`crate::params::XzCoeffs`]: the time derivative of `t` under `f`.
pub fn transformed_derivative(
    v: &Vehicle,
    t: &XzTransformedState,
    f: &BodyForces,
) -> XzTransformedState {
    let c = &v.xz;
    let (u1, w, q) = (t.u1_m_s, t.w_m_s, t.q_rad_s);
    // The physical surge speed: the d_i, b4 and the (zero) a2 multiply it.
    let u = u1 - c.alpha * q;
    let (sth, cth) = sin_cos(t.pitch_rad);
    let u1_dot = c.a1 * u1
        + c.a2 * sq_signed(u)
        + c.a3 * q
        + c.a4 * sq_signed(q)
        + c.a5 * sth
        + c.a6 * w * q
        + c.a7 * w * u1;
    let w_dot = c.b1 * w
        + c.b2 * sq_signed(w)
        + c.b3 * cth
        + c.b4 * u * q
        + c.b5 * q * q
        + f.heave_n / pos_floor(c.m_z);
    let q_dot = c.d1 * u
        + c.d2 * sq_signed(u)
        + c.d3 * q
        + c.d4 * sq_signed(q)
        + c.d5 * sth
        + c.d6 * w * q
        + c.d7 * w * u
        + c.d_tau * f.surge_n;
    XzTransformedState {
        x1_m: cth * u1 + sth * w,
        z1_m: -sth * u1 + cth * w,
        pitch_rad: q,
        u1_m_s: u1_dot,
        w_m_s: w_dot,
        q_rad_s: q_dot,
    }
}

/// Mechanical energy of the vertical-plane motion: kinetic energy with the full mass matrix,
/// the pendulum energy of the CG below the CB and the potential of the net weight `W - B`
/// (inertial z down). Its rate is `u tau_1 + w tau_3` minus the drag dissipation (the Coriolis
/// and Munk terms do no work), which the tests check.
pub fn energy(v: &Vehicle, s: &XzState) -> f32 {
    let c = &v.xz;
    let p = v.params();
    let (u, w, q) = (s.u_m_s, s.w_m_s, s.q_rad_s);
    let (_, cth) = sin_cos(s.pitch_rad);
    0.5 * (c.m_x * u * u + 2.0 * c.a_uq * u * q + c.j_y * q * q + c.m_z * w * w)
        + p.z_g_m * c.weight_n * (1.0 - cth)
        - (c.weight_n - c.buoyancy_n) * s.z_m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::State6;
    use crate::params::VehicleParams;
    use proptest::prelude::*;

    fn state() -> impl Strategy<Value = XzState> {
        (
            -50.0f32..50.0,
            -50.0f32..50.0,
            -3.0f32..3.0,
            -2.0f32..2.0,
            -2.0f32..2.0,
            -2.0f32..2.0,
        )
            .prop_map(|(x, z, th, u, w, q)| XzState::from_array([x, z, th, u, w, q]))
    }

    fn forces() -> impl Strategy<Value = BodyForces> {
        (-40.0f32..40.0, -40.0f32..40.0).prop_map(|(s, h)| BodyForces {
            surge_n: s,
            yaw_n_m: 0.0,
            heave_n: h,
        })
    }

    /// A vehicle with random but physical z_g, I_y and buoyancy offset, so the identities are
    /// checked beyond the one parameter set.
    fn vehicle() -> impl Strategy<Value = Vehicle> {
        (0.005f32..0.2, 0.05f32..1.0, -5.0f32..5.0).prop_filter_map(
            "valid vehicle",
            |(zg, iy, off)| {
                let mut p = VehicleParams::OBSERVER;
                p.z_g_m = zg;
                p.i_y_kg_m2 = iy;
                p.buoyancy_offset_n = off;
                p.validate().ok()
            },
        )
    }

    fn close(a: f32, b: f32, scale: f32) -> bool {
        (a - b).abs() <= 2e-4 * (1.0 + scale)
    }

    proptest! {
        /// Eq. (3) corrected == eqs. (1)-(2) corrected mapped through the transformation.
        #[test]
        fn transformed_model_matches_physical(v in vehicle(), s in state(), f in forces()) {
            let ds = derivative(&v, &s, &f);
            let mapped = map_derivative(&v, &s, &ds);
            let t = to_transformed(&v, &s);
            let dt = transformed_derivative(&v, &t, &f);
            let scale = mapped.to_array().iter().fold(0.0f32, |m, x| m.max(x.abs()));
            for (a, b) in mapped.to_array().iter().zip(dt.to_array()) {
                prop_assert!(close(*a, b, scale), "mapped {:?}\ntransformed {:?}", mapped, dt);
            }
        }

        /// `u1_dot` does not depend on `tau_1` (physical model, mapped).
        #[test]
        fn u1_dot_independent_of_tau1(v in vehicle(), s in state(), f in forces(), t1 in -100.0f32..100.0) {
            let da = derivative(&v, &s, &f);
            let a = map_derivative(&v, &s, &da);
            let g = BodyForces { surge_n: t1, ..f };
            let db = derivative(&v, &s, &g);
            let b = map_derivative(&v, &s, &db);
            // tau_1 enters u_dot and alpha q_dot with gains J_y/delta and -alpha a_uq/delta,
            // which cancel exactly; what is left is f32 round-off of the two terms.
            let scale = da.u_m_s.abs().max(db.u_m_s.abs())
                + v.xz.alpha * da.q_rad_s.abs().max(db.q_rad_s.abs());
            prop_assert!((a.u1_m_s - b.u1_m_s).abs() < 1e-5 * (1.0 + scale), "{} vs {}", a.u1_m_s, b.u1_m_s);
            // ... while q_dot does depend on it, with gain d_tau = -a_uq / delta.
            let dq = (b.q_rad_s - a.q_rad_s) / (t1 - f.surge_n);
            if (t1 - f.surge_n).abs() > 1.0 {
                prop_assert!((dq - v.xz.d_tau).abs() < 1e-3 * v.xz.d_tau.abs() + 1e-5);
            }
        }

        /// The transformed point moves exactly with the transformed body velocities.
        #[test]
        fn transformed_kinematics_hold(v in vehicle(), s in state(), f in forces()) {
            let ds = derivative(&v, &s, &f);
            let m = map_derivative(&v, &s, &ds);
            let t = to_transformed(&v, &s);
            let (sth, cth) = sin_cos(s.pitch_rad);
            let x1_dot = cth * t.u1_m_s + sth * t.w_m_s;
            let z1_dot = -sth * t.u1_m_s + cth * t.w_m_s;
            prop_assert!(close(m.x1_m, x1_dot, x1_dot.abs()));
            prop_assert!(close(m.z1_m, z1_dot, z1_dot.abs()));
        }

        /// The transformation round-trips.
        #[test]
        fn transformation_round_trips(v in vehicle(), s in state()) {
            let back = from_transformed(&v, &to_transformed(&v, &s));
            for (a, b) in s.to_array().iter().zip(back.to_array()) {
                prop_assert!((a - b).abs() < 1e-4 * (1.0 + a.abs()));
            }
        }

        /// Power balance: dE/dt = u tau_1 + w tau_3 - drag dissipation (Coriolis, Munk and
        /// restoring terms exchange energy but make none).
        #[test]
        fn power_balance(v in vehicle(), s in state(), f in forces()) {
            let p = v.params();
            let ds = derivative(&v, &s, &f);
            let c = &v.xz;
            let (u, w, q) = (s.u_m_s, s.w_m_s, s.q_rad_s);
            let (sth, _) = sin_cos(s.pitch_rad);
            let terms = [
                c.m_x * u * ds.u_m_s,
                c.a_uq * ds.u_m_s * q,
                c.a_uq * u * ds.q_rad_s,
                c.j_y * q * ds.q_rad_s,
                c.m_z * w * ds.w_m_s,
                p.z_g_m * c.weight_n * sth * ds.pitch_rad,
                -(c.weight_n - c.buoyancy_n) * ds.z_m,
            ];
            let e_dot: f32 = terms.iter().sum();
            let scale: f32 = terms.iter().map(|x| x.abs()).sum();
            let dissipation = (p.x_u + p.x_uu * u.abs()) * u * u
                + (p.z_w + p.z_ww * w.abs()) * w * w
                + (p.m_q + p.m_qq * q.abs()) * q * q;
            let power = u * f.surge_n + w * f.heave_n - dissipation;
            prop_assert!((e_dot - power).abs() < 1e-5 * (1.0 + scale + dissipation), "{} vs {}", e_dot, power);
        }
    }

    #[test]
    fn at_rest_level_neutral_is_an_equilibrium() {
        let v = Vehicle::observer();
        let d = derivative(&v, &XzState::default(), &BodyForces::default());
        assert_eq!(d.to_array(), [0.0; 6]);
    }

    #[test]
    fn pitch_is_pendulum_stable() {
        // Nose up (theta > 0): the CG below the CB pulls the nose back down.
        let v = Vehicle::observer();
        let s = XzState {
            pitch_rad: 0.2,
            ..XzState::default()
        };
        let d = derivative(&v, &s, &BodyForces::default());
        assert!(d.q_rad_s < 0.0);
        // Forward thrust pitches the nose down: it acts at the CB, above the CG, so about the
        // CG it is a negative pitch moment (d_tau = -a_uq / delta < 0).
        let f = BodyForces {
            surge_n: 10.0,
            ..BodyForces::default()
        };
        let d = derivative(&v, &XzState::default(), &f);
        assert!(d.q_rad_s < 0.0 && d.u_m_s > 0.0);
        assert!((d.q_rad_s - v.xz.d_tau * 10.0).abs() < 1e-5);
    }

    #[test]
    fn energy_decays_without_input() {
        let v = Vehicle::observer();
        let mut s = XzState::from_array([0.0, 0.0, 0.4, 0.5, -0.3, 0.2]);
        let mut e = energy(&v, &s);
        let f = BodyForces::default();
        for _ in 0..2000 {
            s = crate::model::rk4_step(|x| derivative(&v, x, &f), &s, 0.005);
            let e2 = energy(&v, &s);
            assert!(e2 <= e + 1e-6, "{e2} > {e}");
            e = e2;
        }
    }
}
