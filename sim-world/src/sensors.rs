//! Simulated sensors and the scenario keys that fit them: `[navigation]` and `[sensors.*]`.
//!
//! Each sensor samples the plant's *true* state at its rate and adds what the real one adds.
//! A table present in the scenario means the sensor is fitted; every key has a default:
//!
//! | sensor | default | source of the default |
//! |---|---|---|
//! | `imu` | 100 Hz; gyro 4.9e-5 rad/s/sqrt(Hz), bias 0.005 rad/s, walk 1e-5 rad/s/sqrt(s); accelerometer 6.9e-4 m/s^2/sqrt(Hz), bias 0.02 m/s^2, walk 1e-4 m/s^2/sqrt(s) | TDK ICM-42688-P datasheet (Pixhawk 6 class): 2.8 mdps/sqrt(Hz), 70 ug/sqrt(Hz), offsets after a power-on calibration |
//! | `depth` | 10 Hz, 5 mm, no bias | TE MS5837-30BA: 0.2 mbar resolution at OSR 8192 (2 mm of water) |
//! | `compass` | 10 Hz, 0.02 rad, no bias | a calibrated 3-axis magnetometer near thrusters, about 1 degree |
//! | `dvl` | 5 Hz, 0.01 m/s | Water Linked DVL A50: 2-15 Hz, long-term accuracy 0.1 %, noise about 1 cm/s at ROV speeds |
//! | `usbl` | 1 Hz, 0.3 m, 0.5 s latency, no outliers | Water Linked Underwater GPS G2 / Blueprint SeaTrac X150: about 1 Hz, 1 % of slant range plus a few decimetres, 0.3-1 s of latency |
//!
//! - The IMU's constant biases (`gyro_bias_rad_s`, `accel_bias_m_s2`) are the standard
//!   deviations of a per-axis draw made once per run (Monte Carlo draws each run's own), plus a
//!   random walk. The compass `bias_rad` and depth `bias_m` are fixed offsets (a calibration
//!   error), the same in every run.
//! - White noise of a density `n` is sampled at rate `f` as `n sqrt(f)` per sample.
//! - A USBL fix carries the time of its ping (its time of validity) and arrives `latency_s`
//!   later. An outlier (`outlier_fraction` of the fixes) is the true position moved by a
//!   distance drawn uniformly in `[outlier_m, 2 outlier_m]`, in a random direction (multipath).
//! - `dropouts_s = [[t0, t1], ...]`: no samples with `t0 <= t < t1`.

use crate::checks::{fin as finite, nonneg as noise};
use crate::plant::PlantState;
use anyhow::{bail, Result};
use serde::{Deserialize, Serialize};

/// Where the laws' state comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum NavSource {
    /// The plant's state (delayed and noisy per `[disturbance]`): today's behaviour.
    #[default]
    Truth,
    /// The core's estimator on the simulated sensors.
    Estimator,
}

/// `[navigation]`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NavigationSpec {
    /// `"truth"` (default) or `"estimator"`.
    pub source: NavSource,
    /// What the estimator is told of the launch point is off the truth by `[north, east]`
    /// (m) (an unknown start).
    pub start_error_m: [f64; 2],
    /// What the estimator is told of the start heading is off the truth by this (rad).
    pub start_heading_error_rad: f64,
    /// The start position's uncertainty the estimator is given (m, each horizontal axis);
    /// default the estimator's (0.5 m).
    pub start_position_std_m: Option<f64>,
    /// The start heading's uncertainty the estimator is given (rad); default the
    /// estimator's (0.05 rad).
    pub start_heading_std_rad: Option<f64>,
    /// The compass calibration `[sin_rad, cos_rad]` of a swing
    /// (`controller_core::nav::compass_cal`): each heading fix is corrected by it before the
    /// estimator fuses it. None: no correction.
    pub compass_calibration: Option<[f64; 2]>,
}

