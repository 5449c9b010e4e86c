//! Compass calibration by a swing: the vehicle turns a full circle in place, as
//! operators swing a ship's compass, and the heading-dependent deviation is fitted.
//!
//! A magnetometer next to steel and magnets (hard iron) reads `psi + c + a sin(psi) +
//! b cos(psi)`: a constant and a one-cycle sine in heading. During the turn the gyro gives
//! the heading *change* `theta(t)` (its bias corrected by the estimator, the rest absorbed
//! below) while the true start heading `psi_0` is unknown, so with the compass reading `m`
//! (unwrapped over the turn):
//!
//! ```text
//! m - theta = (psi_0 + c) + a sin(psi) + b cos(psi) + d t + noise
//! ```
//!
//! fitted by least squares on the regressors `[1, sin(m), cos(m), t]`: `psi` is taken as the
//! reading (the error of that is the deviation itself, a few degrees, and moves the fitted
//! sine by its square: 5 degrees of deviation, 0.4 degree); `d` absorbs a residual gyro bias.
//! The constant `psi_0 + c` cannot be split (the swing has no absolute heading reference):
//! the constant bias is left to the estimator's compass-bias state; the calibration is the
//! sine, `a` and `b`, which a survey's straight legs cannot tell from a constant.
//!
//! A swing is refused (the old calibration stays) when the turn is less than a full circle,
//! when it has too few readings, when the fit's residual is too large (the vehicle was pushed,
//! the deviation is not a sine) or when the fitted deviation is beyond 30 degrees.
//!
//! `no_std`, `f32`, no allocation: the normal equations are accumulated as the readings come.

use crate::math::{sin_cos, sqrt, wrap_angle};
use serde::{Deserialize, Serialize};

/// Readings needed for a fit.
pub const MIN_READINGS: u32 = 30;
/// Largest RMS residual of an accepted fit (rad, about 3 degrees).
pub const MAX_RESIDUAL_RAD: f32 = 0.05;
/// Largest deviation amplitude accepted (rad, 30 degrees).
pub const MAX_DEVIATION_RAD: f32 = core::f32::consts::FRAC_PI_6;
/// A full circle (rad).
const FULL_TURN_RAD: f32 = 2.0 * core::f32::consts::PI;

/// The heading-dependent deviation of a compass: it reads `psi + a sin(psi) + b cos(psi)`
/// more than it would without it. The parameters `COMPASS_DEV_SIN`, `COMPASS_DEV_COS`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CompassCalibration {
    /// `a` (rad).
    pub sin_rad: f32,
    /// `b` (rad).
    pub cos_rad: f32,
}

impl CompassCalibration {
    /// No deviation.
    pub const NONE: Self = Self {
        sin_rad: 0.0,
        cos_rad: 0.0,
    };

    /// The deviation at heading `psi_rad`.
    pub fn deviation_rad(&self, psi_rad: f32) -> f32 {
        let (s, c) = sin_cos(psi_rad);
        self.sin_rad * s + self.cos_rad * c
    }

    /// A reading corrected: the reading less the deviation at the reading.
    pub fn correct(&self, reading_rad: f32) -> f32 {
        wrap_angle(reading_rad - self.deviation_rad(reading_rad))
    }

    /// Amplitude of the deviation (rad).
    pub fn amplitude_rad(&self) -> f32 {
        sqrt(self.sin_rad * self.sin_rad + self.cos_rad * self.cos_rad)
    }

    /// Check a calibration set from outside (a parameter write): finite, amplitude within
    /// [`MAX_DEVIATION_RAD`].
    pub fn validate(&self) -> Result<Self, CalRefusal> {
        if !(self.sin_rad.is_finite() && self.cos_rad.is_finite()) {
            return Err(CalRefusal::NonFinite);
        }
        if self.amplitude_rad() > MAX_DEVIATION_RAD {
            return Err(CalRefusal::OutOfRange);
        }
        Ok(*self)
    }
}

