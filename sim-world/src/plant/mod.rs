//! Desktop plant models in `f64`, written from the physical equations (not by calling the
//! core's `f32` model), integrated with RK4 at a fixed step.
//!
//! Every plant takes the commanded thruster forces `[F1x, F2x, F3z]`, applies the thrusters'
//! first-order lag and limits, and advances its state.
//!
//! - [`xz`]: vertical plane (`MODEL_NOTES` section 3), states `x, z, theta, u, w, q`.
//! - [`xy`]: horizontal plane (`MODEL_NOTES` section 4), states `x, y, psi, u, v, r`.
//! - [`six_dof`]: the full 6-DOF rigid body.
//! - [`state`]: the state ([`PlantState`]) and the state before the conversion to Euler
//!   angles ([`RawState`]).
//! - [`lanes`]: arithmetic on several plants at once, lane for lane the scalar's.
//! - [`thrusters`]: the thruster lag and limits shared by the planar plants.

pub use state::{PlantState, RawState};

/// A simulated vehicle.
pub trait Plant: Send {
    /// Advance by `dt_s` with the commanded thruster forces `[F1x, F2x, F3z]` (newtons).
    fn step(&mut self, thrust_cmd_n: [f64; 3], dt_s: f64);
    /// The current state.
    fn state(&self) -> PlantState;
    /// The current state as the plant holds it, converted by [`RawState::state`] when read.
    fn raw_state(&self) -> RawState {
        RawState::Euler(self.state())
    }
    /// The thrust the thrusters really deliver now (after lag and limits).
    fn thrust_n(&self) -> [f64; 3];
    /// Set the ocean current `[cx, cy, cz]` (inertial, m/s) from now on (a current
    /// that changes in time and with depth).
    fn set_current(&mut self, current_m_s: [f64; 3]);
    /// The water's bounds: the surface `z = 0` when `surface`, and the seabed's depth (m,
    /// down) if any; the plant cannot pass them. A plant without depth (XY) ignores them.
    fn set_bounds(&mut self, _surface: bool, _seabed_depth_m: Option<f64>) {}
    /// The first boundary the vehicle met, if any (sticky).
    fn contact(&self) -> Option<Boundary> {
        None
    }
    /// The plant as [`std::any::Any`], for a caller that steps several plants of its kind
    /// side by side (the 6-DOF plant's `step_lanes`); `None` for a plant without such a step.
    fn as_any_mut(&mut self) -> Option<&mut dyn std::any::Any> {
        None
    }
}

/// A boundary of the water.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Boundary {
    /// The surface, `z = 0`.
    Surface,
    /// The seabed.
    Seabed,
}

impl Boundary {
    /// Where the vehicle is kept when it meets a boundary: `z` clamped to
    /// `[0 (if surface), seabed]`, and the boundary met if it was clamped.
    pub fn clamp(z_m: f64, surface: bool, seabed_depth_m: Option<f64>) -> (f64, Option<Boundary>) {
        if surface && z_m < 0.0 {
            (0.0, Some(Boundary::Surface))
        } else {
            match seabed_depth_m {
                Some(d) if z_m > d => (d, Some(Boundary::Seabed)),
                _ => (z_m, None),
            }
        }
    }

    /// The inertial vertical velocity that points through this boundary is removed
    /// (an inelastic contact): up at the surface, down at the seabed.
    pub fn blocks(self, z_dot_m_s: f64) -> bool {
        match self {
            Boundary::Surface => z_dot_m_s < 0.0,
            Boundary::Seabed => z_dot_m_s > 0.0,
        }
    }
}

pub mod lanes;
pub mod six_dof;
pub mod state;
pub mod thrusters;
pub mod water;
pub mod xy;
pub mod xz;

/// The water around the vehicle (inertial frame).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Environment {
    /// Constant ocean current `[cx, cy, cz]`, inertial, m/s.
    pub current_m_s: [f64; 3],
}

