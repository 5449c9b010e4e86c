//! Horizontal-plane (XY) plant in `f64`, `MODEL_NOTES` section 4 (the paper's eq. (34)
//! reduced: roll not modelled).
//!
//! With `m_11 = m - X_udot`, `m_22 = m - Y_vdot`, `m_33 = I_z - N_rdot`:
//! ```text
//! x_dot = cos(psi) u - sin(psi) v,   y_dot = sin(psi) u + cos(psi) v,   psi_dot = r
//! m_11 u_dot = m_22 v r - (X_u + X_uu|u|) u + tau_1
//! m_22 v_dot = -m_11 u r - (Y_v + Y_vv|v|) v
//! m_33 r_dot = (m_11 - m_22) u v - (N_r + N_rr|r|) r + tau_2
//! ```
//! `tau_1 = F1x + F2x`, `tau_2 = l (F1x - F2x)`; `F3z` has no effect in this plane.
//!
//! Current: as in [`super::xz`], the model is evaluated on the relative velocity
//! `nu_r = nu - R(psi)^T (c_x, c_y)` and the body-frame rate of change of the current
//! (`(v_c r, -u_c r)`) is added. `z` and the other out-of-plane states stay at their initial
//! values.

use super::thrusters::Thrusters;
use super::{generalized_forces, rk4, Environment, Plant, PlantParams, PlantState};
use controller_core::params::VehicleParams;

/// Names of the plane's state vector `[x, y, psi, u, v, r]`.
pub const STATE_NAMES: [&str; 6] = ["x", "y", "psi", "u", "v", "r"];

/// Time derivative of the plane's state `[x, y, psi, u, v, r]` for generalized forces
/// `tau = [tau_1, tau_2, tau_3]` (`tau_3` unused) and inertial current `[cx, cy, cz]`.
pub fn derivatives(
    p: &PlantParams,
    s: &[f64; 6],
    tau: [f64; 3],
    current_m_s: [f64; 3],
) -> [f64; 6] {
    let [_x, _y, psi, u, v, r] = *s;
    let (sp, cp) = psi.sin_cos();
    let (cx, cy) = (current_m_s[0], current_m_s[1]);
    let uc = cp * cx + sp * cy;
    let vc = -sp * cx + cp * cy;
    let ur = u - uc;
    let vr = v - vc;

    let m = p.mass_kg;
    let m11 = m - p.x_udot_kg;
    let m22 = m - p.y_vdot_kg;
    let m33 = p.i_z_kg_m2 - p.n_rdot_kg_m2;

    let u_dot_r = (m22 * vr * r - (p.x_u + p.x_uu * ur.abs()) * ur + tau[0]) / m11;
    let v_dot_r = (-m11 * ur * r - (p.y_v + p.y_vv * vr.abs()) * vr) / m22;
    let r_dot = ((m11 - m22) * ur * vr - (p.n_r + p.n_rr * r.abs()) * r + tau[1]) / m33;

    [
        cp * u - sp * v,
        sp * u + cp * v,
        r,
        u_dot_r + vc * r,
        v_dot_r - uc * r,
        r_dot,
    ]
}

/// The horizontal-plane plant.
#[derive(Debug, Clone)]
pub struct XyPlant {
    params: PlantParams,
    env: Environment,
    thrusters: Thrusters,
    state: PlantState,
}

impl XyPlant {
    /// A plant with the given (possibly perturbed) parameters, water, thruster limits switch and
    /// initial state. Only `x, y, yaw, u, v, r` evolve.
    pub fn new(
        params: &VehicleParams,
        env: Environment,
        saturate: bool,
        initial: PlantState,
    ) -> Self {
        Self {
            params: PlantParams::from_vehicle(params),
            env,
            thrusters: Thrusters::new(params, saturate),
            state: initial,
        }
    }

    /// The plane's state vector `[x, y, psi, u, v, r]`.
    pub fn plane_state(&self) -> [f64; 6] {
        let s = &self.state;
        [s.eta[0], s.eta[1], s.eta[5], s.nu[0], s.nu[1], s.nu[5]]
    }

    /// The `f64` parameters in use.
    pub fn params(&self) -> &PlantParams {
        &self.params
    }
}

impl Plant for XyPlant {
    fn set_current(&mut self, current_m_s: [f64; 3]) {
        self.env.current_m_s = current_m_s;
    }

    fn step(&mut self, thrust_cmd_n: [f64; 3], dt_s: f64) {
        let seg = self.thrusters.segment(thrust_cmd_n);
        let p = self.params;
        let c = self.env.current_m_s;
        let x = rk4(&self.plane_state(), dt_s, |s, x| {
            derivatives(&p, x, generalized_forces(seg.at(s), p.lever_arm_m), c)
        });
        self.thrusters.advance(&seg, dt_s);
        let st = &mut self.state;
        st.eta[0] = x[0];
        st.eta[1] = x[1];
        st.eta[5] = x[2];
        st.nu[0] = x[3];
        st.nu[1] = x[4];
        st.nu[5] = x[5];
    }

    fn state(&self) -> PlantState {
        self.state
    }

    fn thrust_n(&self) -> [f64; 3] {
        self.thrusters.force_n
    }
}
