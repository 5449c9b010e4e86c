//! The tracking laws' gains: what each does, its default, and its validation (finite,
//! positive, and within the range its law stays stable in: [`crate::law::gain_bounds`]).

use crate::error::{positive, Error};
use serde::{Deserialize, Serialize};

/// Gains of the tracking laws. Every value must be finite and positive.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TrackingGains {
    /// XY: distance `eps` of the hand point ahead of the origin (m). The yaw dynamics are
    /// stable for `eps > (m11 - m22) U / Y_v` (0.28 U for the Observer, `U` relative to the
    /// water); smaller `eps` shrinks the origin error a heading error causes. 0.2 m covers
    /// about 1 m/s (measured).
    pub hand_m: f32,
    /// XY: hand position gain (1/s^2).
    pub xy_kp: f32,
    /// XY: hand velocity gain (1/s).
    pub xy_kd: f32,
    /// XY: integral gain on the origin error (1/s^3).
    pub xy_ki: f32,
    /// XZ: position gain of the x1 loop (1/s^2).
    pub xz_kp: f32,
    /// XZ: velocity gain of the x1 loop (1/s).
    pub xz_kd: f32,
    /// XZ: integral gain of the x1 loop (1/s^3).
    pub xz_ki: f32,
    /// XZ: pitch gain (1/s^2).
    pub pitch_kp: f32,
    /// XZ: pitch-rate gain (1/s).
    pub pitch_kd: f32,
    /// XZ: largest pitch demand (rad, < 0.7).
    pub pitch_max_rad: f32,
    /// Depth: position gain (1/s^2).
    pub depth_kp: f32,
    /// Depth: velocity gain (1/s).
    pub depth_kd: f32,
    /// Depth: integral gain (1/s^3).
    pub depth_ki: f32,
    /// XZ on the 6-DOF plant: yaw-hold gain (1/s^2).
    pub yaw_kp: f32,
    /// XZ on the 6-DOF plant: yaw-rate gain (1/s).
    pub yaw_kd: f32,
    /// Largest position error fed to the PD terms (m); bounds the virtual controls.
    pub error_limit_m: f32,
    /// Largest acceleration an integrator may contribute (m/s^2).
    pub integral_limit_m_s2: f32,
    /// XY: bandwidth of the disturbance observer read as a current (rad/s); 0 turns it off.
    /// Must be >= 0. Measured effect in `docs/tracking.md`.
    pub current_observer_rad_s: f32,
}

impl TrackingGains {
    /// The documented defaults (`docs/tracking.md`).
    pub const DEFAULT: Self = Self {
        hand_m: 0.2,
        xy_kp: 1.0,
        xy_kd: 2.0,
        xy_ki: 0.15,
        xz_kp: 3.0,
        xz_kd: 3.0,
        xz_ki: 1.0,
        pitch_kp: 9.0,
        pitch_kd: 6.0,
        pitch_max_rad: 0.35,
        depth_kp: 3.0,
        depth_kd: 3.0,
        depth_ki: 1.0,
        yaw_kp: 4.0,
        yaw_kd: 4.0,
        error_limit_m: 0.5,
        integral_limit_m_s2: 1.0,
        current_observer_rad_s: 1.0,
    };

    /// Refuse non-finite or non-positive gains, and a pitch limit at or beyond 0.7 rad (the
    /// inverse of `sin(2 theta)` needs `|theta| < pi / 4`).
    pub fn validate(&self) -> Result<(), Error> {
        for (n, v) in [
            ("hand_m", self.hand_m),
            ("xy_kp", self.xy_kp),
            ("xy_kd", self.xy_kd),
            ("xy_ki", self.xy_ki),
            ("xz_kp", self.xz_kp),
            ("xz_kd", self.xz_kd),
            ("xz_ki", self.xz_ki),
            ("pitch_kp", self.pitch_kp),
            ("pitch_kd", self.pitch_kd),
            ("pitch_max_rad", self.pitch_max_rad),
            ("depth_kp", self.depth_kp),
            ("depth_kd", self.depth_kd),
            ("depth_ki", self.depth_ki),
            ("yaw_kp", self.yaw_kp),
            ("yaw_kd", self.yaw_kd),
            ("error_limit_m", self.error_limit_m),
            ("integral_limit_m_s2", self.integral_limit_m_s2),
        ] {
            positive(n, v)?;
        }
        crate::error::non_negative("current_observer_rad_s", self.current_observer_rad_s)?;
        if self.pitch_max_rad >= 0.7 {
            return Err(Error::OutOfRange("pitch_max_rad"));
        }
        Ok(())
    }
}

impl Default for TrackingGains {
    fn default() -> Self {
        Self::DEFAULT
    }
}
