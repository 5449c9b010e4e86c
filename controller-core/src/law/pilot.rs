//! Pilot-assisted flying (ArduSub's STABILIZE and ALT_HOLD): the pilot's sticks command the
//! forces, and an axis whose stick is centred is held where the pilot left it.
//!
//! - **Heading hold** (both modes): with the yaw stick centred the heading at release is held
//!   by a PD on the yaw acceleration through the yaw model of eq. (34):
//!   `r_dot_c = -k_p wrap(psi - psi_h) - k_d r`, `tau_2 = m_33 (r_dot_c + gamma1 r +
//!   gamma2 |r| r + gamma3 u v)`. Moving the stick flies the yaw moment open loop and releases
//!   the hold; centring it captures the heading of that instant.
//! - **Depth hold** (ALT_HOLD): with the heave stick centred the depth at release is held by
//!   the tracking laws' depth PID with feedforward ([`super::tracking::depth`]), whose integral
//!   takes up the buoyancy offset.
//! - Surge always comes from its stick (the Observer has no sway thruster: there is nothing to
//!   hold sideways).
//!
//! A stick is centred when its magnitude is below [`STICK_DEADBAND`]. As in ArduSub, a target
//! is captured once the motion on that axis has stopped (|r| < [`CAPTURE_RATE_RAD_S`],
//! |z_dot| < [`CAPTURE_SPEED_M_S`]): until then the hold only brakes (its target moves with
//! the vehicle), so releasing a stick at speed does not overshoot and come back.

use super::tracking::{depth, TrackingGains, TrackingState};
use crate::alloc::ThrusterLimits;
use crate::math::{sin_cos, wrap_angle};
use crate::params::Vehicle;
use crate::reference::RefSample;
use crate::state::{BodyForces, NavState, TrackingErrors};

/// Below this magnitude a stick counts as centred (ArduSub's 5 % deadzone).
pub const STICK_DEADBAND: f32 = 0.05;
/// A heading is captured once the yaw rate is below this (rad/s).
pub const CAPTURE_RATE_RAD_S: f32 = 0.05;
/// A depth is captured once the vertical speed is below this (m/s).
pub const CAPTURE_SPEED_M_S: f32 = 0.05;
/// Heading hold's natural frequency squared (1/s^2): 0.8 rad/s, critically damped.
pub const HEADING_KP_1_S2: f32 = 0.64;
/// Heading hold's damping (1/s).
pub const HEADING_KD_1_S: f32 = 1.6;

/// The pilot's sticks, each a fraction in [-1, 1] of the largest force or moment that way.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Sticks {
    /// Surge (forward positive).
    pub surge: f32,
    /// Yaw (clockwise positive).
    pub yaw: f32,
    /// Heave (down positive).
    pub heave: f32,
}

/// What the pilot modes hold: the targets captured when a stick was centred.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PilotHold {
    /// Heading held while the yaw stick is centred (rad).
    pub yaw_rad: Option<f32>,
    /// Depth held while the heave stick is centred (m), in ALT_HOLD.
    pub depth_m: Option<f32>,
}

