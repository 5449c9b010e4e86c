//! Depth of the body origin by the heave force (shared by the XZ and 3-D laws).
//!
//! `z_dot = -s_theta u + c_theta s_phi v + c_theta c_phi w`. A PID with feedforward sets the
//! depth acceleration `z_ddot_c = z_r_ddot - k_d e_dot - k_p sat(e) - k_i int(e)`; with
//! `z_ddot ~ c_theta c_phi w_dot - c_theta q u - s_theta q w` (the `s_theta u_dot` term is left
//! out), `w_dot_c = (z_ddot_c + c_theta q u + s_theta q w) / max(c_theta c_phi, 0.5)` and the
//! heave model `m_z w_dot = F_w + tau_3`,
//! `F_w = -(Z_w + Z_ww |w|) w + (W - B) c_theta c_phi + m_x u q + a_uq q^2`, gives `tau_3`.
//! The integral absorbs a buoyancy offset (5 N needs 0.45 m/s^2) and is frozen while the
//! heave thruster saturates.

use super::gains::TrackingGains;
use super::state::{integrate, sat, TrackingState};
use crate::math::{max, sin_cos};
use crate::params::Vehicle;
use crate::reference::RefSample;
use crate::state::NavState;

/// Heave force and depth error `z - z_r` of the origin.
pub fn depth(
    v: &Vehicle,
    g: &TrackingGains,
    st: &mut TrackingState,
    nav: &NavState,
    r: &RefSample,
    dt: f32,
) -> (f32, f32) {
    depth_with(v, g, st, nav, r, dt, sin_cos(nav.pitch_rad))
}

/// [`depth`] with `(sin, cos)` of the pitch already computed by the caller.
#[inline]
pub(crate) fn depth_with(
    v: &Vehicle,
    g: &TrackingGains,
    st: &mut TrackingState,
    nav: &NavState,
    r: &RefSample,
    dt: f32,
    (sth, cth): (f32, f32),
) -> (f32, f32) {
    let p = v.params();
    let c = &v.xz;
    let (sf, cf) = sin_cos(nav.roll_rad);
    let (u, vv, w, q) = (nav.u_m_s, nav.v_m_s, nav.w_m_s, nav.q_rad_s);
    let [_, _, zr] = r.pos_m;
    let [_, _, vzr] = r.vel_m_s;
    let [_, _, azr] = r.acc_m_s2;
    let z_dot = -sth * u + cth * sf * vv + cth * cf * w;
    let ez = nav.z_m - zr;
    let ez_dot = z_dot - vzr;
    let limit = g.integral_limit_m_s2 / g.depth_ki;
    let es = sat(ez, g.error_limit_m);
    st.z_int = integrate(st.z_int, es, dt, st.heave_sat, limit);
    let zdd_c = azr - g.depth_kd * ez_dot - g.depth_kp * es - g.depth_ki * st.z_int;
    let ccf = max(cth * cf, 0.5);
    let wdot_c = (zdd_c + cth * q * u + sth * q * w) / ccf;
    let fw = -(p.z_w + p.z_ww * w.abs()) * w
        + (c.weight_n - c.buoyancy_n) * cth * cf
        + c.m_x * u * q
        + c.a_uq * q * q;
    (c.m_z * wdot_c - fw, ez)
}
