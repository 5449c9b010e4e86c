//! XZ: x steered through pitch, on the transformed point (see `docs/tracking.md`).
//!
//! Coupled model (`MODEL_NOTES` section 3), with `u1 = u + alpha q`, `x1 = x + alpha s_theta`:
//! ```text
//! u1_dot  = F_q / a_uq                                   (no tau_1)
//! x1_dot  = c u1 + s w
//! x1_ddot = c u1_dot + (-s q u1 + c q w + s w_dot) =: -g s c + h
//! q_dot   = (m_x F_q - a_uq F_u0) / delta - (a_uq / delta) tau_1
//! ```
//! `h` collects the small terms (pitch drag, `w q`, `u w`, `s w_dot`); it is evaluated from
//! the state each step and its derivative is neglected. Outer loop on `x1`:
//! `a_d = x1r_ddot - k_d e1 - k_p e0 - k_i int(e0)`; pitch demand from
//! `-(g/2) sin(2 theta_u) + h = a_d`, i.e. `theta_u = asin(y) / 2`, `y = -2 (a_d - h) / g`;
//! smooth limit `theta_d = th_max tanh(theta_u / th_max)`. Its derivatives are analytic:
//! `a_d_dot` uses the model `x1_ddot` (no `tau_1` in it) and `a_d_ddot` the dominant jerk
//! `x1_dddot ~ -g cos(2 theta) q`. Inner loop (backstepping on `theta`, `q`):
//! `q_dot_c = theta_d_ddot - k_th (theta - theta_d) - k_q (q - theta_d_dot)`, solved for
//! `tau_1` through the coupled mass matrix.

use super::gains::TrackingGains;
use super::state::{integrate, sat, TrackingState};
use crate::math::{asin, sqrt, tanh, wrap_angle};
use crate::params::Vehicle;
use crate::reference::feasible::pitch_xz_sc;
use crate::reference::RefSample;
use crate::state::NavState;

