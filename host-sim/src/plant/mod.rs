//! Desktop plant models in `f64`, written from the physical equations (not by calling the
//! core's `f32` model), integrated with RK4 at a fixed step.
//!
//! Every plant takes the commanded thruster forces `[F1x, F2x, F3z]`, applies the thrusters'
//! first-order lag and limits, and advances its state.

/// Pose and body velocities of the plant, `f64`, SI units.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PlantState {
    /// `[x, y, z, roll, pitch, yaw]` of the body origin (the CB), inertial, z down.
    pub eta: [f64; 6],
    /// `[u, v, w, p, q, r]` in the body frame.
    pub nu: [f64; 6],
}

/// A simulated vehicle.
pub trait Plant: Send {
    /// Advance by `dt_s` with the commanded thruster forces `[F1x, F2x, F3z]` (newtons).
    fn step(&mut self, thrust_cmd_n: [f64; 3], dt_s: f64);
    /// The current state.
    fn state(&self) -> PlantState;
    /// The thrust the thrusters really deliver now (after lag and limits).
    fn thrust_n(&self) -> [f64; 3];
}

pub mod six_dof;

/// The water around the vehicle (inertial frame).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Environment {
    /// Constant ocean current `[cx, cy, cz]`, inertial, m/s.
    pub current_m_s: [f64; 3],
}
