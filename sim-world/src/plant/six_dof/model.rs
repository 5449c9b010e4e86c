//! The 6-DOF model's constants ([`Coeffs`]), its derivative and its RK4 step, written once
//! over [`Lane`]: for one plant in `f64`, or for several plants side by side in
//! [`Lanes`], each lane the bits of the `f64` computation.

use super::super::lanes::{Lane, Lanes};
use super::super::state::rot;
use controller_core::params::VehicleParams;

/// Constants of the model, precomputed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Coeffs<T = f64> {
    pub(super) m: T,
    pub(super) zg: T,
    pub(super) weight: T,
    pub(super) buoyancy: T,
    /// `W - B`.
    pub(super) weight_net: T,
    /// `W z_g` and `-W z_g` (the righting moment's factors).
    pub(super) weight_zg: T,
    pub(super) neg_weight_zg: T,
    /// Added mass (positive) `[A1..A6]`.
    pub(super) a: [T; 6],
    /// Rigid-body inertia about the origin.
    pub(super) i: [T; 3],
    /// Linear drag.
    pub(super) dl: [T; 6],
    /// Quadratic drag.
    pub(super) dq: [T; 6],
    /// Inverse of the (u, q) block: `[i_uu, i_uq, i_qq]`.
    pub(super) inv_uq: [T; 3],
    /// Inverse of the (v, p) block: `[i_vv, i_vp, i_pp]`.
    pub(super) inv_vp: [T; 3],
    /// `1 / (m + A3)`.
    pub(super) inv_w: T,
    /// `1 / (I_z + A6)`.
    pub(super) inv_r: T,
    pub(super) lever: T,
}

fn inv2(a: f64, b: f64, d: f64) -> [f64; 3] {
    // [[a, b], [b, d]]^-1
    let det = a * d - b * b;
    [d / det, -b / det, a / det]
}