impl NavigationSpec {
    /// Check the start keys; the error names the key.
    pub fn validate(&self) -> Result<()> {
        finite("navigation.start_error_m[0]", self.start_error_m[0])?;
        finite("navigation.start_error_m[1]", self.start_error_m[1])?;
        finite(
            "navigation.start_heading_error_rad",
            self.start_heading_error_rad,
        )?;
        if let Some(v) = self.start_position_std_m {
            crate::checks::pos("navigation.start_position_std_m", v)?;
        }
        if let Some(v) = self.start_heading_std_rad {
            crate::checks::pos("navigation.start_heading_std_rad", v)?;
        }
        if let Some([a, b]) = self.compass_calibration {
            finite("navigation.compass_calibration[0]", a)?;
            finite("navigation.compass_calibration[1]", b)?;
            if a.hypot(b) > MAX_COMPASS_ERROR_RAD {
                bail!(
                    "navigation.compass_calibration must have an amplitude within 30 deg (got {:.1} deg)",
                    a.hypot(b).to_degrees()
                );
            }
        }
        Ok(())
    }

    /// What the estimator is told at the start: the true initial state moved by the start
    /// errors.
    pub fn told_start(&self, truth: &PlantState) -> PlantState {
        let mut told = *truth;
        told.eta[0] += self.start_error_m[0];
        told.eta[1] += self.start_error_m[1];
        told.eta[5] += self.start_heading_error_rad;
        told
    }
}

/// `[sensors.imu]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ImuSpec {
    /// Sample rate (Hz).
    pub rate_hz: f64,
    /// Gyro white noise density (rad/s/sqrt(Hz)).
    pub gyro_noise_rad_s_sqrt_hz: f64,
    /// Standard deviation of the per-axis constant gyro bias drawn per run (rad/s).
    pub gyro_bias_rad_s: f64,
    /// Gyro bias random walk (rad/s/sqrt(s)).
    pub gyro_bias_walk_rad_s_sqrt_s: f64,
    /// Accelerometer white noise density (m/s^2/sqrt(Hz)).
    pub accel_noise_m_s2_sqrt_hz: f64,
    /// Standard deviation of the per-axis constant accelerometer bias drawn per run (m/s^2).
    pub accel_bias_m_s2: f64,
    /// Accelerometer bias random walk (m/s^2/sqrt(s)).
    pub accel_bias_walk_m_s2_sqrt_s: f64,
}

impl Default for ImuSpec {
    fn default() -> Self {
        Self {
            rate_hz: 100.0,
            gyro_noise_rad_s_sqrt_hz: 4.9e-5,
            gyro_bias_rad_s: 0.005,
            gyro_bias_walk_rad_s_sqrt_s: 1.0e-5,
            accel_noise_m_s2_sqrt_hz: 6.9e-4,
            accel_bias_m_s2: 0.02,
            accel_bias_walk_m_s2_sqrt_s: 1.0e-4,
        }
    }
}

/// `[sensors.depth]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DepthSpec {
    /// Sample rate (Hz).
    pub rate_hz: f64,
    /// Noise standard deviation (m).
    pub noise_m: f64,
    /// Fixed offset (m).
    pub bias_m: f64,
}

impl Default for DepthSpec {
    fn default() -> Self {
        Self {
            rate_hz: 10.0,
            noise_m: 0.005,
            bias_m: 0.0,
        }
    }
}

/// `[sensors.compass]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CompassSpec {
    /// Sample rate (Hz).
    pub rate_hz: f64,
    /// Noise standard deviation (rad).
    pub noise_rad: f64,
    /// Fixed offset (rad).
    pub bias_rad: f64,
    /// Amplitude of the hard-iron deviation, a one-cycle sine in heading (rad):
    /// `hard_iron_rad sin(psi + hard_iron_phase_rad)`.
    pub hard_iron_rad: f64,
    /// Phase of the hard-iron deviation (rad).
    pub hard_iron_phase_rad: f64,
    /// Offset proportional to the thrusters' effort (rad per newton of `|F1x| + |F2x| + |F3z|`,
    /// the commanded thrusts): the field of the motor currents next to the magnetometer.
    pub thrust_offset_rad_per_n: f64,
}

