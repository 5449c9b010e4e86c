//! Thrust allocation and the thrust <-> PWM pulse-width map.
//!
//! Thruster layout (assumed, `MODEL_NOTES` section 2): `F1x` and `F2x` parallel to body x at
//! `y = -l` (port) and `y = +l` (starboard), through the CB height; `F3z` on the body z axis.
//! So `tau_1 = F1x + F2x`, `tau_2 = l (F1x - F2x)`, `tau_3 = F3z` (paper, after eq. (2)).
//!
//! Saturation priority: the yaw moment first (it is clamped to what the pair can make), then
//! the surge force is clamped into what is left, so the heading loop keeps its authority and
//! the horizontal pair never exceeds its limits. Heave is independent. The achieved forces are
//! returned so the laws can stop integrating against a saturated actuator.

use crate::math::{clamp, clamp_nan_safe, min, sqrt};
use crate::params::Vehicle;
use crate::state::BodyForces;
use serde::{Deserialize, Serialize};

/// Per-thruster limits and the horizontal lever arm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ThrusterLimits {
    /// Largest forward thrust of one thruster.
    pub max_forward_n: f32,
    /// Largest reverse thrust of one thruster (magnitude).
    pub max_reverse_n: f32,
    /// Lateral lever arm `l` of the horizontal pair.
    pub lever_arm_m: f32,
}

impl ThrusterLimits {
    /// The limits of a validated vehicle.
    pub fn of(vehicle: &Vehicle) -> Self {
        let p = vehicle.params();
        Self {
            max_forward_n: p.thrust_max_forward_n,
            max_reverse_n: p.thrust_max_reverse_n,
            lever_arm_m: p.thruster_lever_arm_m,
        }
    }

    /// Clamp one thruster force into its limits (NaN goes to zero).
    #[inline]
    pub fn clamp(&self, thrust_n: f32) -> f32 {
        clamp_nan_safe(thrust_n, -self.max_reverse_n, self.max_forward_n)
    }
}

/// The result of [`allocate`].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Allocation {
    /// `[F1x, F2x, F3z]`, each within its limits.
    pub thrust_n: [f32; 3],
    /// The generalized forces these thrusts make.
    pub achieved: BodyForces,
    /// True when the request had to be clamped.
    pub saturated: bool,
}

/// Map generalized forces to the three thrusters with the saturation priority above.
/// Non-finite requests are treated as zero.
pub fn allocate(request: &BodyForces, limits: &ThrusterLimits) -> Allocation {
    let fwd = limits.max_forward_n;
    let rev = limits.max_reverse_n;
    let l = limits.lever_arm_m;
    let finite_or_zero = |x: f32| if x.is_finite() { x } else { 0.0 };
    let (yaw_req, s_req, h_req, finite) = (
        finite_or_zero(request.yaw_n_m),
        finite_or_zero(request.surge_n),
        finite_or_zero(request.heave_n),
        request.is_finite(),
    );
    // Differential thrust d = F1 - F2, limited to what the pair can make.
    let d_req = yaw_req / l;
    let d_max = fwd + rev;
    // Strictly inside: the clamp would return `d_req` (one comparison).
    let d = if d_req.abs() < d_max {
        d_req
    } else {
        clamp(d_req, -d_max, d_max)
    };
    // Common thrust s = F1 + F2 with both F1 = (s + d)/2 and F2 = (s - d)/2 in [-rev, fwd].
    let s = clamp(s_req, -2.0 * rev + d.abs(), 2.0 * fwd - d.abs());
    // `s`, `d` and `h_req` are finite here, so the plain clamp (no NaN test) gives what
    // `limits.clamp` would.
    let f1 = clamp(0.5 * (s + d), -rev, fwd);
    let f2 = clamp(0.5 * (s - d), -rev, fwd);
    let f3 = clamp(h_req, -rev, fwd);
    let achieved = BodyForces {
        surge_n: f1 + f2,
        yaw_n_m: l * (f1 - f2),
        heave_n: f3,
    };
    let tol = 1e-4;
    // Unclamped values equal their request (all finite here): one comparison then.
    let off = |x: f32, r: f32| x != r && (x - r).abs() > tol * (1.0 + r.abs());
    let saturated = off(d, d_req) || off(s, s_req) || off(f3, h_req) || !finite;
    Allocation {
        thrust_n: [f1, f2, f3],
        achieved,
        saturated,
    }
}

