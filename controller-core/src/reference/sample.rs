//! A reference sample: the reference point's position and its time derivatives, the value
//! every reference kind produces and every law reads.

use serde::{Deserialize, Serialize};

/// Position and derivatives of the reference point at one instant (inertial, z down).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct RefSample {
    /// Time of the sample.
    pub t_s: f32,
    /// Position `[x, y, z]`.
    pub pos_m: [f32; 3],
    /// Velocity.
    pub vel_m_s: [f32; 3],
    /// Acceleration.
    pub acc_m_s2: [f32; 3],
    /// Jerk.
    pub jerk_m_s3: [f32; 3],
}

/// Scalar value with its first three derivatives.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Deriv3 {
    /// Value.
    pub p: f32,
    /// First derivative.
    pub dp: f32,
    /// Second derivative.
    pub ddp: f32,
    /// Third derivative.
    pub dddp: f32,
}
