//! The estimator's process noise and start-up uncertainty ([`NavConfig`]).

use crate::error::{non_negative, positive, Error};

/// Standard gravity (m/s^2).
pub const GRAVITY_M_S2: f32 = 9.806_65;
use serde::{Deserialize, Serialize};

/// Process noise and start-up uncertainty, validated by [`NavConfig::validate`].
///
/// The sensor noise of each fix travels with the fix; these are the figures of the IMU and of
/// the model that the prediction uses.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NavConfig {
    /// Gyro white noise density (rad/s/sqrt(Hz)).
    pub gyro_noise_rad_s_sqrt_hz: f32,
    /// Gyro bias random walk (rad/s/sqrt(s)).
    pub gyro_bias_walk_rad_s_sqrt_s: f32,
    /// Accelerometer white noise density (m/s^2/sqrt(Hz)).
    pub accel_noise_m_s2_sqrt_hz: f32,
    /// Accelerometer bias random walk (m/s^2/sqrt(s)).
    pub accel_bias_walk_m_s2_sqrt_s: f32,
    /// What the horizontal model does not explain, as a white acceleration noise on surge and
    /// sway (m/s^2/sqrt(Hz)): parameter errors, thruster lag and curve, unmodelled coupling.
    pub model_accel_noise_m_s2_sqrt_hz: f32,
    /// Random walk of the ocean current (m/s/sqrt(s)).
    pub current_walk_m_s_sqrt_s: f32,
    /// Uncertainty of the start position, each horizontal axis (m).
    pub initial_position_std_m: f32,
    /// Uncertainty of the start depth (m).
    pub initial_depth_std_m: f32,
    /// Uncertainty of the start heading (rad).
    pub initial_heading_std_rad: f32,
    /// Uncertainty of the gyro bias at start (rad/s).
    pub initial_gyro_bias_std_rad_s: f32,
    /// Uncertainty of the vertical accelerometer bias at start (m/s^2).
    pub initial_accel_bias_std_m_s2: f32,
    /// Uncertainty of the current at start, each axis (m/s).
    pub initial_current_std_m_s: f32,
    /// Time constant of the tilt filter's pull toward the accelerometer (s).
    pub tilt_time_constant_s: f32,
    /// Uncertainty of the compass's constant bias at start (rad): how far off the
    /// magnetometer may read next to the thrusters.
    pub initial_compass_bias_std_rad: f32,
    /// Random walk of the compass bias (rad/sqrt(s)): the part that changes with the
    /// thrusters' currents and the heading.
    pub compass_bias_walk_rad_sqrt_s: f32,
}

impl Default for NavConfig {
    /// The process noise of a Pixhawk-class MEMS IMU (ICM-42688-P: 2.8 mdps/sqrt(Hz),
    /// 70 ug/sqrt(Hz)) *inflated* for what the decoupled filters neglect: the tilt error
    /// leaks gravity into the vertical acceleration (0.05 rad of roll is 0.012 m/s^2),
    /// vibration, and the heading's coupling to the tilt. With the datasheet figures alone the
    /// filters grow overconfident, gate out good fixes and diverge (seen in Monte Carlo, 1 run
    /// in 100). The Observer's model is known to about 20 %, the launch point to 0.5 m.
    fn default() -> Self {
        Self {
            gyro_noise_rad_s_sqrt_hz: 5.0e-4,
            gyro_bias_walk_rad_s_sqrt_s: 1.0e-5,
            accel_noise_m_s2_sqrt_hz: 0.05,
            accel_bias_walk_m_s2_sqrt_s: 1.0e-4,
            model_accel_noise_m_s2_sqrt_hz: 0.01,
            current_walk_m_s_sqrt_s: 2.0e-3,
            initial_position_std_m: 0.5,
            initial_depth_std_m: 0.1,
            initial_heading_std_rad: 0.05,
            initial_gyro_bias_std_rad_s: 0.01,
            initial_accel_bias_std_m_s2: 0.1,
            initial_current_std_m_s: 0.1,
            tilt_time_constant_s: 1.0,
            initial_compass_bias_std_rad: 0.1,
            compass_bias_walk_rad_sqrt_s: 1.0e-4,
        }
    }
}

impl NavConfig {
    /// Check every figure: noises and walks finite and >= 0, start-up uncertainties and the
    /// tilt time constant > 0.
    pub fn validate(&self) -> Result<Self, Error> {
        non_negative("gyro_noise_rad_s_sqrt_hz", self.gyro_noise_rad_s_sqrt_hz)?;
        non_negative(
            "gyro_bias_walk_rad_s_sqrt_s",
            self.gyro_bias_walk_rad_s_sqrt_s,
        )?;
        non_negative("accel_noise_m_s2_sqrt_hz", self.accel_noise_m_s2_sqrt_hz)?;
        non_negative(
            "accel_bias_walk_m_s2_sqrt_s",
            self.accel_bias_walk_m_s2_sqrt_s,
        )?;
        non_negative(
            "model_accel_noise_m_s2_sqrt_hz",
            self.model_accel_noise_m_s2_sqrt_hz,
        )?;
        non_negative("current_walk_m_s_sqrt_s", self.current_walk_m_s_sqrt_s)?;
        positive("initial_position_std_m", self.initial_position_std_m)?;
        positive("initial_depth_std_m", self.initial_depth_std_m)?;
        positive("initial_heading_std_rad", self.initial_heading_std_rad)?;
        positive(
            "initial_gyro_bias_std_rad_s",
            self.initial_gyro_bias_std_rad_s,
        )?;
        positive(
            "initial_accel_bias_std_m_s2",
            self.initial_accel_bias_std_m_s2,
        )?;
        positive("initial_current_std_m_s", self.initial_current_std_m_s)?;
        positive("tilt_time_constant_s", self.tilt_time_constant_s)?;
        positive(
            "initial_compass_bias_std_rad",
            self.initial_compass_bias_std_rad,
        )?;
        non_negative(
            "compass_bias_walk_rad_sqrt_s",
            self.compass_bias_walk_rad_sqrt_s,
        )?;
        Ok(*self)
    }
}
