//! Depth: `[z, z_dot, b_a]` driven by the accelerometer's vertical specific force, updated by
//! the pressure depth. `b_a` is the bias of the vertical acceleration (the accelerometer's
//! z bias, seen through a small tilt).

use super::config::{NavConfig, GRAVITY_M_S2};
use super::kf::{unit, Kf};
use super::refusal::{Refusal, GATE_CHI2_1DOF};
use crate::math::sin_cos;
use crate::state::NavState;

const Z: usize = 0;
const ZD: usize = 1;
const BA: usize = 2;

#[derive(Debug, Clone, Copy)]
pub(super) struct Vertical {
    kf: Kf<3>,
}

impl Vertical {
    pub(super) fn new(initial: &NavState, cfg: &NavConfig) -> Self {
        let sz = cfg.initial_depth_std_m;
        let sb = cfg.initial_accel_bias_std_m_s2;
        Self {
            kf: Kf::new([initial.z_m, 0.0, 0.0], [sz * sz, 0.01, sb * sb]),
        }
    }

    pub(super) fn depth(&self) -> f32 {
        self.kf.x[Z]
    }

    pub(super) fn depth_rate(&self) -> f32 {
        self.kf.x[ZD]
    }

    pub(super) fn depth_variance(&self) -> f32 {
        self.kf.var(Z)
    }

    /// Down acceleration `(R f)_z + g - b_a` with `R` the body-to-NED rotation (its z row
    /// does not depend on the heading).
    pub(super) fn predict(
        &mut self,
        cfg: &NavConfig,
        roll_rad: f32,
        pitch_rad: f32,
        accel: [f32; 3],
        dt: f32,
    ) {
        let (sr, cr) = sin_cos(roll_rad);
        let (sp, cp) = sin_cos(pitch_rad);
        let [fx, fy, fz] = accel;
        let a = -sp * fx + cp * sr * fy + cp * cr * fz + GRAVITY_M_S2 - self.kf.x[BA];
        let x = &mut self.kf.x;
        x[Z] += x[ZD] * dt + 0.5 * a * dt * dt;
        x[ZD] += a * dt;
        let phi = [[1.0, dt, -0.5 * dt * dt], [0.0, 1.0, -dt], [0.0, 0.0, 1.0]];
        let n = cfg.accel_noise_m_s2_sqrt_hz;
        let w = cfg.accel_bias_walk_m_s2_sqrt_s;
        self.kf
            .propagate(&phi, &[0.25 * n * n * dt * dt * dt, n * n * dt, w * w * dt]);
    }

    /// Take `from`'s accelerometer bias and its variance (a restart of the depth keeps it).
    pub(super) fn keep_learned(&mut self, from: &Self) {
        self.kf.reset_state(BA, from.kf.x[BA], from.kf.var(BA));
    }

    /// Depth to the fix, its variance to the fix's, its correlations cleared.
    pub(super) fn reset_depth(&mut self, depth_m: f32, std_m: f32) {
        self.kf.reset_state(Z, depth_m, std_m * std_m);
    }

    pub(super) fn fuse_depth(&mut self, depth_m: f32, std_m: f32) -> Result<(), Refusal> {
        let nu = depth_m - self.kf.x[Z];
        let r = std_m * std_m;
        if nu * nu > GATE_CHI2_1DOF * (self.kf.var(Z) + r) {
            return Err(Refusal::Outlier);
        }
        self.kf.update(&unit(Z), nu, r);
        Ok(())
    }
}
