//! Tilt: roll and pitch from a complementary filter (the heading is a state of the
//! horizontal filter, `horizontal.rs`).

use super::config::{NavConfig, GRAVITY_M_S2};
use crate::math::{atan2, clamp, sin_cos, sqrt, wrap_angle};

/// Largest |pitch| the Euler kinematics are integrated at (rad); the Observer is passively
/// stable in pitch and never comes near it.
const MAX_PITCH_RAD: f32 = 1.4;

/// Roll and pitch with their gyro biases: a complementary filter with an integral term
/// (Mahony, Hamel and Pflimlin, 2008, reduced to the two tilt angles). The gyro propagates
/// the Euler angles; the accelerometer's gravity direction pulls them back with the time
/// constant `tau` (`kp = 1 / tau`), and the integral term (`ki = kp^2 / 4`, critically
/// damped) learns the gyro biases of `p` and `q`. The pull is skipped while the specific force
/// is not close to `g` (the vehicle is accelerating hard or the sample is bad).
#[derive(Debug, Clone, Copy)]
pub(super) struct Tilt {
    roll_rad: f32,
    pitch_rad: f32,
    bias_p_rad_s: f32,
    bias_q_rad_s: f32,
}

impl Tilt {
    pub(super) fn new(roll_rad: f32, pitch_rad: f32) -> Self {
        Self {
            roll_rad,
            pitch_rad,
            bias_p_rad_s: 0.0,
            bias_q_rad_s: 0.0,
        }
    }

    pub(super) fn angles(&self) -> (f32, f32) {
        (self.roll_rad, self.pitch_rad)
    }

    /// Take `from`'s learned gyro biases of `p` and `q` (the angles stay).
    pub(super) fn keep_learned(&mut self, from: &Self) {
        (self.bias_p_rad_s, self.bias_q_rad_s) = from.bias();
    }

    pub(super) fn bias(&self) -> (f32, f32) {
        (self.bias_p_rad_s, self.bias_q_rad_s)
    }

    /// `rates` are bias-corrected `[p, q, r]`, `accel` the specific force.
    pub(super) fn predict(&mut self, cfg: &NavConfig, rates: [f32; 3], accel: [f32; 3], dt: f32) {
        let [p, q, r] = rates;
        let (sr, cr) = sin_cos(self.roll_rad);
        let (sp, cp) = sin_cos(self.pitch_rad);
        let tp = sp / cp;
        let roll_dot = p + (sr * q + cr * r) * tp;
        let pitch_dot = cr * q - sr * r;
        let [fx, fy, fz] = accel;
        let f2 = fx * fx + fy * fy + fz * fz;
        let g2 = GRAVITY_M_S2 * GRAVITY_M_S2;
        let (mut e_roll, mut e_pitch) = (0.0, 0.0);
        if f2 > 0.64 * g2 && f2 < 1.44 * g2 {
            let roll_acc = atan2(-fy, -fz);
            let pitch_acc = atan2(fx, sqrt(fy * fy + fz * fz));
            e_roll = wrap_angle(roll_acc - self.roll_rad);
            e_pitch = pitch_acc - self.pitch_rad;
        }
        let kp = 1.0 / cfg.tilt_time_constant_s;
        let ki = 0.25 * kp * kp;
        self.roll_rad = wrap_angle(self.roll_rad + (roll_dot + kp * e_roll) * dt);
        self.pitch_rad = clamp(
            self.pitch_rad + (pitch_dot + kp * e_pitch) * dt,
            -MAX_PITCH_RAD,
            MAX_PITCH_RAD,
        );
        self.bias_p_rad_s -= ki * e_roll * dt;
        self.bias_q_rad_s -= ki * e_pitch * dt;
    }
}
