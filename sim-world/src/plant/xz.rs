//! Vertical-plane (XZ) plant in `f64`, `MODEL_NOTES` section 3 (the paper's eqs. (1)-(2) with
//! the sign and index errors corrected).
//!
//! With `m_x = m - X_udot`, `m_z = m - Z_wdot`, `J_y = I_y - M_qdot`, `a_uq = m z_g`:
//! ```text
//! x_dot = cos(theta) u + sin(theta) w,   z_dot = -sin(theta) u + cos(theta) w,   theta_dot = q
//! [m_x  a_uq] [u_dot]   [F_u]   F_u = -(X_u + X_uu|u|)u - m_z w q - (W - B) sin(theta) + tau_1
//! [a_uq J_y ] [q_dot] = [F_q]   F_q = -(M_q + M_qq|q|)q - a_uq w q - (Z_wdot - X_udot) u w
//!                                     - z_g W sin(theta)
//! m_z w_dot = -(Z_w + Z_ww|w|)w + (W - B) cos(theta) + m_x u q + a_uq q^2 + tau_3
//! ```
//! `tau_1 = F1x + F2x` (the horizontal pair passes through the CB height, so no pitch moment),
//! `tau_3 = F3z`. `W - B = -buoyancy_offset_n`.
//!
//! Current: a constant inertial current `(c_x, c_z)` enters through the relative velocity
//! `nu_r = nu - nu_c`, `nu_c = R(theta)^T (c_x, c_z)`: the hydrodynamic model is evaluated on
//! `nu_r` and the body-frame rate of change of `nu_c` (`(-w_c q, u_c q)`) is added, the
//! standard formulation for an irrotational constant current (Fossen 2011, section 10.3).
//! With no current this is exactly the model above. `y` and the other out-of-plane states stay
//! at their initial values.

use super::thrusters::Thrusters;
use super::{generalized_forces, rk4, Boundary, Environment, Plant, PlantParams, PlantState};
use controller_core::params::VehicleParams;

/// Index of each state in the plane's state vector `[x, z, theta, u, w, q]`.
pub const STATE_NAMES: [&str; 6] = ["x", "z", "theta", "u", "w", "q"];

/// Time derivative of the plane's state `[x, z, theta, u, w, q]` for generalized forces
/// `tau = [tau_1, tau_2, tau_3]` (`tau_2` is unused here) and inertial current `[cx, cy, cz]`.
pub fn derivatives(
    p: &PlantParams,
    s: &[f64; 6],
    tau: [f64; 3],
    current_m_s: [f64; 3],
) -> [f64; 6] {
    let [_x, _z, th, u, w, q] = *s;
    let (sth, cth) = th.sin_cos();
    // Current in the body frame and its rate of change (irrotational, constant inertially).
    let (cx, cz) = (current_m_s[0], current_m_s[2]);
    let uc = cth * cx - sth * cz;
    let wc = sth * cx + cth * cz;
    let ur = u - uc;
    let wr = w - wc;

    let m = p.mass_kg;
    let m_x = m - p.x_udot_kg;
    let m_z = m - p.z_wdot_kg;
    let j_y = p.i_y_kg_m2 - p.m_qdot_kg_m2;
    let a_uq = m * p.z_g_m;
    let delta = m_x * j_y - a_uq * a_uq;
    let weight = p.weight_n();
    let w_minus_b = -p.buoyancy_offset_n;
    let zx = p.z_wdot_kg - p.x_udot_kg;

    let f_u = -(p.x_u + p.x_uu * ur.abs()) * ur - m_z * wr * q - w_minus_b * sth + tau[0];
    let f_q =
        -(p.m_q + p.m_qq * q.abs()) * q - a_uq * wr * q - zx * ur * wr - p.z_g_m * weight * sth;
    let u_dot_r = (j_y * f_u - a_uq * f_q) / delta;
    let q_dot = (m_x * f_q - a_uq * f_u) / delta;
    let w_dot_r = (-(p.z_w + p.z_ww * wr.abs()) * wr
        + w_minus_b * cth
        + m_x * ur * q
        + a_uq * q * q
        + tau[2])
        / m_z;

    [
        cth * u + sth * w,
        -sth * u + cth * w,
        q,
        u_dot_r - wc * q,
        w_dot_r + uc * q,
        q_dot,
    ]
}

/// The vertical-plane plant.
#[derive(Debug, Clone)]
pub struct XzPlant {
    params: PlantParams,
    env: Environment,
    thrusters: Thrusters,
    state: PlantState,
    surface: bool,
    seabed_depth_m: Option<f64>,
    contact: Option<Boundary>,
}

impl XzPlant {
    /// A plant with the given (possibly perturbed) parameters, water, thruster limits switch and
    /// initial state. Only `x, z, pitch, u, w, q` evolve.
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
            surface: false,
            seabed_depth_m: None,
            contact: None,
        }
    }

    /// The plane's state vector `[x, z, theta, u, w, q]`.
    pub fn plane_state(&self) -> [f64; 6] {
        let s = &self.state;
        [s.eta[0], s.eta[2], s.eta[4], s.nu[0], s.nu[2], s.nu[4]]
    }

    /// The `f64` parameters in use.
    pub fn params(&self) -> &PlantParams {
        &self.params
    }
}

impl Plant for XzPlant {
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
        st.eta[2] = x[1];
        st.eta[4] = x[2];
        st.nu[0] = x[3];
        st.nu[2] = x[4];
        st.nu[4] = x[5];
        // The surface and the seabed: z clamped, the velocity through them removed.
        let (z, met) = Boundary::clamp(st.eta[2], self.surface, self.seabed_depth_m);
        if let Some(b) = met {
            st.eta[2] = z;
            let (s, c) = st.eta[4].sin_cos();
            let z_dot = -s * st.nu[0] + c * st.nu[2];
            if b.blocks(z_dot) {
                st.nu[0] += z_dot * s;
                st.nu[2] -= z_dot * c;
            }
            self.contact.get_or_insert(b);
        }
    }

    fn set_current(&mut self, current_m_s: [f64; 3]) {
        self.env.current_m_s = current_m_s;
    }

    fn set_bounds(&mut self, surface: bool, seabed_depth_m: Option<f64>) {
        self.surface = surface;
        self.seabed_depth_m = seabed_depth_m;
    }

    fn contact(&self) -> Option<Boundary> {
        self.contact
    }

    fn state(&self) -> PlantState {
        self.state
    }

    fn thrust_n(&self) -> [f64; 3] {
        self.thrusters.force_n
    }
}