/// Why a swing was not accepted. The calibration in force is unchanged.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum CalRefusal {
    /// The vehicle turned less than a full circle.
    NotFullTurn,
    /// Fewer than [`MIN_READINGS`] readings.
    TooFewReadings,
    /// The fit's RMS residual exceeds [`MAX_RESIDUAL_RAD`].
    ResidualTooLarge,
    /// A reading or rate was NaN or infinite, or the fit is singular.
    NonFinite,
    /// The fitted deviation exceeds [`MAX_DEVIATION_RAD`].
    OutOfRange,
}

/// Regressors.
const K: usize = 4;

/// A swing in progress: the gyro's heading change, the unwrapped compass, and the normal
/// equations of the fit.
#[derive(Debug, Clone, Copy, Default)]
pub struct CompassSwing {
    /// Heading change integrated from the gyro since the start (rad).
    theta_rad: f32,
    /// The last reading, wrapped, and the unwrapping's turns so far (rad).
    last_reading_rad: Option<f32>,
    unwrapped_rad: f32,
    /// Time since the start (s).
    t_s: f32,
    n: u32,
    ata: [[f32; K]; K],
    aty: [f32; K],
    yty: f32,
    /// Set by a non-finite input: the swing can only be refused.
    poisoned: bool,
}

impl CompassSwing {
    /// A swing starting now.
    pub fn new() -> Self {
        Self::default()
    }

    /// The yaw rate (rad/s, bias-corrected) over `dt_s`.
    pub fn rate(&mut self, yaw_rate_rad_s: f32, dt_s: f32) {
        if !(yaw_rate_rad_s.is_finite() && dt_s.is_finite()) {
            self.poisoned = true;
            return;
        }
        self.theta_rad += yaw_rate_rad_s * dt_s;
        self.t_s += dt_s;
    }

    /// A compass reading (rad), made now.
    pub fn reading(&mut self, reading_rad: f32) {
        if !reading_rad.is_finite() {
            self.poisoned = true;
            return;
        }
        let m = wrap_angle(reading_rad);
        self.unwrapped_rad += match self.last_reading_rad {
            Some(last) => wrap_angle(m - last),
            None => m,
        };
        self.last_reading_rad = Some(m);
        let (s, c) = sin_cos(m);
        let row = [1.0, s, c, self.t_s];
        // The unwrapped reading less the gyro's heading change: the left side of the fit.
        let y = self.unwrapped_rad - self.theta_rad;
        for (i, ri) in row.iter().enumerate() {
            if let (Some(ata_i), Some(aty_i)) = (self.ata.get_mut(i), self.aty.get_mut(i)) {
                for (a, rj) in ata_i.iter_mut().zip(&row) {
                    *a += ri * rj;
                }
                *aty_i += ri * y;
            }
        }
        self.yty += y * y;
        self.n += 1;
    }

    /// Heading turned so far (rad, the gyro's).
    pub fn turned_rad(&self) -> f32 {
        self.theta_rad
    }

    /// Fit the deviation: the calibration and the fit's RMS residual (rad), or why not.
    pub fn fit(&self) -> Result<(CompassCalibration, f32), CalRefusal> {
        if self.poisoned {
            return Err(CalRefusal::NonFinite);
        }
        if self.theta_rad.abs() < FULL_TURN_RAD {
            return Err(CalRefusal::NotFullTurn);
        }
        if self.n < MIN_READINGS {
            return Err(CalRefusal::TooFewReadings);
        }
        let x = solve(self.ata, self.aty).ok_or(CalRefusal::NonFinite)?;
        // Residual sum of squares: y'y - x'A'y (normal equations).
        let explained: f32 = x.iter().zip(&self.aty).map(|(a, b)| a * b).sum();
        let rss = (self.yty - explained).max(0.0);
        let residual = sqrt(rss / self.n as f32);
        let [_, a, b, _] = x;
        let cal = CompassCalibration {
            sin_rad: a,
            cos_rad: b,
        }
        .validate()?;
        if !residual.is_finite() {
            return Err(CalRefusal::NonFinite);
        }
        if residual > MAX_RESIDUAL_RAD {
            return Err(CalRefusal::ResidualTooLarge);
        }
        Ok((cal, residual))
    }
}