/// Map between thrust and the ESC pulse width.
///
/// Pulse widths from `min_us` to `max_us`, `neutral_us` at rest, a symmetric deadband of
/// `deadband_us` around neutral in which the ESC gives no thrust. Outside the deadband, with
/// `x` the normalized distance from the deadband edge to the end of travel (0..1), thrust is
/// `F_max (k x + (1 - k) x^2)`, `k = linear_fraction`: a propeller's thrust grows roughly
/// with the square of its speed. `F_max` is the forward or reverse limit, so the curve is
/// asymmetric like a real thruster's.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PwmMap {
    /// Shortest pulse (full reverse).
    pub min_us: f32,
    /// Neutral pulse.
    pub neutral_us: f32,
    /// Longest pulse (full forward).
    pub max_us: f32,
    /// Half-width of the deadband around neutral.
    pub deadband_us: f32,
    /// Linear share `k` of the thrust curve, in [0, 1].
    pub linear_fraction: f32,
    /// Thrust at `max_us`.
    pub max_forward_n: f32,
    /// Thrust magnitude at `min_us`.
    pub max_reverse_n: f32,
}

/// Constants of the inverse thrust curve (see [`PwmMap::pulse_us`]).
#[derive(Clone, Copy)]
struct CurveInv {
    k: f32,
    k2: f32,
    four_a: f32,
    two_a: f32,
    /// False for a (nearly) linear curve, `1 - k <= 1e-6`.
    quadratic: bool,
}

// The ESC's constants live with the pulse curve they bound (`params`, which the vehicle's
// checks read without a module circle); the allocation's callers find them here too.
pub use crate::params::{ESC_MAX_US, ESC_MIN_US, ESC_NEUTRAL_US};

impl PwmMap {
    /// The vehicle's pulse curve and thrust limits.
    pub fn for_vehicle(vehicle: &Vehicle) -> Self {
        let p = vehicle.params();
        Self {
            min_us: p.pulse.min_us,
            neutral_us: p.pulse.neutral_us,
            max_us: p.pulse.max_us,
            deadband_us: p.pulse.deadband_us,
            linear_fraction: p.pulse.linear_fraction,
            max_forward_n: p.thrust_max_forward_n,
            max_reverse_n: p.thrust_max_reverse_n,
        }
    }

    fn curve(&self, x: f32) -> f32 {
        let k = self.linear_fraction;
        k * x + (1.0 - k) * x * x
    }

    /// The constants of the inverse curve, computed once per call of [`Self::pulse_us`] or
    /// once for all three pulses in [`Self::pulses_us`].
    #[inline(always)]
    fn curve_inv_consts(&self) -> CurveInv {
        let k = self.linear_fraction;
        let a = 1.0 - k;
        CurveInv {
            k,
            k2: k * k,
            four_a: 4.0 * a,
            two_a: 2.0 * a,
            quadratic: a > 1e-6,
        }
    }

    /// Pulse width for one thrust with the curve constants `c` (see [`Self::pulse_us`]).
    #[inline(always)]
    fn pulse_with(&self, c: &CurveInv, thrust_n: f32) -> f32 {
        // Solve (1 - k) x^2 + k x - y = 0 for x >= 0.
        let x_of = |y: f32| {
            if c.quadratic {
                (-c.k + sqrt(c.k2 + c.four_a * y)) / c.two_a
            } else {
                y
            }
        };
        // Zero, NaN and the infinities give neutral.
        if !thrust_n.is_finite() || thrust_n == 0.0 {
            return self.neutral_us;
        }
        if thrust_n > 0.0 {
            let y = min(thrust_n / self.max_forward_n, 1.0);
            let lo = self.neutral_us + self.deadband_us;
            lo + x_of(y) * (self.max_us - lo)
        } else {
            let y = min(-thrust_n / self.max_reverse_n, 1.0);
            let hi = self.neutral_us - self.deadband_us;
            hi - x_of(y) * (hi - self.min_us)
        }
    }