impl Default for CompassSpec {
    fn default() -> Self {
        Self {
            rate_hz: 10.0,
            noise_rad: 0.02,
            bias_rad: 0.0,
            hard_iron_rad: 0.0,
            hard_iron_phase_rad: 0.0,
            thrust_offset_rad_per_n: 0.0,
        }
    }
}

/// Largest compass error accepted in a scenario (30 degrees): beyond it the magnetometer is
/// not calibrated at all, and no estimator should be asked to fly on it.
pub const MAX_COMPASS_ERROR_RAD: f64 = 30.0 * std::f64::consts::PI / 180.0;
/// Total thrust the compass's thrust offset is checked at (N): three 20 N thrusters at full.
pub const COMPASS_CHECK_THRUST_N: f64 = 60.0;
/// Largest DVL scale-factor error accepted in a scenario (10 %).
pub const MAX_DVL_SCALE_ERROR: f64 = 0.10;

impl CompassSpec {
    /// The heading the compass reads for the true heading `psi` with the thrusters making
    /// `thrust_n` (before its white noise): `psi + bias + A sin(psi + phase) + k sum|F|`.
    pub fn reading_rad(&self, psi_rad: f64, thrust_n: [f64; 3]) -> f64 {
        let effort_n: f64 = thrust_n.iter().map(|f| f.abs()).sum();
        psi_rad
            + self.bias_rad
            + self.hard_iron_rad * (psi_rad + self.hard_iron_phase_rad).sin()
            + self.thrust_offset_rad_per_n * effort_n
    }
}

/// `key`, an angle error, must be finite and within [`MAX_COMPASS_ERROR_RAD`].
fn plausible_angle(key: &str, v: f64) -> Result<()> {
    finite(key, v)?;
    if v.abs() > MAX_COMPASS_ERROR_RAD {
        bail!(
            "{key} must be within +-30 deg = +-{MAX_COMPASS_ERROR_RAD:.4} rad (got {v}: {:.1} deg)",
            v.to_degrees()
        );
    }
    Ok(())
}

/// `[sensors.dvl]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DvlSpec {
    /// Sample rate (Hz).
    pub rate_hz: f64,
    /// Noise standard deviation of each component (m/s).
    pub noise_m_s: f64,
    /// Intervals without bottom lock `[[t0, t1], ...]` (s).
    pub dropouts_s: Vec<[f64; 2]>,
    /// Scale-factor error: the DVL reads `(1 + scale_error)` times the true speed.
    pub scale_error: f64,
    /// Mounting yaw: the DVL's axes are turned by this angle from the body's (rad), so it
    /// reports the body velocity rotated by `-mounting_yaw_rad`.
    pub mounting_yaw_rad: f64,
    /// Highest altitude above the seabed with bottom lock (m); above it (with a
    /// `water.seabed_depth_m`) the DVL gives nothing. None: always in range.
    pub max_altitude_m: Option<f64>,
}

impl Default for DvlSpec {
    fn default() -> Self {
        Self {
            rate_hz: 5.0,
            noise_m_s: 0.01,
            dropouts_s: Vec::new(),
            scale_error: 0.0,
            mounting_yaw_rad: 0.0,
            max_altitude_m: None,
        }
    }
}

impl DvlSpec {
    /// The body-axis velocity `[u, v]` as this DVL reports it (before its white noise).
    pub fn reading_m_s(&self, uv_m_s: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.mounting_yaw_rad.sin_cos();
        let k = 1.0 + self.scale_error;
        [
            k * (c * uv_m_s[0] + s * uv_m_s[1]),
            k * (-s * uv_m_s[0] + c * uv_m_s[1]),
        ]
    }
}

