//! The depth limit (`DEPTH_LIMIT_M`): targets deeper than it are refused, a warning at 90 %,
//! and in every mode the vertical command is capped by a braking envelope so the vehicle
//! stops at the limit: the largest downward heave allowed is
//! `k_p * (limit - depth) - k_d * descent rate`, which turns into an upward push under the
//! limit. The pilot's and the laws' heave are both capped; a command upward is never changed.

/// Fraction of the limit at which the warning starts.
pub const WARNING_FRACTION: f32 = 0.9;

/// Distance over which the envelope goes from full downward thrust to none, m: the cap's
/// stiffness is the vertical thruster's largest force over this distance.
pub const BRAKE_DISTANCE_M: f32 = 1.0;

/// Descent rate at which the envelope allows no downward thrust at the limit's distance
/// [`BRAKE_DISTANCE_M`], m/s: the damping is the largest force over this rate.
pub const BRAKE_RATE_M_S: f32 = 0.25;

/// A depth limit in force.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthLimit {
    limit_m: f32,
}

impl DepthLimit {
    /// None when `limit_m` is off (0, negative or not finite).
    pub fn new(limit_m: f32) -> Option<Self> {
        (limit_m.is_finite() && limit_m > 0.0).then_some(Self { limit_m })
    }

    /// The limit, m.
    pub fn limit_m(&self) -> f32 {
        self.limit_m
    }

    /// At or below 90 % of the limit.
    pub fn warning(&self, depth_m: f32) -> bool {
        depth_m >= WARNING_FRACTION * self.limit_m
    }

    /// A target at `depth_m` is refused (deeper than the limit).
    pub fn refuses(&self, depth_m: f32) -> bool {
        !depth_m.is_finite() || depth_m > self.limit_m
    }

    /// The largest downward heave force allowed at `depth_m` descending at `descent_m_s`
    /// (positive down), for a vertical thruster of `max_heave_n`.
    pub fn heave_cap_n(&self, depth_m: f32, descent_m_s: f32, max_heave_n: f32) -> f32 {
        let k_p = max_heave_n / BRAKE_DISTANCE_M;
        let k_d = max_heave_n / BRAKE_RATE_M_S;
        k_p * (self.limit_m - depth_m) - k_d * descent_m_s
    }

    /// `heave_n` (positive down) capped by the envelope; unchanged when within it.
    pub fn cap(&self, heave_n: f32, depth_m: f32, descent_m_s: f32, max_heave_n: f32) -> f32 {
        let cap = self.heave_cap_n(depth_m, descent_m_s, max_heave_n);
        if cap.is_finite() {
            heave_n.min(cap)
        } else {
            heave_n
        }
    }
}
