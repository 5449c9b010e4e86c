//! The 6-DOF rigid-body plant (f64), Fossen's vector form about the body origin (the CB):
//! ```text
//! M_RB nu_dot + C_RB(nu) nu + M_A nu_r_dot + C_A(nu_r) nu_r + D(nu_r) nu_r + g(eta) = tau
//! ```
//! - `M_RB` with the CG at `(0, 0, z_g)`: surge-pitch coupling `+m z_g`, sway-roll `-m z_g`;
//!   inertia `diag(I_x, I_y, I_z)` about the origin (as in the planar models, where
//!   `J_y = I_y - M_qdot` sits beside `a_uq = m z_g`).
//! - `C_RB nu = [m (w x v + w x (w x r_g)); w x (I w) + m r_g x (w x v)]`.
//! - `M_A = diag(-X_udot, -Y_vdot, -Z_wdot, -K_pdot, -M_qdot, -N_rdot)`, `K_pdot = 0`
//!   (assumed: roll is not in Table I). `C_A(nu_r) nu_r = [w x a; v_r x a + w x b]` with
//!   `a = A_lin v_r`, `b = A_ang w`; the `v_r x a` term is the Munk moment.
//! - `D(nu_r)`: diagonal linear + quadratic drag on the relative velocity; roll drag assumed
//!   equal to pitch drag (`K_p = M_q`, `K_pp = M_qq`), not given in the paper.
//! - `g(eta)`: weight `W` at the CG, buoyancy `B = W + buoyancy_offset_n` at the origin.
//! - Current: constant and irrotational in the inertial frame; `nu_r = nu - [R^T V_c; 0]`, so
//!   `nu_r_dot = nu_dot + [w x v_c; 0]` (the added-mass force of the turning current).
//! - Thrusters `F1x` at `(0, -l, 0)` and `F2x` at `(0, +l, 0)` along body x, `F3z` along body z
//!   at the origin: `tau = [F1 + F2, 0, F3, 0, 0, l (F1 - F2)]`. First-order lag solved
//!   exactly over the step (one `exp` per step) and limits ([`super::thrusters`]).
//! - Attitude as a unit quaternion (no trigonometry in the derivative, no gimbal lock),
//!   renormalized after every step; [`Plant::state`] reports ZYX Euler angles.
//!
//! One [`Plant::step`] is one classic RK4 step.

use super::state::{rot, RawState};
use super::thrusters::Thrusters;
use super::{Boundary, Environment, Plant, PlantState};
use controller_core::params::VehicleParams;

/// Constants of the model, precomputed.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Coeffs {
    m: f64,
    zg: f64,
    weight: f64,
    buoyancy: f64,
    /// `W - B`.
    weight_net: f64,
    /// `W z_g` and `-W z_g` (the righting moment's factors).
    weight_zg: f64,
    neg_weight_zg: f64,
    /// Added mass (positive) `[A1..A6]`.
    a: [f64; 6],
    /// Rigid-body inertia about the origin.
    i: [f64; 3],
    /// Linear drag.
    dl: [f64; 6],
    /// Quadratic drag.
    dq: [f64; 6],
    /// Inverse of the (u, q) block: `[i_uu, i_uq, i_qq]`.
    inv_uq: [f64; 3],
    /// Inverse of the (v, p) block: `[i_vv, i_vp, i_pp]`.
    inv_vp: [f64; 3],
    /// `1 / (m + A3)`.
    inv_w: f64,
    /// `1 / (I_z + A6)`.
    inv_r: f64,
    lever: f64,
}

fn inv2(a: f64, b: f64, d: f64) -> [f64; 3] {
    // [[a, b], [b, d]]^-1
    let det = a * d - b * b;
    [d / det, -b / det, a / det]
}