/// `[sensors.usbl]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct UsblSpec {
    /// Fix rate (Hz).
    pub rate_hz: f64,
    /// Noise standard deviation of each horizontal component (m).
    pub noise_m: f64,
    /// Time from the ping to the fix's arrival on board (s).
    pub latency_s: f64,
    /// Share of fixes replaced by multipath outliers, in [0, 1].
    pub outlier_fraction: f64,
    /// Smallest distance of an outlier from the truth (m); the largest is twice this.
    pub outlier_m: f64,
    /// Intervals without fixes `[[t0, t1], ...]` (s).
    pub dropouts_s: Vec<[f64; 2]>,
    /// Constant offset of every fix `[north, east]` (m): a transceiver's position or
    /// alignment error.
    pub bias_m: [f64; 2],
    /// Latency jitter: each fix arrives `latency_s + U(0, latency_jitter_s)` after its ping
    /// (s); the fix still carries its ping time.
    pub latency_jitter_s: f64,
    /// A persistent step `[north, east]` (m) added to every fix pinged at or after
    /// `step_at_s`: the transceiver moved, or was re-surveyed.
    pub step_m: [f64; 2],
    /// Time of the step (s).
    pub step_at_s: f64,
}

impl Default for UsblSpec {
    fn default() -> Self {
        Self {
            rate_hz: 1.0,
            noise_m: 0.3,
            latency_s: 0.5,
            outlier_fraction: 0.0,
            outlier_m: 10.0,
            dropouts_s: Vec::new(),
            bias_m: [0.0; 2],
            latency_jitter_s: 0.0,
            step_m: [0.0; 2],
            step_at_s: 0.0,
        }
    }
}

/// `[sensors]`: a table present = the sensor is fitted.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SensorsSpec {
    /// Gyro and accelerometer.
    pub imu: Option<ImuSpec>,
    /// Pressure depth.
    pub depth: Option<DepthSpec>,
    /// Compass heading.
    pub compass: Option<CompassSpec>,
    /// Doppler velocity log.
    pub dvl: Option<DvlSpec>,
    /// Acoustic position fixes.
    pub usbl: Option<UsblSpec>,
}

fn rate(key: &str, v: f64) -> Result<()> {
    finite(key, v)?;
    if v <= 0.0 || v > 10_000.0 {
        bail!("{key} must be > 0 and <= 10000 Hz (got {v})");
    }
    Ok(())
}

fn dropouts(key: &str, d: &[[f64; 2]]) -> Result<()> {
    for (i, [a, b]) in d.iter().enumerate() {
        finite(&format!("{key}[{i}][0]"), *a)?;
        finite(&format!("{key}[{i}][1]"), *b)?;
        if b < a {
            bail!("{key}[{i}] must be [start, end] with start <= end (got [{a}, {b}])");
        }
    }
    Ok(())
}

