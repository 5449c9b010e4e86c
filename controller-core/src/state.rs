//! Vehicle state, generalized forces and tracking errors, in SI units.

use serde::{Deserialize, Serialize};

/// Full navigation state: inertial pose of the body origin (the CB) and body-frame velocities.
/// This is what the state estimator delivers and what the laws read.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NavState {
    /// North / forward inertial position.
    pub x_m: f32,
    /// East inertial position.
    pub y_m: f32,
    /// Depth (z down).
    pub z_m: f32,
    /// Roll angle `phi`.
    pub roll_rad: f32,
    /// Pitch angle `theta`.
    pub pitch_rad: f32,
    /// Yaw angle `psi`.
    pub yaw_rad: f32,
    /// Surge speed `u`.
    pub u_m_s: f32,
    /// Sway speed `v`.
    pub v_m_s: f32,
    /// Heave speed `w`.
    pub w_m_s: f32,
    /// Roll rate `p`.
    pub p_rad_s: f32,
    /// Pitch rate `q`.
    pub q_rad_s: f32,
    /// Yaw rate `r`.
    pub r_rad_s: f32,
}

impl NavState {
    /// True when every field is finite.
    pub fn is_finite(&self) -> bool {
        [
            self.x_m,
            self.y_m,
            self.z_m,
            self.roll_rad,
            self.pitch_rad,
            self.yaw_rad,
            self.u_m_s,
            self.v_m_s,
            self.w_m_s,
            self.p_rad_s,
            self.q_rad_s,
            self.r_rad_s,
        ]
        .iter()
        .all(|v| v.is_finite())
    }

    /// The vertical-plane part.
    pub fn xz(&self) -> XzState {
        XzState {
            x_m: self.x_m,
            z_m: self.z_m,
            pitch_rad: self.pitch_rad,
            u_m_s: self.u_m_s,
            w_m_s: self.w_m_s,
            q_rad_s: self.q_rad_s,
        }
    }

    /// The horizontal-plane part.
    pub fn xy(&self) -> XyState {
        XyState {
            x_m: self.x_m,
            y_m: self.y_m,
            yaw_rad: self.yaw_rad,
            u_m_s: self.u_m_s,
            v_m_s: self.v_m_s,
            r_rad_s: self.r_rad_s,
        }
    }
}

/// State of the vertical-plane (XZ) model, eqs. (1)-(2).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct XzState {
    /// Inertial x of the body origin.
    pub x_m: f32,
    /// Depth of the body origin.
    pub z_m: f32,
    /// Pitch `theta`.
    pub pitch_rad: f32,
    /// Surge `u`.
    pub u_m_s: f32,
    /// Heave `w`.
    pub w_m_s: f32,
    /// Pitch rate `q`.
    pub q_rad_s: f32,
}

/// State of the horizontal-plane (XY) model, eq. (34).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct XyState {
    /// Inertial x.
    pub x_m: f32,
    /// Inertial y.
    pub y_m: f32,
    /// Yaw `psi`.
    pub yaw_rad: f32,
    /// Surge `u`.
    pub u_m_s: f32,
    /// Sway `v`.
    pub v_m_s: f32,
    /// Yaw rate `r`.
    pub r_rad_s: f32,
}

/// The three generalized forces the thrusters can make: `tau_1` (surge force,
/// `F1x + F2x`), `tau_2` (yaw moment, `l (F1x - F2x)`) and `tau_3` (heave force, `F3z`).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BodyForces {
    /// Surge force `tau_1`.
    pub surge_n: f32,
    /// Yaw moment `tau_2`.
    pub yaw_n_m: f32,
    /// Heave force `tau_3` (positive down).
    pub heave_n: f32,
}

impl BodyForces {
    /// True when every component is finite.
    pub fn is_finite(&self) -> bool {
        self.surge_n.is_finite() && self.yaw_n_m.is_finite() && self.heave_n.is_finite()
    }
}

/// Tracking errors of the body origin against the reference for the body origin, and of the
/// plane's controlled angle, for logs, telemetry and tests.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TrackingErrors {
    /// `x - x_r`.
    pub x_m: f32,
    /// `y - y_r`.
    pub y_m: f32,
    /// `z - z_r`.
    pub z_m: f32,
    /// Pitch error `theta - theta_r`, wrapped.
    pub pitch_rad: f32,
    /// Yaw error `psi - psi_r`, wrapped.
    pub yaw_rad: f32,
}

impl TrackingErrors {
    /// Euclidean norm of the position error.
    pub fn position_norm_m(&self) -> f32 {
        crate::math::sqrt(self.x_m * self.x_m + self.y_m * self.y_m + self.z_m * self.z_m)
    }
}