impl Coeffs {
    fn new(p: &VehicleParams) -> Self {
        let w = |x: f32| f64::from(x);
        let m = w(p.mass_kg);
        let zg = w(p.z_g_m);
        let weight = m * w(p.gravity_m_s2);
        let a = [
            -w(p.x_udot_kg),
            -w(p.y_vdot_kg),
            -w(p.z_wdot_kg),
            0.0,
            -w(p.m_qdot_kg_m2),
            -w(p.n_rdot_kg_m2),
        ];
        let i = [w(p.i_x_kg_m2), w(p.i_y_kg_m2), w(p.i_z_kg_m2)];
        let [a1, a2, a3, a4, a5, a6] = a;
        let [ix, iy, iz] = i;
        let buoyancy = weight + w(p.buoyancy_offset_n);
        Self {
            m,
            zg,
            weight,
            buoyancy,
            weight_net: weight - buoyancy,
            weight_zg: weight * zg,
            neg_weight_zg: -weight * zg,
            a,
            i,
            dl: [w(p.x_u), w(p.y_v), w(p.z_w), w(p.m_q), w(p.m_q), w(p.n_r)],
            dq: [
                w(p.x_uu),
                w(p.y_vv),
                w(p.z_ww),
                w(p.m_qq),
                w(p.m_qq),
                w(p.n_rr),
            ],
            inv_uq: inv2(m + a1, m * zg, iy + a5),
            inv_vp: inv2(m + a2, -m * zg, ix + a4),
            inv_w: 1.0 / (m + a3),
            inv_r: 1.0 / (iz + a6),
            lever: w(p.thruster_lever_arm_m),
        }
    }
}

#[inline(always)]
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    let [a0, a1, a2] = a;
    let [b0, b1, b2] = b;
    [a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0]
}

/// State layout: `[x, y, z, e0, e1, e2, e3, u, v, w, p, q, r]`.
type X = [f64; 13];

/// The generalized thrust `[X, Z, N]` of the delivered thrusts `f = [F1x, F2x, F3z]`:
/// `X = F1 + F2`, `Z = F3`, `N = l (F1 - F2)` (the sway force, roll and pitch moments are 0).
#[inline(always)]
fn thrust_xzn(k: &Coeffs, f: [f64; 3]) -> [f64; 3] {
    let [f1, f2, f3] = f;
    [f1 + f2, f3, k.lever * (f1 - f2)]
}

