//! The vehicle the closed-loop bench items steer: the core's own planar models, so that
//! the control step sees the states it sees in operation (continuous in time, consistent
//! with the thrust it asked for) rather than independent random states.
//!
//! - XZ modes: the vertical-plane model ([`controller_core::model::xz`], surge, heave and
//!   pitch coupled), fourth-order Runge-Kutta.
//! - XY and 3-D modes: the horizontal-plane model ([`controller_core::model::xy`]) and,
//!   for depth, the heave equation of the same vehicle at zero pitch and roll,
//!   `m_z w_dot = -(Z_w + Z_ww |w|) w + (W - B) + tau_3`, `z_dot = w`.
//!
//! The plant takes the forces the allocation achieved (the thrusters' limits apply) and
//! runs untimed between two timed control steps.

use controller_core::controller::ControlMode;
use controller_core::model::{rk4_step, xy, xz};
use controller_core::params::Vehicle;
use controller_core::state::{BodyForces, NavState, XyState, XzState};

/// Which model moves the vehicle.
#[derive(Clone, Copy)]
pub enum Plane {
    /// Vertical plane.
    Xz,
    /// Horizontal plane plus depth.
    Xy3d,
}

impl Plane {
    /// The model for a control mode: the vertical plane for the XZ laws, else the horizontal
    /// plane plus depth.
    pub fn for_mode(mode: ControlMode) -> Self {
        match mode {
            ControlMode::PaperXz | ControlMode::TrackingXz => Plane::Xz,
            _ => Plane::Xy3d,
        }
    }
}

/// The simulated vehicle.
pub struct Plant {
    vehicle: Vehicle,
    plane: Plane,
    nav: NavState,
}

impl Plant {
    /// A vehicle of `plane` in the state `nav`.
    pub fn new(vehicle: Vehicle, plane: Plane, nav: NavState) -> Self {
        Self {
            vehicle,
            plane,
            nav,
        }
    }

    /// The navigation state (exact, no sensor model).
    pub fn nav(&self) -> &NavState {
        &self.nav
    }

    /// Advance by `dt_s` under the generalized forces `f` (zero-order hold, 4 substeps).
    pub fn advance(&mut self, f: &BodyForces, dt_s: f32) {
        const SUB: u32 = 4;
        let h = dt_s / SUB as f32;
        let v = &self.vehicle;
        let n = &mut self.nav;
        for _ in 0..SUB {
            match self.plane {
                Plane::Xz => {
                    let s = rk4_step(|s: &XzState| xz::derivative(v, s, f), &n.xz(), h);
                    n.x_m = s.x_m;
                    n.z_m = s.z_m;
                    n.pitch_rad = s.pitch_rad;
                    n.u_m_s = s.u_m_s;
                    n.w_m_s = s.w_m_s;
                    n.q_rad_s = s.q_rad_s;
                }
                Plane::Xy3d => {
                    let s = rk4_step(|s: &XyState| xy::derivative(v, s, f), &n.xy(), h);
                    n.x_m = s.x_m;
                    n.y_m = s.y_m;
                    n.yaw_rad = s.yaw_rad;
                    n.u_m_s = s.u_m_s;
                    n.v_m_s = s.v_m_s;
                    n.r_rad_s = s.r_rad_s;
                    let p = v.params();
                    let c = &v.xz;
                    let w = n.w_m_s;
                    let drag = (p.z_w + p.z_ww * w.abs()) * w;
                    let w_dot = (-drag + (c.weight_n - c.buoyancy_n) + f.heave_n) / c.m_z;
                    // Semi-implicit Euler: the new heave rate moves the depth.
                    n.w_m_s = w + h * w_dot;
                    n.z_m += h * n.w_m_s;
                }
            }
        }
    }
}
