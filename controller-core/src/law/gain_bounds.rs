//! The range of every gain a law stays stable with at its control period.
//!
//! The tracking laws cancel the modelled dynamics of each axis (feedback linearization), so
//! what the gains act on is a double integrator per axis (`e'' = a`), the acceleration held
//! for one control period `T` (zero-order hold): `a = -k_d e' - k_p e - k_i int(e)`. The
//! ranges below keep that discrete loop stable, and its velocity loop free of ringing, with
//! one whole period of delay between the measurement and the force (the topside layout's
//! link; on board, the estimator's step), at `T` = [`CONTROL_PERIOD_S`] (20 ms, the slower of
//! the two layouts; the on-board 10 ms is inside every range). Derivation and numbers:
//! `docs/safety.md`, "Gain bounds".
//!
//! - A rate gain (1/s: `k_d`, the paper laws' first-order gains, the current observer's
//!   bandwidth) at most `1 / (4 T)` = 12.5/s: the velocity loop with one period of delay,
//!   `z^2 - z + k_d T = 0`, has real poles up to `k_d T = 1/4` and is unstable from
//!   `k_d T = 1` (sign flips every period: bang-bang at the thrusters' limits).
//! - A position gain (1/s^2) at most `(1 / (4 T))^2` = 156/s^2 (natural frequency at most
//!   the velocity loop's bound).
//! - The three together: `k_d >= 2 k_p T + 4 k_i / k_p`. The discrete PD loop on a double
//!   integrator is stable only for `k_d > k_p T / 2` (Jury), the PID loop only for
//!   `k_d > k_i / k_p` (Routh); each is kept with a margin of 4, and the two are added so
//!   that the damping the period's delay takes (about `1.5 k_p T`) and the integral's
//!   (`k_i / k_p`) leave some over. Each gain's range is this read given the other two.
//! - An integral gain (1/s^3) at most `(1 / (4 T))^3 / 4` = 488/s^3.
//! - Every gain at least what acts within [`SLOWEST_LOOP_S`] (10 s): 0.1/s, 0.01/s^2,
//!   0.001/s^3. A smaller one is a law switched off (a position gain of 1e-30 leaves the axis
//!   drifting; a rate gain of 1e-30 with an integral leaves it unstable: `k_i > k_p k_d`).
//!
//! The nonlinear gains (the paper laws' cubic and quartic terms) and the lengths and limits
//! (`hand_m`, `error_limit_m`, ...) keep their own checks and the controller's `MAX_GAIN`.

use crate::error::Error;
use crate::law::paper_xy::PaperXyGains;
use crate::law::paper_xz::PaperXzGains;
use crate::law::tracking::TrackingGains;
use crate::math::sqrt;

/// The control period the ranges hold at (s): the topside layout's 20 ms.
pub const CONTROL_PERIOD_S: f32 = 0.02;
/// Longest time scale of a loop that still acts (s).
pub const SLOWEST_LOOP_S: f32 = 10.0;
/// Largest rate gain (1/s): `1 / (4 T)`.
pub const RATE_GAIN_MAX: f32 = 1.0 / (4.0 * CONTROL_PERIOD_S);
/// Largest position gain (1/s^2): `(1 / (4 T))^2`.
pub const POSITION_GAIN_MAX: f32 = RATE_GAIN_MAX * RATE_GAIN_MAX;
/// Largest integral gain (1/s^3): `k_p k_d / 4` at the two largest.
pub const INTEGRAL_GAIN_MAX: f32 = POSITION_GAIN_MAX * RATE_GAIN_MAX / 4.0;
/// Smallest rate gain (1/s): `1 / SLOWEST_LOOP_S`.
pub const RATE_GAIN_MIN: f32 = 1.0 / SLOWEST_LOOP_S;
/// Smallest position gain (1/s^2).
pub const POSITION_GAIN_MIN: f32 = RATE_GAIN_MIN * RATE_GAIN_MIN;
/// Smallest integral gain (1/s^3).
pub const INTEGRAL_GAIN_MIN: f32 = POSITION_GAIN_MIN * RATE_GAIN_MIN;

/// A value and the range it must be in; `Err` names both.
fn within(name: &'static str, value: f32, min: f32, max: f32) -> Result<(), Error> {
    if (min..=max).contains(&value) {
        Ok(())
    } else {
        Err(Error::GainRange {
            name,
            value,
            min,
            max,
        })
    }
}