/// `x_dot` for the generalized thrust `tau = [X, Z, N]` ([`thrust_xzn`]).
///
/// Written for this vehicle's structure: the CG on the z axis (`r_g = [0, 0, z_g]`), no roll
/// added mass (`A4 = 0`), thrust only in surge, heave and yaw. The terms these make zero are
/// left out; every other term is the vector form's, operation for operation, in its order
/// (so the trajectory is the same to the bit as the cross products written out in full).
#[inline(always)]
fn deriv(k: &Coeffs, vc: [f64; 3], s: &X, tau: [f64; 3]) -> X {
    let [_, _, _, e0, e1, e2, e3, u, v, w, p, q, r] = *s;
    let [r0, r1, r2] = rot([e0, e1, e2, e3]);
    // Kinematics.
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let nu1 = [u, v, w];
    let pd = [dot(r0, nu1), dot(r1, nu1), dot(r2, nu1)];
    let qd = [
        0.5 * (-e1 * p - e2 * q - e3 * r),
        0.5 * (e0 * p - e3 * q + e2 * r),
        0.5 * (e3 * p + e0 * q - e1 * r),
        0.5 * (-e2 * p + e1 * q + e0 * r),
    ];
    // Current in the body frame: R^T V_c (columns of R).
    let [cx, cy, cz] = vc;
    let vcb = [
        r0[0] * cx + r1[0] * cy + r2[0] * cz,
        r0[1] * cx + r1[1] * cy + r2[1] * cz,
        r0[2] * cx + r1[2] * cy + r2[2] * cz,
    ];
    let vr = [u - vcb[0], v - vcb[1], w - vcb[2]];
    let om = [p, q, r];
    let [a1, a2, a3, _, a5, a6] = k.a;
    let [ix, iy, iz] = k.i;
    let (m, zg) = (k.m, k.zg);
    // Rigid body Coriolis: `w x v + w x (w x r_g)` with `w x r_g = [q z_g, -p z_g, 0]`.
    let wv = cross(om, nu1);
    let wwr = [r * (p * zg), r * (q * zg), -(p * (p * zg)) - q * (q * zg)];
    let f_rb = [
        m * (wv[0] + wwr[0]),
        m * (wv[1] + wwr[1]),
        m * (wv[2] + wwr[2]),
    ];
    // `w x (I w) + m r_g x (w x v)`, `r_g x (w x v) = [-z_g wv_y, z_g wv_x, 0]`.
    let iw = cross(om, [ix * p, iy * q, iz * r]);
    let m_rb = [iw[0] - m * (zg * wv[1]), iw[1] + m * (zg * wv[0]), iw[2]];
    // Added mass Coriolis (Munk moment in v_r x a); `b = [0, A5 q, A6 r]`, so
    // `w x b = [q b_z - r b_y, -p b_z, p b_y]`.
    let am = [a1 * vr[0], a2 * vr[1], a3 * vr[2]];
    let (by, bz) = (a5 * q, a6 * r);
    let f_a = cross(om, am);
    let vra = cross(vr, am);
    let wb = [q * bz - r * by, -(p * bz), p * by];
    // Turning current: M_A [w x v_c; 0] moved to the right-hand side.
    let wvc = cross(om, vcb);
    // Drag.
    let rel = [vr[0], vr[1], vr[2], p, q, r];
    let mut d = [0.0; 6];
    for (((di, x), l), qd_) in d
        .iter_mut()
        .zip(rel.iter())
        .zip(k.dl.iter())
        .zip(k.dq.iter())
    {
        *di = (l + qd_ * x.abs()) * x;
    }
    // Restoring: g_b = R^T e3 (third row of R); the righting moment has no yaw part.
    let gb = r2;
    let wb_net = k.weight_net;
    let fg = [wb_net * gb[0], wb_net * gb[1], wb_net * gb[2]];
    let mg = [k.neg_weight_zg * gb[1], k.weight_zg * gb[0]];
    let [tau_x, tau_z, tau_n] = tau;
    let rhs = [
        tau_x - f_rb[0] - f_a[0] - d[0] + fg[0] - a1 * wvc[0],
        -f_rb[1] - f_a[1] - d[1] + fg[1] - a2 * wvc[1],
        tau_z - f_rb[2] - f_a[2] - d[2] + fg[2] - a3 * wvc[2],
        -m_rb[0] - vra[0] - wb[0] - d[3] + mg[0],
        -m_rb[1] - vra[1] - wb[1] - d[4] + mg[1],
        tau_n - m_rb[2] - vra[2] - wb[2] - d[5],
    ];
    let [iuu, iuq, iqq] = k.inv_uq;
    let [ivv, ivp, ipp] = k.inv_vp;
    let ud = iuu * rhs[0] + iuq * rhs[4];
    let qd_dot = iuq * rhs[0] + iqq * rhs[4];
    let vd = ivv * rhs[1] + ivp * rhs[3];
    let pdd = ivp * rhs[1] + ipp * rhs[3];
    let wd = k.inv_w * rhs[2];
    let rd = k.inv_r * rhs[5];
    [
        pd[0], pd[1], pd[2], qd[0], qd[1], qd[2], qd[3], ud, vd, wd, pdd, qd_dot, rd,
    ]
}

#[inline(always)]
fn axpy(x: &X, h: f64, d: &X) -> X {
    let mut o = *x;
    for (oi, di) in o.iter_mut().zip(d.iter()) {
        *oi += h * di;
    }
    o
}

