//! Vehicle models in `f32`: the vertical plane in physical and transformed coordinates
//! ([`xz`], paper eqs. (1)-(3), corrected) and the horizontal plane ([`xy`], paper eq. (34)
//! reduced as in `MODEL_NOTES` section 4).
//!
//! Every model is a pure function `(vehicle, state, generalized forces) -> state derivative`.
//! The derivative is returned in the state's own type (each field holds the time derivative of
//! the field of the same name), so a fixed-step integrator such as [`rk4_step`] can combine
//! them. The generalized forces are [`crate::state::BodyForces`]: the vertical plane reads
//! `surge_n` (`tau_1`) and `heave_n` (`tau_3`), the horizontal plane `surge_n` (`tau_1`) and
//! `yaw_n_m` (`tau_2`); the unused component is ignored.
//!
//! The derivation (conventions, the corrected equations, the transformation and its
//! coefficients) is written out in `docs/derivation.md`.

pub mod xy;
pub mod xz;

pub use xz::XzTransformedState;

/// A state of six `f32` components that an integrator can add and scale.
pub trait State6: Copy {
    /// The components in a fixed order.
    fn to_array(&self) -> [f32; 6];
    /// Build from components in the order of [`State6::to_array`].
    fn from_array(a: [f32; 6]) -> Self;
}

/// `s + h d`, component-wise.
#[inline]
pub fn axpy<S: State6>(s: &S, h: f32, d: &S) -> S {
    let mut out = s.to_array();
    for (o, di) in out.iter_mut().zip(d.to_array()) {
        *o += h * di;
    }
    S::from_array(out)
}

/// One classical fourth-order Runge-Kutta step of length `dt_s` for `s_dot = f(s)` (inputs held
/// constant over the step: zero-order hold).
pub fn rk4_step<S: State6>(f: impl Fn(&S) -> S, s: &S, dt_s: f32) -> S {
    let k1 = f(s);
    let k2 = f(&axpy(s, 0.5 * dt_s, &k1));
    let k3 = f(&axpy(s, 0.5 * dt_s, &k2));
    let k4 = f(&axpy(s, dt_s, &k3));
    let mut out = s.to_array();
    let (a1, a2, a3, a4) = (k1.to_array(), k2.to_array(), k3.to_array(), k4.to_array());
    for ((((o, d1), d2), d3), d4) in out.iter_mut().zip(a1).zip(a2).zip(a3).zip(a4) {
        *o += dt_s / 6.0 * (d1 + 2.0 * d2 + 2.0 * d3 + d4);
    }
    S::from_array(out)
}

impl State6 for crate::state::XzState {
    fn to_array(&self) -> [f32; 6] {
        [
            self.x_m,
            self.z_m,
            self.pitch_rad,
            self.u_m_s,
            self.w_m_s,
            self.q_rad_s,
        ]
    }
    fn from_array(a: [f32; 6]) -> Self {
        let [x_m, z_m, pitch_rad, u_m_s, w_m_s, q_rad_s] = a;
        Self {
            x_m,
            z_m,
            pitch_rad,
            u_m_s,
            w_m_s,
            q_rad_s,
        }
    }
}

impl State6 for crate::state::XyState {
    fn to_array(&self) -> [f32; 6] {
        [
            self.x_m,
            self.y_m,
            self.yaw_rad,
            self.u_m_s,
            self.v_m_s,
            self.r_rad_s,
        ]
    }
    fn from_array(a: [f32; 6]) -> Self {
        let [x_m, y_m, yaw_rad, u_m_s, v_m_s, r_rad_s] = a;
        Self {
            x_m,
            y_m,
            yaw_rad,
            u_m_s,
            v_m_s,
            r_rad_s,
        }
    }
}

impl State6 for XzTransformedState {
    fn to_array(&self) -> [f32; 6] {
        [
            self.x1_m,
            self.z1_m,
            self.pitch_rad,
            self.u1_m_s,
            self.w_m_s,
            self.q_rad_s,
        ]
    }
    fn from_array(a: [f32; 6]) -> Self {
        let [x1_m, z1_m, pitch_rad, u1_m_s, w_m_s, q_rad_s] = a;
        Self {
            x1_m,
            z1_m,
            pitch_rad,
            u1_m_s,
            w_m_s,
            q_rad_s,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::state::XzState;

    #[test]
    fn rk4_integrates_a_linear_system_to_fourth_order() {
        // x_dot = -x on every component: exact solution e^{-t}.
        let f = |s: &XzState| XzState::from_array(s.to_array().map(|v| -v));
        let mut s = XzState::from_array([1.0; 6]);
        for _ in 0..100 {
            s = rk4_step(f, &s, 0.01);
        }
        for v in s.to_array() {
            assert!((v - (-1.0f32).exp()).abs() < 1e-6, "{v}");
        }
    }
}