impl SensorsSpec {
    /// Check every key; the error names it.
    pub fn validate(&self) -> Result<()> {
        if let Some(s) = &self.imu {
            rate("sensors.imu.rate_hz", s.rate_hz)?;
            noise(
                "sensors.imu.gyro_noise_rad_s_sqrt_hz",
                s.gyro_noise_rad_s_sqrt_hz,
            )?;
            noise("sensors.imu.gyro_bias_rad_s", s.gyro_bias_rad_s)?;
            noise(
                "sensors.imu.gyro_bias_walk_rad_s_sqrt_s",
                s.gyro_bias_walk_rad_s_sqrt_s,
            )?;
            noise(
                "sensors.imu.accel_noise_m_s2_sqrt_hz",
                s.accel_noise_m_s2_sqrt_hz,
            )?;
            noise("sensors.imu.accel_bias_m_s2", s.accel_bias_m_s2)?;
            noise(
                "sensors.imu.accel_bias_walk_m_s2_sqrt_s",
                s.accel_bias_walk_m_s2_sqrt_s,
            )?;
        }
        if let Some(s) = &self.depth {
            rate("sensors.depth.rate_hz", s.rate_hz)?;
            noise("sensors.depth.noise_m", s.noise_m)?;
            finite("sensors.depth.bias_m", s.bias_m)?;
        }
        if let Some(s) = &self.compass {
            rate("sensors.compass.rate_hz", s.rate_hz)?;
            noise("sensors.compass.noise_rad", s.noise_rad)?;
            plausible_angle("sensors.compass.bias_rad", s.bias_rad)?;
            plausible_angle("sensors.compass.hard_iron_rad", s.hard_iron_rad)?;
            finite("sensors.compass.hard_iron_phase_rad", s.hard_iron_phase_rad)?;
            finite(
                "sensors.compass.thrust_offset_rad_per_n",
                s.thrust_offset_rad_per_n,
            )?;
            if (s.thrust_offset_rad_per_n * COMPASS_CHECK_THRUST_N).abs() > MAX_COMPASS_ERROR_RAD {
                bail!(
                    "sensors.compass.thrust_offset_rad_per_n must keep the offset at {COMPASS_CHECK_THRUST_N} N within +-30 deg (got {} rad/N: {:.1} deg)",
                    s.thrust_offset_rad_per_n,
                    (s.thrust_offset_rad_per_n * COMPASS_CHECK_THRUST_N).to_degrees()
                );
            }
        }
        if let Some(s) = &self.dvl {
            rate("sensors.dvl.rate_hz", s.rate_hz)?;
            noise("sensors.dvl.noise_m_s", s.noise_m_s)?;
            dropouts("sensors.dvl.dropouts_s", &s.dropouts_s)?;
            finite("sensors.dvl.scale_error", s.scale_error)?;
            if s.scale_error.abs() > MAX_DVL_SCALE_ERROR {
                bail!(
                    "sensors.dvl.scale_error must be within +-0.1 (10 %) (got {})",
                    s.scale_error
                );
            }
            plausible_angle("sensors.dvl.mounting_yaw_rad", s.mounting_yaw_rad)?;
            if let Some(a) = s.max_altitude_m {
                crate::checks::pos("sensors.dvl.max_altitude_m", a)?;
            }
        }
        if let Some(s) = &self.usbl {
            rate("sensors.usbl.rate_hz", s.rate_hz)?;
            noise("sensors.usbl.noise_m", s.noise_m)?;
            noise("sensors.usbl.latency_s", s.latency_s)?;
            if s.latency_s >= 10.0 {
                bail!(
                    "sensors.usbl.latency_s must be < 10 s (got {})",
                    s.latency_s
                );
            }
            finite("sensors.usbl.outlier_fraction", s.outlier_fraction)?;
            if !(0.0..=1.0).contains(&s.outlier_fraction) {
                bail!(
                    "sensors.usbl.outlier_fraction must be in [0, 1] (got {})",
                    s.outlier_fraction
                );
            }
            noise("sensors.usbl.outlier_m", s.outlier_m)?;
            dropouts("sensors.usbl.dropouts_s", &s.dropouts_s)?;
            finite("sensors.usbl.bias_m[0]", s.bias_m[0])?;
            finite("sensors.usbl.bias_m[1]", s.bias_m[1])?;
            noise("sensors.usbl.latency_jitter_s", s.latency_jitter_s)?;
            finite("sensors.usbl.step_m[0]", s.step_m[0])?;
            finite("sensors.usbl.step_m[1]", s.step_m[1])?;
            noise("sensors.usbl.step_at_s", s.step_at_s)?;
            if s.latency_s + s.latency_jitter_s >= 10.0 {
                bail!(
                    "sensors.usbl.latency_s + latency_jitter_s must be < 10 s (got {})",
                    s.latency_s + s.latency_jitter_s
                );
            }
        }
        Ok(())
    }

    /// What `source = "estimator"` lacks, if anything: IMU, depth, compass and at least one of
    /// DVL and USBL.
    pub fn missing_for_estimator(&self) -> Option<String> {
        let mut missing = Vec::new();
        if self.imu.is_none() {
            missing.push("[sensors.imu]");
        }
        if self.depth.is_none() {
            missing.push("[sensors.depth]");
        }
        if self.compass.is_none() {
            missing.push("[sensors.compass]");
        }
        if self.dvl.is_none() && self.usbl.is_none() {
            missing.push("[sensors.dvl] or [sensors.usbl]");
        }
        (!missing.is_empty()).then(|| missing.join(", "))
    }
}