/// Euler angles (ZYX) to a unit quaternion.
fn quat_from_euler(roll: f64, pitch: f64, yaw: f64) -> [f64; 4] {
    let (sf, cf) = (0.5 * roll).sin_cos();
    let (st, ct) = (0.5 * pitch).sin_cos();
    let (sp, cp) = (0.5 * yaw).sin_cos();
    [
        cf * ct * cp + sf * st * sp,
        sf * ct * cp - cf * st * sp,
        cf * st * cp + sf * ct * sp,
        cf * ct * sp - sf * st * cp,
    ]
}

/// The 6-DOF plant.
#[derive(Debug, Clone)]
pub struct SixDof {
    k: Coeffs,
    env: Environment,
    x: X,
    thr: Thrusters,
    surface: bool,
    seabed_depth_m: Option<f64>,
    contact: Option<Boundary>,
    /// The step `dt` that [`Self::lag_half`] was computed for (NaN before the first step).
    lag_dt_s: f64,
    /// The thrusters' lag factor over half a step, `exp(-dt / 2T)`: the plant runs at one
    /// step, so the `exp` is computed once, not at every step.
    lag_half: f64,
}

impl SixDof {
    /// A plant with the vehicle `params` (buoyancy offset included), the water `env`, thruster
    /// limits applied when `saturate`, starting at `initial` with the thrusters at rest.
    pub fn new(
        params: &VehicleParams,
        env: Environment,
        saturate: bool,
        initial: PlantState,
    ) -> SixDof {
        let [x, y, z, roll, pitch, yaw] = initial.eta;
        let [e0, e1, e2, e3] = quat_from_euler(roll, pitch, yaw);
        let [u, v, w, p, q, r] = initial.nu;
        SixDof {
            k: Coeffs::new(params),
            env,
            x: [x, y, z, e0, e1, e2, e3, u, v, w, p, q, r],
            thr: Thrusters::new(params, saturate),
            surface: false,
            seabed_depth_m: None,
            contact: None,
            lag_dt_s: f64::NAN,
            lag_half: 0.0,
        }
    }

    /// State derivative `[x, y, z, e0..e3, u, v, w, p, q, r]` for delivered thrusts `f`
    /// (for tests against the planar models).
    pub fn derivative(&self, thrust_n: [f64; 3]) -> [f64; 13] {
        deriv(
            &self.k,
            self.env.current_m_s,
            &self.x,
            thrust_xzn(&self.k, thrust_n),
        )
    }

    /// Kinetic energy `nu^T M nu / 2` (ground-relative velocities) plus the pendulum energy
    /// `W z_g (1 - cos(theta) cos(phi))` and the net-buoyancy energy `(W - B) z`.
    pub fn energy_j(&self) -> f64 {
        let [_, _, z, _, e1, e2, _, u, v, w, p, q, r] = self.x;
        let k = &self.k;
        let [a1, a2, a3, a4, a5, a6] = k.a;
        let [ix, iy, iz] = k.i;
        let m = k.m;
        let kin = 0.5
            * ((m + a1) * u * u
                + (m + a2) * v * v
                + (m + a3) * w * w
                + (ix + a4) * p * p
                + (iy + a5) * q * q
                + (iz + a6) * r * r)
            + m * k.zg * (u * q - v * p);
        let g33 = 1.0 - 2.0 * (e1 * e1 + e2 * e2);
        kin + k.weight * k.zg * (1.0 - g33) - (k.weight - k.buoyancy) * z
    }
}