impl Coeffs {
    pub(super) fn new(p: &VehicleParams) -> Self {
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
fn cross<T: Lane>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    let [a0, a1, a2] = a;
    let [b0, b1, b2] = b;
    [a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0]
}

/// State layout: `[x, y, z, e0, e1, e2, e3, u, v, w, p, q, r]`.
pub(super) type X<T = f64> = [T; 13];

/// The generalized thrust `[X, Z, N]` of the delivered thrusts `f = [F1x, F2x, F3z]`:
/// `X = F1 + F2`, `Z = F3`, `N = l (F1 - F2)` (the sway force, roll and pitch moments are 0).
#[inline(always)]
pub(super) fn thrust_xzn(k: &Coeffs, f: [f64; 3]) -> [f64; 3] {
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
pub(super) fn deriv<T: Lane>(k: &Coeffs<T>, vc: [T; 3], s: &X<T>, tau: [T; 3]) -> X<T> {
    let [_, _, _, e0, e1, e2, e3, u, v, w, p, q, r] = *s;
    let [r0, r1, r2] = rot([e0, e1, e2, e3]);
    // Kinematics.
    let dot = |a: [T; 3], b: [T; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let nu1 = [u, v, w];
    let pd = [dot(r0, nu1), dot(r1, nu1), dot(r2, nu1)];
    let half = T::splat(0.5);
    let qd = [
        half * (-e1 * p - e2 * q - e3 * r),
        half * (e0 * p - e3 * q + e2 * r),
        half * (e3 * p + e0 * q - e1 * r),
        half * (-e2 * p + e1 * q + e0 * r),
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
    let mut d = [T::splat(0.0); 6];
    for (((di, x), l), qd_) in d
        .iter_mut()
        .zip(rel.iter())
        .zip(k.dl.iter())
        .zip(k.dq.iter())
    {
        *di = (*l + *qd_ * x.abs()) * *x;
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
fn axpy<T: Lane>(x: &X<T>, h: T, d: &X<T>) -> X<T> {
    let mut o = *x;
    for (oi, di) in o.iter_mut().zip(d.iter()) {
        *oi = *oi + h * *di;
    }
    o
}

/// One classic RK4 step of `h` from `x` in the current `vc`, with the generalized thrust
/// `tau = [at the start, at the half step, at the end]`, before the quaternion's
/// renormalization.
#[inline(always)]
pub(super) fn rk4<T: Lane, S: Stages<T>>(
    k: &Coeffs<T>,
    vc: [T; 3],
    x: &X<T>,
    tau: [[T; 3]; 3],
    h: f64,
) -> X<T> {
    let deriv = S::deriv;
    let [ts, th, te] = tau;
    let k1 = deriv(k, vc, x, ts);
    let k2 = deriv(k, vc, &axpy(x, T::splat(0.5 * h), &k1), th);
    let k3 = deriv(k, vc, &axpy(x, T::splat(0.5 * h), &k2), th);
    let k4 = deriv(k, vc, &axpy(x, T::splat(h), &k3), te);
    let (h6, two) = (T::splat(h / 6.0), T::splat(2.0));
    let mut o = *x;
    for ((((oi, a), b), c), d) in o
        .iter_mut()
        .zip(k1.iter())
        .zip(k2.iter())
        .zip(k3.iter())
        .zip(k4.iter())
    {
        *oi = *oi + h6 * (*a + two * *b + two * *c + *d);
    }
    o
}

/// How an RK4 step evaluates [`deriv`].
pub(super) trait Stages<T: Lane> {
    /// [`deriv`] of the state `s`.
    fn deriv(k: &Coeffs<T>, vc: [T; 3], s: &X<T>, tau: [T; 3]) -> X<T>;
}

/// One plant: [`deriv`] inlined in each of the four stages.
pub(super) struct Inlined;

impl Stages<f64> for Inlined {
    #[inline(always)]
    fn deriv(k: &Coeffs, vc: [f64; 3], s: &X, tau: [f64; 3]) -> X {
        deriv(k, vc, s, tau)
    }
}

/// `W` plants side by side: [`deriv`] out of line, the four stages sharing one copy of its
/// code (a few kilobytes for two plants) instead of four.
pub(super) struct Shared;

impl<const W: usize> Stages<Lanes<W>> for Shared {
    #[inline(never)]
    fn deriv(
        k: &Coeffs<Lanes<W>>,
        vc: [Lanes<W>; 3],
        s: &X<Lanes<W>>,
        tau: [Lanes<W>; 3],
    ) -> X<Lanes<W>> {
        deriv(k, vc, s, tau)
    }
}

/// The quaternion of the state `o` divided by its norm, and the norm (the step keeps the
/// divided one when the norm is positive and finite).
#[inline(always)]
pub(super) fn unit_quaternion<T: Lane>(o: &X<T>) -> ([T; 4], T) {
    let [_, _, _, e0, e1, e2, e3, ..] = *o;
    let n = (e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3).sqrt();
    ([e0 / n, e1 / n, e2 / n, e3 / n], n)
}

/// `W` plants' rows side by side: row `j` of the result holds element `j` of every plant's.
#[inline(always)]
pub(super) fn to_lanes<const N: usize, const W: usize>(rows: [[f64; N]; W]) -> [Lanes<W>; N] {
    let mut out = [Lanes([0.0; W]); N];
    for (w, row) in rows.iter().enumerate() {
        for (o, v) in out.iter_mut().zip(row) {
            if let Some(slot) = o.0.get_mut(w) {
                *slot = *v;
            }
        }
    }
    out
}

/// The inverse of [`to_lanes`]: each plant's row back.
#[inline(always)]
pub(super) fn from_lanes<const N: usize, const W: usize>(cols: [Lanes<W>; N]) -> [[f64; N]; W] {
    let mut out = [[0.0; N]; W];
    for (j, col) in cols.iter().enumerate() {
        for (row, v) in out.iter_mut().zip(col.0) {
            if let Some(slot) = row.get_mut(j) {
                *slot = v;
            }
        }
    }
    out
}

impl<const W: usize> Coeffs<Lanes<W>> {
    /// The constants of `W` plants side by side.
    pub(super) fn gather(ks: [&Coeffs; W]) -> Self {
        let one = |f: fn(&Coeffs) -> f64| Lanes(ks.map(f));
        Self {
            m: one(|k| k.m),
            zg: one(|k| k.zg),
            weight: one(|k| k.weight),
            buoyancy: one(|k| k.buoyancy),
            weight_net: one(|k| k.weight_net),
            weight_zg: one(|k| k.weight_zg),
            neg_weight_zg: one(|k| k.neg_weight_zg),
            a: to_lanes(ks.map(|k| k.a)),
            i: to_lanes(ks.map(|k| k.i)),
            dl: to_lanes(ks.map(|k| k.dl)),
            dq: to_lanes(ks.map(|k| k.dq)),
            inv_uq: to_lanes(ks.map(|k| k.inv_uq)),
            inv_vp: to_lanes(ks.map(|k| k.inv_vp)),
            inv_w: one(|k| k.inv_w),
            inv_r: one(|k| k.inv_r),
            lever: one(|k| k.lever),
        }
    }
}