    /// Pulse width for a thrust request. The thrust is clamped to the limits first; zero
    /// thrust gives exactly `neutral_us`. NaN gives neutral.
    pub fn pulse_us(&self, thrust_n: f32) -> f32 {
        self.pulse_with(&self.curve_inv_consts(), thrust_n)
    }

    /// [`Self::pulse_us`] of three thrusts, the curve constants computed once.
    pub fn pulses_us(&self, thrust_n: [f32; 3]) -> [f32; 3] {
        let c = self.curve_inv_consts();
        let [t1, t2, t3] = thrust_n;
        [
            self.pulse_with(&c, t1),
            self.pulse_with(&c, t2),
            self.pulse_with(&c, t3),
        ]
    }

    /// Thrust the ESC makes for a pulse width (the plant's view). Pulses outside
    /// `[min_us, max_us]` are clamped; inside the deadband the thrust is zero.
    pub fn thrust_n(&self, pulse_us: f32) -> f32 {
        let pw = clamp_nan_safe(pulse_us, self.min_us, self.max_us);
        let pw = if pulse_us.is_nan() {
            self.neutral_us
        } else {
            pw
        };
        let lo = self.neutral_us + self.deadband_us;
        let hi = self.neutral_us - self.deadband_us;
        if pw > lo {
            self.max_forward_n * self.curve((pw - lo) / (self.max_us - lo))
        } else if pw < hi {
            -self.max_reverse_n * self.curve((hi - pw) / (hi - self.min_us))
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn limits() -> ThrusterLimits {
        ThrusterLimits::of(&Vehicle::observer())
    }

    #[test]
    fn unsaturated_request_is_exact() {
        let r = BodyForces {
            surge_n: 5.0,
            yaw_n_m: 0.6,
            heave_n: -3.0,
        };
        let a = allocate(&r, &limits());
        assert!(!a.saturated);
        assert!((a.achieved.surge_n - 5.0).abs() < 1e-5);
        assert!((a.achieved.yaw_n_m - 0.6).abs() < 1e-5);
        assert_eq!(a.thrust_n[2], -3.0);
        assert!((a.thrust_n[0] - 5.0).abs() < 1e-5 && a.thrust_n[1].abs() < 1e-5);
    }

    #[test]
    fn yaw_has_priority_over_surge() {
        // 100 N m is far beyond the pair (l (20 + 15) = 4.2 N m): full differential, no surge.
        let a = allocate(
            &BodyForces {
                surge_n: 30.0,
                yaw_n_m: 100.0,
                heave_n: 0.0,
            },
            &limits(),
        );
        assert!(a.saturated);
        assert!((a.achieved.yaw_n_m - 4.2).abs() < 1e-4);
        assert!((a.thrust_n[0] - 20.0).abs() < 1e-5 && (a.thrust_n[1] + 15.0).abs() < 1e-5);
    }

    #[test]
    fn nan_request_gives_zero_thrust() {
        let a = allocate(
            &BodyForces {
                surge_n: f32::NAN,
                yaw_n_m: f32::INFINITY,
                heave_n: f32::NAN,
            },
            &limits(),
        );
        assert_eq!(a.thrust_n, [0.0; 3]);
        assert!(a.saturated);
    }

    #[test]
    fn huge_finite_requests_whose_sum_overflows_are_clamped_not_zeroed() {
        // The sum of the three overflows: the per-value path, which keeps them (finite).
        let a = allocate(
            &BodyForces {
                surge_n: f32::MAX,
                yaw_n_m: f32::MAX,
                heave_n: f32::MAX,
            },
            &limits(),
        );
        assert!(a.saturated);
        assert_eq!(a.thrust_n, [20.0, -15.0, 20.0]);
        let a = allocate(
            &BodyForces {
                surge_n: 1.0,
                yaw_n_m: f32::NAN,
                heave_n: f32::MAX,
            },
            &limits(),
        );
        assert!(a.saturated);
        assert_eq!(a.thrust_n, [0.5, 0.5, 20.0]);
    }

    proptest! {
        #[test]
        fn thrusts_always_within_limits(s in -200.0f32..200.0, y in -50.0f32..50.0, h in -200.0f32..200.0) {
            let l = limits();
            let a = allocate(&BodyForces { surge_n: s, yaw_n_m: y, heave_n: h }, &l);
            for f in a.thrust_n {
                prop_assert!(f <= l.max_forward_n && f >= -l.max_reverse_n);
            }
            // The achieved yaw has the requested sign and never exceeds it.
            prop_assert!(a.achieved.yaw_n_m * y >= 0.0);
            prop_assert!(a.achieved.yaw_n_m.abs() <= y.abs() + 1e-4);
        }

        #[test]
        fn pwm_round_trip(t in -15.0f32..20.0) {
            let m = PwmMap::for_vehicle(&Vehicle::observer());
            let pw = m.pulse_us(t);
            prop_assert!((1100.0..=1900.0).contains(&pw));
            prop_assert!((m.thrust_n(pw) - t).abs() < 1e-3 * (1.0 + t.abs()));
        }

        #[test]
        fn deadband_gives_zero(pw in 1475.0f32..=1525.0) {
            let m = PwmMap::for_vehicle(&Vehicle::observer());
            prop_assert_eq!(m.thrust_n(pw), 0.0);
        }
    }

    #[test]
    fn pulses_us_matches_pulse_us() {
        let m = PwmMap::for_vehicle(&Vehicle::observer());
        for i in -400..=400 {
            let t = i as f32 * 0.06;
            let p = m.pulses_us([t, -t, 0.5 * t]);
            assert_eq!(p, [m.pulse_us(t), m.pulse_us(-t), m.pulse_us(0.5 * t)]);
        }
        // The same bits as the two-branch formula this replaced.
        let inv = |y: f32| (-0.25 + sqrt(0.25 * 0.25 + 4.0 * 0.75 * y)) / (2.0 * 0.75);
        for i in -3000..=3000 {
            let t = i as f32 * 0.007_3;
            let expect = if t == 0.0 {
                1500.0
            } else if t > 0.0 {
                1525.0 + inv((t / m.max_forward_n).min(1.0)) * (1900.0 - 1525.0)
            } else {
                1475.0 - inv((-t / m.max_reverse_n).min(1.0)) * (1475.0 - 1100.0)
            };
            assert_eq!(m.pulse_us(t).to_bits(), expect.to_bits(), "{t}");
        }
        let odd = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY];
        assert_eq!(m.pulses_us(odd), [1500.0; 3]);
        assert_eq!(m.pulse_us(-0.0), 1500.0);
        assert_eq!(m.pulse_us(-f32::NAN), 1500.0);
        assert!(m.pulse_us(f32::MAX) > 1899.9 && m.pulse_us(f32::MIN) < 1100.1);
        assert!(m.pulse_us(1e-45) > 1500.0 && m.pulse_us(-1e-45) < 1500.0);
    }

    #[test]
    fn pwm_ends_and_neutral() {
        let m = PwmMap::for_vehicle(&Vehicle::observer());
        assert_eq!(m.pulse_us(0.0), 1500.0);
        assert_eq!(m.pulse_us(f32::NAN), 1500.0);
        assert!((m.pulse_us(20.0) - 1900.0).abs() < 1e-3);
        assert!((m.pulse_us(-15.0) - 1100.0).abs() < 1e-3);
        assert!((m.pulse_us(1e6) - 1900.0).abs() < 1e-3);
        assert!((m.thrust_n(1900.0) - 20.0).abs() < 1e-4);
        assert!((m.thrust_n(1100.0) + 15.0).abs() < 1e-4);
        assert!((m.thrust_n(2500.0) - 20.0).abs() < 1e-4);
        // Just outside the deadband the thrust is small and has the right sign.
        assert!(m.thrust_n(1530.0) > 0.0 && m.thrust_n(1530.0) < 0.2);
        assert!(m.thrust_n(1470.0) < 0.0);
    }
}
