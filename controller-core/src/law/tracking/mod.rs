//! Laws that really track, in the vertical plane, the horizontal plane and 3-D.
//!
//! - [`step_xz`]: a cascade on the transformed point `x1 = x + alpha sin(theta)` of
//!   `MODEL_NOTES` section 3, whose acceleration is set by the pitch (`u1_dot = F_q / a_uq`,
//!   independent of `tau_1`): x1 error -> desired x1 acceleration (PID) -> pitch demand
//!   `theta_d` (exact inverse of the dominant term `-g sin(theta) cos(theta)`, smoothly limited
//!   to `pitch_max_rad`) with analytic first and second derivatives -> pitch-rate loop ->
//!   `tau_1` through the coupled mass matrix (`q_dot = q_dot_0 - (a_uq / delta) tau_1`).
//!   Depth by the heave force ([`depth`]); yaw held at 0 on the 6-DOF plant.
//! - [`step_xy`]: the "hand position" `h = p + eps (cos psi, sin psi)`, fully actuated for
//!   `eps > 0`, is feedback-linearized (`tau_1`, `tau_2` give any hand acceleration); the
//!   hand reference is the origin reference shifted by `eps` along the *feasible* heading
//!   (course minus the sideslip the sway dynamics need, [`crate::reference::feasible`]), so
//!   when the hand tracks, the internal yaw dynamics (stable when moving forward with
//!   `Y_v eps > (m11 - m22) U`) bring the origin onto its reference. The integral acts on the
//!   *origin* error, so a current or a model error that leaves the heading off the computed
//!   feasible heading is still removed at the origin.
//! - [`step_3d`]: the XY law plus the depth law; pitch and roll are left to their restoring
//!   moments.
//!
//! Saturation awareness: position errors entering the PD terms are limited
//! (`error_limit_m`), the pitch demand is limited, every integrator is clamped and frozen while
//! its actuator is saturated (from [`TrackingState::on_allocation`]; integration that shrinks
//! the integrator is still allowed), so nothing winds up and recovery is smooth.
//!
//! Design notes, equations and measured numbers: `docs/tracking.md`.

mod depth;
mod gains;
mod state;
mod xy;
mod xz;

use super::LawOutput;
use crate::params::Vehicle;
use crate::reference::RefSample;
use crate::state::{BodyForces, NavState, TrackingErrors};

pub use depth::depth;
pub use gains::TrackingGains;
use state::clean_dt;
pub use state::TrackingState;

/// XZ tracking step: x by pitch (cascade on the transformed point), depth by heave, yaw held
/// at 0. Errors: `x`, `z` of the origin and the pitch error against the steady pitch of the
/// reference acceleration (`y`, yaw: 0).
pub fn step_xz(
    v: &Vehicle,
    g: &TrackingGains,
    st: &mut TrackingState,
    nav: &NavState,
    r: &RefSample,
    dt_s: f32,
) -> LawOutput {
    let dt = clean_dt(dt_s);
    let pitch_sc = crate::math::sin_cos(nav.pitch_rad);
    let (heave_n, ez) = depth::depth_with(v, g, st, nav, r, dt, pitch_sc);
    let (surge_n, pitch_err) = xz::surge(v, g, st, nav, r, heave_n, dt, pitch_sc);
    let yaw_n_m = xz::yaw_hold(v, g, nav);
    let [xr, _, _] = r.pos_m;
    LawOutput {
        forces: BodyForces {
            surge_n,
            yaw_n_m,
            heave_n,
        },
        errors: TrackingErrors {
            x_m: nav.x_m - xr,
            y_m: 0.0,
            z_m: ez,
            pitch_rad: pitch_err,
            yaw_rad: 0.0,
        },
    }
}

/// XY tracking step (hand position with feasible heading); no heave force. Errors: `x`, `y`
/// of the origin and the yaw error against the feasible heading (`z`, pitch: 0).
pub fn step_xy(
    v: &Vehicle,
    g: &TrackingGains,
    st: &mut TrackingState,
    nav: &NavState,
    r: &RefSample,
    dt_s: f32,
) -> LawOutput {
    let dt = clean_dt(dt_s);
    let (surge_n, yaw_n_m, ex, ey, eyaw) = xy::hand(v, g, st, nav, r, dt);
    LawOutput {
        forces: BodyForces {
            surge_n,
            yaw_n_m,
            heave_n: 0.0,
        },
        errors: TrackingErrors {
            x_m: ex,
            y_m: ey,
            z_m: 0.0,
            pitch_rad: 0.0,
            yaw_rad: eyaw,
        },
    }
}

/// 3-D tracking step: the XY law plus the depth law; pitch and roll left to their restoring
/// moments. Errors: `x`, `y`, `z` of the origin and the yaw error.
pub fn step_3d(
    v: &Vehicle,
    g: &TrackingGains,
    st: &mut TrackingState,
    nav: &NavState,
    r: &RefSample,
    dt_s: f32,
) -> LawOutput {
    let dt = clean_dt(dt_s);
    let (heave_n, ez) = depth(v, g, st, nav, r, dt);
    let (surge_n, yaw_n_m, ex, ey, eyaw) = xy::hand(v, g, st, nav, r, dt);
    LawOutput {
        forces: BodyForces {
            surge_n,
            yaw_n_m,
            heave_n,
        },
        errors: TrackingErrors {
            x_m: ex,
            y_m: ey,
            z_m: ez,
            pitch_rad: 0.0,
            yaw_rad: eyaw,
        },
    }
}

#[cfg(test)]
mod tests;