impl Plant for SixDof {
    fn step(&mut self, thrust_cmd_n: [f64; 3], dt_s: f64) {
        let seg_cmd = [
            self.thr.limit(thrust_cmd_n[0]),
            self.thr.limit(thrust_cmd_n[1]),
            self.thr.limit(thrust_cmd_n[2]),
        ];
        let f0 = self.thr.force_n;
        let tc = self.thr.time_constant_s;
        let (eh, ef) = if tc > 0.0 {
            if dt_s.to_bits() != self.lag_dt_s.to_bits() {
                self.lag_dt_s = dt_s;
                self.lag_half = (-0.5 * dt_s / tc).exp();
            }
            let e = self.lag_half;
            (e, e * e)
        } else {
            (0.0, 0.0)
        };
        let at = |e: f64| {
            [
                seg_cmd[0] + (f0[0] - seg_cmd[0]) * e,
                seg_cmd[1] + (f0[1] - seg_cmd[1]) * e,
                seg_cmd[2] + (f0[2] - seg_cmd[2]) * e,
            ]
        };
        let fs = if tc > 0.0 { f0 } else { seg_cmd };
        let fh = at(eh);
        let fe = at(ef);
        let k = &self.k;
        let vc = self.env.current_m_s;
        let h = dt_s;
        let x = &self.x;
        let (ts, th, te) = (thrust_xzn(k, fs), thrust_xzn(k, fh), thrust_xzn(k, fe));
        let k1 = deriv(k, vc, x, ts);
        let k2 = deriv(k, vc, &axpy(x, 0.5 * h, &k1), th);
        let k3 = deriv(k, vc, &axpy(x, 0.5 * h, &k2), th);
        let k4 = deriv(k, vc, &axpy(x, h, &k3), te);
        let mut o = *x;
        for ((((oi, a), b), c), d) in o
            .iter_mut()
            .zip(k1.iter())
            .zip(k2.iter())
            .zip(k3.iter())
            .zip(k4.iter())
        {
            *oi += h / 6.0 * (a + 2.0 * b + 2.0 * c + d);
        }
        // Renormalize the quaternion.
        let [_, _, _, e0, e1, e2, e3, ..] = o;
        let n = (e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3).sqrt();
        if n > 0.0 && n.is_finite() {
            for e in o.iter_mut().skip(3).take(4) {
                *e /= n;
            }
        }
        // The surface and the seabed: z clamped, the inertial velocity through them removed
        // (`r2` is the inertial z axis in body axes, the third row of R).
        let (z, met) = Boundary::clamp(o[2], self.surface, self.seabed_depth_m);
        if let Some(b) = met {
            o[2] = z;
            let [_, _, r2] = rot([o[3], o[4], o[5], o[6]]);
            let z_dot = r2[0] * o[7] + r2[1] * o[8] + r2[2] * o[9];
            if b.blocks(z_dot) {
                for (v, r) in o.iter_mut().skip(7).take(3).zip(r2) {
                    *v -= z_dot * r;
                }
            }
            self.contact.get_or_insert(b);
        }
        self.x = o;
        self.thr.force_n = fe;
    }

    fn set_current(&mut self, current_m_s: [f64; 3]) {
        self.env.current_m_s = current_m_s;
    }

    fn set_bounds(&mut self, surface: bool, seabed_depth_m: Option<f64>) {
        self.surface = surface;
        self.seabed_depth_m = seabed_depth_m;
    }

    fn contact(&self) -> Option<Boundary> {
        self.contact
    }

    fn state(&self) -> PlantState {
        self.raw_state().state()
    }

    fn raw_state(&self) -> RawState {
        let [x, y, z, e0, e1, e2, e3, u, v, w, p, q, r] = self.x;
        RawState::Quaternion {
            pos_m: [x, y, z],
            quat: [e0, e1, e2, e3],
            nu: [u, v, w, p, q, r],
        }
    }

    fn thrust_n(&self) -> [f64; 3] {
        self.thr.force_n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quaternion_round_trip() {
        let s = PlantState {
            eta: [1.0, 2.0, 3.0, 0.1, -0.2, 2.5],
            nu: [0.0; 6],
        };
        let p = SixDof::new(&VehicleParams::OBSERVER, Environment::default(), true, s);
        let got = p.state();
        for (a, b) in got.eta.iter().zip(s.eta.iter()) {
            assert!((a - b).abs() < 1e-12, "{got:?}");
        }
    }
}