/// A measurement as it reaches the vehicle, in the core's `f32` types.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Measurement {
    /// Gyro and accelerometer.
    Imu(controller_core::nav::ImuSample),
    /// Pressure depth.
    Depth(controller_core::nav::DepthFix),
    /// Compass.
    Heading(controller_core::nav::HeadingFix),
    /// DVL.
    Dvl(controller_core::nav::DvlFix),
    /// USBL (with `true` when this fix is an injected outlier).
    Position(controller_core::nav::PositionFix, bool),
}

/// The simulated DVL's serial line into the firmware's DVL port: what the DVL sends (Water
/// Linked A50 `wrz` reports, `docs/instruments.md`) waits here until the firmware's
/// `DvlPort` reads it. Shared by the sender (the tether endpoint, which has the
/// measurements) and the in-process App (its UART); clones are the same line.
#[derive(Debug, Clone, Default)]
pub struct DvlWire {
    bytes: std::sync::Arc<std::sync::Mutex<std::collections::VecDeque<u8>>>,
    /// Time of validity of the previous report (us), for its "time since last" field.
    last_tov_us: Option<u64>,
}

/// The simulated DVL's clock: Unix time in microseconds at simulated time 0.
pub const DVL_EPOCH_US: u64 = 1_767_225_600_000_000;

/// Altitude the simulated DVL reports (m): a [`DvlFix`](controller_core::nav::DvlFix)
/// does not carry one and the estimator does not use it.
pub const DVL_REPORTED_ALTITUDE_M: f32 = 10.0;

impl DvlWire {
    fn queue(&self) -> std::sync::MutexGuard<'_, std::collections::VecDeque<u8>> {
        // A panic elsewhere while holding the lock leaves whole bytes behind: still usable.
        self.bytes.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Send `fix` as the A50 sends a velocity report with bottom lock: `wrz` with the
    /// velocity to 1 mm/s, the standard deviation as the figure of merit and the diagonal
    /// of the covariance, time of validity = time of transmission (the simulated DVL has no
    /// processing latency; its fix is delivered in the step it is made), and its CRC-8.
    pub fn send_wrz(&mut self, fix: &controller_core::nav::DvlFix) {
        let tov = DVL_EPOCH_US + fix.t_us;
        let since_ms = self
            .last_tov_us
            .map_or(0.0, |prev| tov.saturating_sub(prev) as f64 * 1e-3);
        self.last_tov_us = Some(tov);
        let var = f64::from(fix.std_m_s).powi(2);
        let body = format!(
            "wrz,{:.3},{:.3},0.000,y,{:.2},{:.3},{var:.3e};0;0;0;{var:.3e};0;0;0;{var:.3e},{tov},{tov},{since_ms:.2},0",
            fix.velocity_m_s[0], fix.velocity_m_s[1], DVL_REPORTED_ALTITUDE_M, fix.std_m_s,
        );
        let crc = firmware::sensors::dvl::a50::CRC8.checksum(body.as_bytes());
        let line = format!("{body}*{crc:02x}\r\n");
        self.queue().extend(line.as_bytes());
    }

    /// Bytes waiting to be read.
    pub fn pending(&self) -> usize {
        self.queue().len()
    }
}

impl embedded_io::ErrorType for DvlWire {
    type Error = std::convert::Infallible;
}

impl embedded_io::Read for DvlWire {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        let mut q = self.queue();
        let n = buf.len().min(q.len());
        for (b, x) in buf.iter_mut().zip(q.drain(..n)) {
            *b = x;
        }
        Ok(n)
    }
}

impl embedded_io::ReadReady for DvlWire {
    fn read_ready(&mut self) -> Result<bool, Self::Error> {
        Ok(!self.queue().is_empty())
    }
}