/// Surge force and pitch error; `heave_n` is the heave force the depth law asks for (enters
/// `w_dot` in `h`), `(s, co)` the sine and cosine of the pitch.
#[allow(clippy::too_many_arguments)]
pub fn surge(
    v: &Vehicle,
    g: &TrackingGains,
    st: &mut TrackingState,
    nav: &NavState,
    r: &RefSample,
    heave_n: f32,
    dt: f32,
    (s, co): (f32, f32),
) -> (f32, f32) {
    let p = v.params();
    let c = &v.xz;
    let grav = p.gravity_m_s2;
    let (u, w, q) = (nav.u_m_s, nav.w_m_s, nav.q_rad_s);
    let alpha = c.alpha;
    let u1 = u + alpha * q;
    let x1 = nav.x_m + alpha * s;
    let zx = p.z_wdot_kg - p.x_udot_kg;
    let w_minus_b = c.weight_n - c.buoyancy_n;
    // Model terms (no tau_1 in any of them).
    let fq =
        -(p.m_q + p.m_qq * q.abs()) * q - c.a_uq * w * q - zx * u * w - p.z_g_m * c.weight_n * s;
    let u1dot = fq / c.a_uq;
    let fw = -(p.z_w + p.z_ww * w.abs()) * w + w_minus_b * co + c.m_x * u * q + c.a_uq * q * q;
    let wdot = (fw + heave_n) / c.m_z;
    let x1_dot = co * u1 + s * w;
    let x1_ddot = -s * q * u1 + co * u1dot + co * q * w + s * wdot;
    let h = x1_ddot + grav * s * co;
    // Reference for x1 = x + alpha sin(theta) along the feasible pitch.
    let [xr, _, _] = r.pos_m;
    let [vxr, _, _] = r.vel_m_s;
    let [axr, _, _] = r.acc_m_s2;
    let [jxr, _, _] = r.jerk_m_s3;
    let (pr, (sr, cr)) = pitch_xz_sc(c, zx, grav, r);
    let x1r = xr + alpha * sr;
    let x1r_dot = vxr + alpha * cr * pr.theta_dot;
    let x1r_ddot = axr + alpha * (cr * pr.theta_ddot - sr * pr.theta_dot * pr.theta_dot);
    let e0 = sat(x1 - x1r, g.error_limit_m);
    let e1 = x1_dot - x1r_dot;
    let e2 = x1_ddot - x1r_ddot;
    let cos2 = co * co - s * s;
    let e3 = -grav * cos2 * q - pr.munk_m_s2[1] - jxr;
    let limit = g.integral_limit_m_s2 / g.xz_ki;
    let frozen = st.surge_sat || st.pitch_limited;
    st.xz_int = integrate(st.xz_int, e0, dt, frozen, limit);
    let a_d = x1r_ddot - g.xz_kd * e1 - g.xz_kp * e0 - g.xz_ki * st.xz_int;
    let a_d1 = jxr - g.xz_kd * e2 - g.xz_kp * e1 - g.xz_ki * e0;
    let a_d2 = -g.xz_kd * e3 - g.xz_kp * e2 - g.xz_ki * e1;
    // Pitch demand, exact inverse of the dominant term.
    let y_raw = -2.0 * (a_d - h) / grav;
    let y_max = 0.95;
    // Beyond the limit or NaN (one comparison); inside, `sat` would return `y_raw`.
    let inside = y_raw.abs() <= y_max;
    let clipped = !inside;
    let y = if inside { y_raw } else { sat(y_raw, y_max) };
    // h_dot, h_ddot ~ -(Munk term along the reference)', '' (the dominant part of h).
    let [_, munk1, munk2] = pr.munk_m_s2;
    let (y1, y2) = if clipped {
        (0.0, 0.0)
    } else {
        (-2.0 * (a_d1 + munk1) / grav, -2.0 * (a_d2 + munk2) / grav)
    };
    // `|y| <= 0.95` (NaN went to 0 in `sat`), so `sqrt(1 - y^2) >= 0.31`.
    let asin_y = asin(y);
    let root = sqrt(1.0 - y * y);
    let th_u = 0.5 * asin_y;
    let th_u1 = 0.5 * y1 / root;
    let th_u2 = 0.5 * (y2 / root + y * y1 * y1 / (root * root * root));
    // Smooth limit.
    let m = g.pitch_max_rad;
    let tn = tanh(th_u / m);
    let sech2 = 1.0 - tn * tn;
    let th_d = m * tn;
    let th_d1 = sech2 * th_u1;
    let th_d2 = sech2 * (th_u2 - 2.0 * tn * th_u1 * th_u1 / m);
    st.pitch_limited = clipped || sech2 < 0.5;
    // Inner loop.
    let z1 = wrap_angle(nav.pitch_rad - th_d);
    let z2 = q - th_d1;
    let qdot_c = th_d2 - g.pitch_kp * z1 - g.pitch_kd * z2;
    let fu0 = -(p.x_u + p.x_uu * u.abs()) * u - c.m_z * w * q - w_minus_b * s;
    let qdot0 = (c.m_x * fq - c.a_uq * fu0) / c.delta;
    let tau1 = (qdot_c - qdot0) / c.d_tau;
    (tau1, wrap_angle(nav.pitch_rad - pr.theta_rad))
}

/// Yaw held at 0 (the XZ plane) with a PD on the yaw model `m33 r_dot = -N(r) + tau_2`.
pub fn yaw_hold(v: &Vehicle, g: &TrackingGains, nav: &NavState) -> f32 {
    let p = v.params();
    let r = nav.r_rad_s;
    let e = wrap_angle(nav.yaw_rad);
    v.xy.m33 * (-g.yaw_kp * e - g.yaw_kd * r) + (p.n_r + p.n_rr * r.abs()) * r
}
