//! Why the estimator refuses a measurement, and the chi-square gates its updates pass.

use serde::{Deserialize, Serialize};

/// Chi-square gate of a 1-D innovation (99.9 %).
pub const GATE_CHI2_1DOF: f32 = 10.83;
/// Chi-square gate of a 2-D innovation (99.9 %).
pub const GATE_CHI2_2DOF: f32 = 13.82;

/// Why a measurement was not fused. The estimator's state is unchanged.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Refusal {
    /// A value is NaN or infinite.
    NonFinite,
    /// A value is outside what the vehicle or the sensor can produce.
    OutOfRange,
    /// The standard deviation is not positive.
    BadAccuracy,
    /// The time of validity is after the estimator's time.
    InFuture,
    /// The time of validity is older than the history (or, for the IMU, goes backwards).
    TooOld,
    /// The IMU interval is longer than [`MAX_PREDICT_DT_S`](super::MAX_PREDICT_DT_S).
    ImuGap,
    /// The innovation failed the chi-square gate: an outlier.
    Outlier,
}