/// The vehicle parameters in `f64`, as the planar plants use them.
///
/// Built from the core's [`controller_core::params::VehicleParams`] (which is `f32`) by
/// widening every field; the plant never calls the core's model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlantParams {
    /// `m`.
    pub mass_kg: f64,
    /// `X_udot` (negative).
    pub x_udot_kg: f64,
    /// `Y_vdot` (negative).
    pub y_vdot_kg: f64,
    /// `Z_wdot` (negative).
    pub z_wdot_kg: f64,
    /// `M_qdot` (negative).
    pub m_qdot_kg_m2: f64,
    /// `N_rdot` (negative).
    pub n_rdot_kg_m2: f64,
    /// Linear drags `X_u, Y_v, Z_w, M_q, N_r` (magnitudes).
    pub x_u: f64,
    /// `Y_v`.
    pub y_v: f64,
    /// `Z_w`.
    pub z_w: f64,
    /// `M_q`.
    pub m_q: f64,
    /// `N_r`.
    pub n_r: f64,
    /// Quadratic drags `X_uu, Y_vv, Z_ww, M_qq, N_rr` (magnitudes).
    pub x_uu: f64,
    /// `Y_vv`.
    pub y_vv: f64,
    /// `Z_ww`.
    pub z_ww: f64,
    /// `M_qq`.
    pub m_qq: f64,
    /// `N_rr`.
    pub n_rr: f64,
    /// `I_y`.
    pub i_y_kg_m2: f64,
    /// `I_z`.
    pub i_z_kg_m2: f64,
    /// `z_g` (CG below CB).
    pub z_g_m: f64,
    /// `g`.
    pub gravity_m_s2: f64,
    /// `B - W` (positive floats up).
    pub buoyancy_offset_n: f64,
    /// Lever arm `l` of the horizontal thrusters.
    pub lever_arm_m: f64,
}

impl PlantParams {
    /// Widen the core's parameter set to `f64`.
    pub fn from_vehicle(p: &controller_core::params::VehicleParams) -> Self {
        let w = |x: f32| f64::from(x);
        Self {
            mass_kg: w(p.mass_kg),
            x_udot_kg: w(p.x_udot_kg),
            y_vdot_kg: w(p.y_vdot_kg),
            z_wdot_kg: w(p.z_wdot_kg),
            m_qdot_kg_m2: w(p.m_qdot_kg_m2),
            n_rdot_kg_m2: w(p.n_rdot_kg_m2),
            x_u: w(p.x_u),
            y_v: w(p.y_v),
            z_w: w(p.z_w),
            m_q: w(p.m_q),
            n_r: w(p.n_r),
            x_uu: w(p.x_uu),
            y_vv: w(p.y_vv),
            z_ww: w(p.z_ww),
            m_qq: w(p.m_qq),
            n_rr: w(p.n_rr),
            i_y_kg_m2: w(p.i_y_kg_m2),
            i_z_kg_m2: w(p.i_z_kg_m2),
            z_g_m: w(p.z_g_m),
            gravity_m_s2: w(p.gravity_m_s2),
            buoyancy_offset_n: w(p.buoyancy_offset_n),
            lever_arm_m: w(p.thruster_lever_arm_m),
        }
    }

    /// Weight `W = m g`.
    pub fn weight_n(&self) -> f64 {
        self.mass_kg * self.gravity_m_s2
    }
}

/// Generalized forces from the three thrusts: `tau_1 = F1x + F2x`, `tau_2 = l (F1x - F2x)`,
/// `tau_3 = F3z`.
pub fn generalized_forces(thrust_n: [f64; 3], lever_arm_m: f64) -> [f64; 3] {
    [
        thrust_n[0] + thrust_n[1],
        lever_arm_m * (thrust_n[0] - thrust_n[1]),
        thrust_n[2],
    ]
}

/// One classic RK4 step of `x_dot = f(t, x)` for a fixed-size state. `t` is the time since
/// the start of the step (so the caller can evaluate time-varying inputs such as the
/// thruster lag exactly).
pub fn rk4<const N: usize>(
    x: &[f64; N],
    h: f64,
    f: impl Fn(f64, &[f64; N]) -> [f64; N],
) -> [f64; N] {
    let add = |a: &[f64; N], b: &[f64; N], s: f64| -> [f64; N] {
        let mut o = *a;
        for (oi, bi) in o.iter_mut().zip(b.iter()) {
            *oi += s * bi;
        }
        o
    };
    let k1 = f(0.0, x);
    let k2 = f(0.5 * h, &add(x, &k1, 0.5 * h));
    let k3 = f(0.5 * h, &add(x, &k2, 0.5 * h));
    let k4 = f(h, &add(x, &k3, h));
    let mut o = *x;
    for i in 0..N {
        o[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    o
}