/// One axis's loop: its gains' names and values (no integral for a PD loop).
struct Axis {
    kp: (&'static str, f32),
    kd: (&'static str, f32),
    ki: Option<(&'static str, f32)>,
}

impl Axis {
    /// Each gain within its own range, then each within the range the other two leave it
    /// (the first out of a non-empty range is named).
    fn check(&self) -> Result<(), Error> {
        let ((np, kp), (nd, kd)) = (self.kp, self.kd);
        within(np, kp, POSITION_GAIN_MIN, POSITION_GAIN_MAX)?;
        within(nd, kd, RATE_GAIN_MIN, RATE_GAIN_MAX)?;
        if let Some((ni, ki)) = self.ki {
            within(ni, ki, INTEGRAL_GAIN_MIN, INTEGRAL_GAIN_MAX)?;
        }
        let t = CONTROL_PERIOD_S;
        let ki = self.ki.map_or(0.0, |(_, ki)| ki);
        // k_d >= 2 k_p T + 4 k_i / k_p, read for each gain given the other two.
        let kd_range = (
            RATE_GAIN_MIN.max(2.0 * kp * t + 4.0 * ki / kp),
            RATE_GAIN_MAX,
        );
        // 2 T k_p^2 - k_d k_p + 4 k_i <= 0 between its roots (none: an empty range).
        let disc = kd * kd - 32.0 * t * ki;
        let kp_range = if disc >= 0.0 {
            let root = sqrt(disc);
            (
                POSITION_GAIN_MIN.max((kd - root) / (4.0 * t)),
                POSITION_GAIN_MAX.min((kd + root) / (4.0 * t)),
            )
        } else {
            (POSITION_GAIN_MAX, POSITION_GAIN_MIN)
        };
        let ki_max = INTEGRAL_GAIN_MAX.min(kp * (kd - 2.0 * kp * t) / 4.0);
        let mut ranges = [
            (nd, kd, kd_range),
            (np, kp, kp_range),
            ("", 0.0, (0.0, 0.0)),
        ];
        if let (Some((ni, ki)), Some(r)) = (self.ki, ranges.get_mut(2)) {
            *r = (ni, ki, (INTEGRAL_GAIN_MIN, ki_max));
        }
        let mut first = None;
        for (name, v, (lo, hi)) in ranges {
            if name.is_empty() {
                continue;
            }
            match within(name, v, lo, hi) {
                Err(e) if lo <= hi => return Err(e),
                Err(e) => {
                    first.get_or_insert(e);
                }
                Ok(()) => {}
            }
        }
        first.map_or(Ok(()), Err)
    }
}

/// Check the tracking laws' gains: the XY, XZ (x1) and depth PID loops, the pitch and yaw
/// PD loops, and the current observer's bandwidth (0 turns it off).
pub fn check_tracking(g: &TrackingGains) -> Result<(), Error> {
    let pid = |p: &'static str, kp, d: &'static str, kd, i: &'static str, ki| Axis {
        kp: (p, kp),
        kd: (d, kd),
        ki: Some((i, ki)),
    };
    let pd = |p: &'static str, kp, d: &'static str, kd| Axis {
        kp: (p, kp),
        kd: (d, kd),
        ki: None,
    };
    for axis in [
        pid("xy_kp", g.xy_kp, "xy_kd", g.xy_kd, "xy_ki", g.xy_ki),
        pid("xz_kp", g.xz_kp, "xz_kd", g.xz_kd, "xz_ki", g.xz_ki),
        pid(
            "depth_kp", g.depth_kp, "depth_kd", g.depth_kd, "depth_ki", g.depth_ki,
        ),
        pd("pitch_kp", g.pitch_kp, "pitch_kd", g.pitch_kd),
        pd("yaw_kp", g.yaw_kp, "yaw_kd", g.yaw_kd),
    ] {
        axis.check()?;
    }
    within(
        "current_observer_rad_s",
        g.current_observer_rad_s,
        0.0,
        RATE_GAIN_MAX,
    )
}

/// Check the first-order gains of the paper's laws (the rate each backstepping error decays
/// at): within the rate range.
pub fn check_paper(xz: &PaperXzGains, xy: &PaperXyGains) -> Result<(), Error> {
    for (name, v) in [
        ("paper_xz.k", xz.k),
        ("paper_xz.c1w", xz.c1w),
        ("paper_xz.c1q", xz.c1q),
        ("paper_xz.cq", xz.cq),
        ("paper_xy.k", xy.k),
        ("paper_xy.c1u", xy.c1u),
        ("paper_xy.c1r", xy.c1r),
        ("paper_xy.cr", xy.cr),
    ] {
        within(name, v, RATE_GAIN_MIN, RATE_GAIN_MAX)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests;
