//! Thrusters: first-order spin-up lag and per-thruster limits.
//!
//! Each thruster's delivered force `f` follows its (held) command `c` with
//! `f_dot = (c - f) / T`. Over one plant step the command is constant, so the lag is solved
//! exactly: `f(t0 + s) = c + (f(t0) - c) exp(-s / T)`; the RK4 stages read the force at their
//! own time from this closed form. With `saturate`, the command is first clamped to
//! `[-thrust_max_reverse_n, +thrust_max_forward_n]`, so the delivered force never leaves the
//! limits either.

use controller_core::params::VehicleParams;

/// The three thrusters `[F1x, F2x, F3z]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Thrusters {
    /// Delivered forces now.
    pub force_n: [f64; 3],
    /// Lag time constant `T` (0 = no lag).
    pub time_constant_s: f64,
    /// Largest forward thrust.
    pub max_forward_n: f64,
    /// Largest reverse thrust (magnitude).
    pub max_reverse_n: f64,
    /// Whether the limits apply.
    pub saturate: bool,
}

/// The held command over one step, ready to be evaluated at any time inside the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LagSegment {
    start_n: [f64; 3],
    cmd_n: [f64; 3],
    time_constant_s: f64,
}

impl LagSegment {
    /// Delivered forces `s` seconds after the start of the step.
    #[inline]
    pub fn at(&self, s: f64) -> [f64; 3] {
        if self.time_constant_s <= 0.0 {
            return self.cmd_n;
        }
        let e = (-s / self.time_constant_s).exp();
        [
            self.cmd_n[0] + (self.start_n[0] - self.cmd_n[0]) * e,
            self.cmd_n[1] + (self.start_n[1] - self.cmd_n[1]) * e,
            self.cmd_n[2] + (self.start_n[2] - self.cmd_n[2]) * e,
        ]
    }
}

impl Thrusters {
    /// At rest, with the vehicle's lag and limits.
    pub fn new(params: &VehicleParams, saturate: bool) -> Self {
        Self {
            force_n: [0.0; 3],
            time_constant_s: f64::from(params.thruster_time_constant_s),
            max_forward_n: f64::from(params.thrust_max_forward_n),
            max_reverse_n: f64::from(params.thrust_max_reverse_n),
            saturate,
        }
    }

    /// Clamp a command to the limits when `saturate` (NaN becomes 0).
    #[inline]
    pub fn limit(&self, cmd_n: f64) -> f64 {
        if cmd_n.is_nan() {
            return 0.0;
        }
        if self.saturate {
            cmd_n.clamp(-self.max_reverse_n, self.max_forward_n)
        } else {
            cmd_n
        }
    }

    /// The lag segment for one step with the held command `cmd_n`.
    pub fn segment(&self, cmd_n: [f64; 3]) -> LagSegment {
        LagSegment {
            start_n: self.force_n,
            cmd_n: [
                self.limit(cmd_n[0]),
                self.limit(cmd_n[1]),
                self.limit(cmd_n[2]),
            ],
            time_constant_s: self.time_constant_s,
        }
    }

    /// Finish a step of `dt_s` on `seg`.
    pub fn advance(&mut self, seg: &LagSegment, dt_s: f64) {
        self.force_n = seg.at(dt_s);
    }
}