/// Solve the symmetric positive definite 4x4 system `m x = v` (normal equations) by
/// Gaussian elimination without pivoting, which is stable for a positive definite matrix
/// (its pivots are the Schur complements, all positive); `None` when singular or not finite.
/// No pivot search: the code is smaller on the MCU (the firmware flies the turn).
fn solve(mut m: [[f32; K]; K], mut v: [f32; K]) -> Option<[f32; K]> {
    for col in 0..K {
        let pivot_row = *m.get(col)?;
        let pivot = *pivot_row.get(col)?;
        if pivot.is_nan() || pivot.abs() <= 1e-9 {
            return None;
        }
        let v_col = *v.get(col)?;
        for r in col + 1..K {
            let row = m.get_mut(r)?;
            let f = *row.get(col)? / pivot;
            for (a, p) in row.iter_mut().zip(&pivot_row) {
                *a -= f * p;
            }
            *v.get_mut(r)? -= f * v_col;
        }
    }
    let mut x = [0.0f32; K];
    for r in (0..K).rev() {
        let row = m.get(r)?;
        let mut s = *v.get(r)?;
        for c in r + 1..K {
            s -= row.get(c)? * x.get(c)?;
        }
        *x.get_mut(r)? = s / row.get(r)?;
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A swing at `rate` rad/s for `turn_rad`, compass 10 Hz with a deviation `a sin + b cos`,
    /// a constant offset and a gyro bias residual; no noise.
    fn swing(turn_rad: f32, a: f32, b: f32) -> CompassSwing {
        let mut s = CompassSwing::new();
        let (rate, dt, psi0) = (0.3f32, 0.01f32, 1.0f32);
        let steps = (turn_rad / rate / dt) as u32;
        for k in 1..=steps {
            s.rate(rate + 0.002, dt);
            if k % 10 == 0 {
                let psi = psi0 + rate * dt * k as f32;
                let (sn, cs) = sin_cos(psi);
                s.reading(psi + 0.07 + a * sn + b * cs);
            }
        }
        s
    }

    #[test]
    fn a_full_swing_recovers_the_deviation_within_a_degree() {
        let (a, b) = (0.06, -0.05);
        let (cal, residual) = swing(7.0, a, b).fit().unwrap();
        for k in 0..36 {
            let psi = k as f32 * 0.1745;
            let (sn, cs) = sin_cos(psi);
            let err = cal.deviation_rad(psi) - (a * sn + b * cs);
            assert!(err.abs() < 0.0175, "at {psi}: {err}");
        }
        assert!(residual < 0.01, "{residual}");
    }

    #[test]
    fn a_half_turn_and_a_bad_fit_are_refused() {
        assert_eq!(swing(3.0, 0.05, 0.0).fit(), Err(CalRefusal::NotFullTurn));
        let mut s = swing(7.0, 0.05, 0.0);
        // A reading that jumps by a radian every other sample: not a sine.
        for k in 0..40 {
            s.rate(0.0, 0.1);
            s.reading(if k % 2 == 0 { 1.0 } else { 2.5 });
        }
        assert_eq!(s.fit(), Err(CalRefusal::ResidualTooLarge));
        let mut s = CompassSwing::new();
        s.rate(f32::NAN, 0.01);
        assert_eq!(s.fit(), Err(CalRefusal::NonFinite));
        assert_eq!(
            CompassCalibration {
                sin_rad: 0.5,
                cos_rad: 0.5
            }
            .validate(),
            Err(CalRefusal::OutOfRange)
        );
    }
}