/// The forces of one pilot-assisted step, and the errors of the held axes (zero otherwise).
/// `Controller::pilot_step` is the entry point; the arguments are its parts.
#[allow(clippy::too_many_arguments)]
pub fn step(
    v: &Vehicle,
    g: &TrackingGains,
    st: &mut TrackingState,
    hold: &mut PilotHold,
    lim: &ThrusterLimits,
    nav: &NavState,
    sticks: &Sticks,
    hold_depth: bool,
    dt_s: f32,
) -> (BodyForces, TrackingErrors) {
    let centred = |s: f32| s.abs() < STICK_DEADBAND;
    // The largest force each way (the thrusters are asymmetric, so it depends on the sign).
    let one_way = |x: f32| {
        if x >= 0.0 {
            lim.max_forward_n
        } else {
            lim.max_reverse_n
        }
    };
    let mut errors = TrackingErrors::default();
    let surge_n = sticks.surge * 2.0 * one_way(sticks.surge);

    let yaw_n_m = if centred(sticks.yaw) {
        let psi_h = match hold.yaw_rad {
            Some(h) => h,
            None if nav.r_rad_s.abs() < CAPTURE_RATE_RAD_S => *hold.yaw_rad.insert(nav.yaw_rad),
            None => nav.yaw_rad,
        };
        let c = &v.xy;
        let (u, vv, r) = (nav.u_m_s, nav.v_m_s, nav.r_rad_s);
        let e = wrap_angle(nav.yaw_rad - psi_h);
        errors.yaw_rad = e;
        let r_dot_c = -HEADING_KP_1_S2 * e - HEADING_KD_1_S * r;
        c.m33 * (r_dot_c + c.gamma1 * r + c.gamma2 * r.abs() * r + c.gamma3 * u * vv)
    } else {
        hold.yaw_rad = None;
        sticks.yaw * lim.lever_arm_m * (lim.max_forward_n + lim.max_reverse_n)
    };

    let heave_n = if hold_depth && centred(sticks.heave) {
        let (sth, cth) = sin_cos(nav.pitch_rad);
        let (sf, cf) = sin_cos(nav.roll_rad);
        let z_dot = -sth * nav.u_m_s + cth * sf * nav.v_m_s + cth * cf * nav.w_m_s;
        let z_h = match hold.depth_m {
            Some(h) => h,
            None if z_dot.abs() < CAPTURE_SPEED_M_S => *hold.depth_m.insert(nav.z_m),
            None => nav.z_m,
        };
        let target = RefSample {
            pos_m: [nav.x_m, nav.y_m, z_h],
            ..RefSample::default()
        };
        let (f, ez) = depth(v, g, st, nav, &target, dt_s);
        errors.z_m = ez;
        f
    } else {
        hold.depth_m = None;
        sticks.heave * one_way(sticks.heave)
    };

    (
        BodyForces {
            surge_n,
            yaw_n_m,
            heave_n,
        },
        errors,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::controller::{Controller, Gains};

    fn controller() -> Controller {
        Controller::new(Vehicle::observer(), Gains::default()).unwrap()
    }

    #[test]
    fn a_centred_stick_holds_the_heading_and_depth_of_release() {
        let mut c = controller();
        let centred = Sticks::default();
        let at = |yaw_rad, r_rad_s, z_m| NavState {
            yaw_rad,
            r_rad_s,
            z_m,
            ..NavState::default()
        };
        // First step captures (yaw 0.3, depth 2): nothing to correct yet but the rate.
        let o = c.pilot_step(&at(0.3, 0.0, 2.0), &centred, true, 0.02);
        assert!(o.requested.yaw_n_m.abs() < 1e-3 && o.errors.yaw_rad == 0.0);
        // Turned past it and deeper: a moment back, a force up.
        let o = c.pilot_step(&at(0.5, 0.0, 2.3), &centred, true, 0.02);
        let m33 = c.vehicle().xy.m33;
        let want = -m33 * HEADING_KP_1_S2 * 0.2;
        assert!(
            (o.requested.yaw_n_m - want).abs() < 1e-6,
            "{:?}",
            o.requested
        );
        assert!(o.requested.heave_n < 0.0, "{:?}", o.requested);
        assert!((o.errors.yaw_rad - 0.2).abs() < 1e-6 && (o.errors.z_m - 0.3).abs() < 1e-6);
        // Without depth hold (STABILIZE) the heave comes from the stick: zero.
        let o = c.pilot_step(&at(0.5, 0.0, 2.3), &centred, false, 0.02);
        assert_eq!(o.requested.heave_n, 0.0);
    }

    #[test]
    fn a_moved_stick_flies_open_loop_and_recaptures_on_release() {
        let mut c = controller();
        let nav = |yaw_rad| NavState {
            yaw_rad,
            ..NavState::default()
        };
        c.pilot_step(&nav(0.0), &Sticks::default(), true, 0.02);
        let turn = Sticks {
            yaw: 0.5,
            surge: 1.0,
            heave: -0.5,
        };
        let o = c.pilot_step(&nav(1.0), &turn, true, 0.02);
        let lim = *c.limits();
        let yaw_max = lim.lever_arm_m * (lim.max_forward_n + lim.max_reverse_n);
        assert!((o.requested.yaw_n_m - 0.5 * yaw_max).abs() < 1e-5);
        assert!((o.requested.surge_n - 2.0 * lim.max_forward_n).abs() < 1e-5);
        assert!((o.requested.heave_n + 0.5 * lim.max_reverse_n).abs() < 1e-5);
        // Released at 1.0 rad: that heading is held now, not the old 0.
        let o = c.pilot_step(&nav(1.0), &Sticks::default(), true, 0.02);
        assert_eq!(o.errors.yaw_rad, 0.0);
        let o = c.pilot_step(&nav(1.1), &Sticks::default(), true, 0.02);
        assert!((o.errors.yaw_rad - 0.1).abs() < 1e-6);
    }

    #[test]
    fn the_heading_hold_settles_on_the_yaw_model() {
        // Closed loop on eq. (34)'s yaw row alone (u = v = 0): from 0.5 rad off, within
        // 0.01 rad in 10 s, no overshoot beyond 0.05 rad.
        let mut c = controller();
        let x = c.vehicle().xy;
        let mut nav = NavState::default();
        c.pilot_step(&nav, &Sticks::default(), false, 0.02);
        nav.yaw_rad = 0.5;
        let mut worst_overshoot = 0.0f32;
        for _ in 0..500 {
            let o = c.pilot_step(&nav, &Sticks::default(), false, 0.02);
            let tau = o.allocation.achieved.yaw_n_m;
            let r = nav.r_rad_s;
            let r_dot = -x.gamma1 * r - x.gamma2 * r.abs() * r + tau / x.m33;
            nav.r_rad_s += r_dot * 0.02;
            nav.yaw_rad += nav.r_rad_s * 0.02;
            worst_overshoot = worst_overshoot.max(-nav.yaw_rad);
        }
        assert!(nav.yaw_rad.abs() < 0.01, "{}", nav.yaw_rad);
        assert!(worst_overshoot < 0.05, "{worst_overshoot}");
    }
}
