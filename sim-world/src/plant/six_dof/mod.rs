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

mod model;

use super::state::{rot, RawState};
use super::thrusters::Thrusters;
use super::{Boundary, Environment, Plant, PlantState};
use controller_core::params::VehicleParams;
use model::{
    deriv, from_lanes, rk4, thrust_xzn, to_lanes, unit_quaternion, Coeffs, Inlined, Shared, X,
};

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

impl SixDof {
    /// The generalized thrust at the start, the middle and the end of a step of `dt_s` with
    /// the command `thrust_cmd_n` held (the lag solved exactly), and the delivered forces at
    /// its end.
    fn thrust_over_step(&mut self, thrust_cmd_n: [f64; 3], dt_s: f64) -> ([[f64; 3]; 3], [f64; 3]) {
        let seg_cmd = thrust_cmd_n.map(|c| self.thr.limit(c));
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
            let mut f = seg_cmd;
            for (fi, f0i) in f.iter_mut().zip(f0) {
                *fi += (f0i - *fi) * e;
            }
            f
        };
        let fs = if tc > 0.0 { f0 } else { seg_cmd };
        let fh = at(eh);
        let fe = at(ef);
        let k = &self.k;
        (
            [thrust_xzn(k, fs), thrust_xzn(k, fh), thrust_xzn(k, fe)],
            fe,
        )
    }

    /// The end of a step: the RK4 result `o` renormalized (`unit`: its quaternion divided by
    /// the norm, and the norm, [`unit_quaternion`]), held in the water, and kept with the
    /// thrusters' delivered forces `fe`.
    fn end_step(&mut self, mut o: X, unit: ([f64; 4], f64), fe: [f64; 3]) {
        let (q, n) = unit;
        if n > 0.0 && n.is_finite() {
            for (e, qi) in o.iter_mut().skip(3).take(4).zip(q) {
                *e = qi;
            }
        }
        // The surface and the seabed: z clamped, the inertial velocity through them removed
        // (`r2` is the inertial z axis in body axes, the third row of R).
        let [x, y, z, e0, e1, e2, e3, u, v, w, p, q, r] = o;
        let (z, met) = Boundary::clamp(z, self.surface, self.seabed_depth_m);
        let mut vel = [u, v, w];
        if let Some(b) = met {
            let [_, _, r2] = rot([e0, e1, e2, e3]);
            let z_dot = r2[0] * u + r2[1] * v + r2[2] * w;
            if b.blocks(z_dot) {
                for (vi, ri) in vel.iter_mut().zip(r2) {
                    *vi -= z_dot * ri;
                }
            }
            self.contact.get_or_insert(b);
        }
        let [u, v, w] = vel;
        self.x = [x, y, z, e0, e1, e2, e3, u, v, w, p, q, r];
        self.thr.force_n = fe;
    }

    /// One RK4 step of `dt_s` of each of `W` plants, plant `i` with the command
    /// `thrust_cmd_n[i]`: the same bits as [`Plant::step`] on each, computed side by side
    /// ([`super::lanes::Lanes`]) so that the plants' chains of operations overlap.
    pub fn step_lanes<const W: usize>(
        plants: &mut [&mut SixDof; W],
        thrust_cmd_n: [[f64; 3]; W],
        dt_s: f64,
    ) {
        let mut thrust = [([[0.0; 3]; 3], [0.0; 3]); W];
        for ((p, cmd), t) in plants.iter_mut().zip(thrust_cmd_n).zip(thrust.iter_mut()) {
            *t = p.thrust_over_step(cmd, dt_s);
        }
        let k = Coeffs::gather(plants.each_ref().map(|p| &p.k));
        let vc = to_lanes(plants.each_ref().map(|p| p.env.current_m_s));
        let x = to_lanes(plants.each_ref().map(|p| p.x));
        let tau = [
            to_lanes(thrust.map(|([t, _, _], _)| t)),
            to_lanes(thrust.map(|([_, t, _], _)| t)),
            to_lanes(thrust.map(|([_, _, t], _)| t)),
        ];
        let o = rk4::<_, Shared>(&k, vc, &x, tau, dt_s);
        let (q, n) = unit_quaternion(&o);
        let units = from_lanes(q).into_iter().zip(n.0);
        for (((p, o), unit), (_, fe)) in plants.iter_mut().zip(from_lanes(o)).zip(units).zip(thrust)
        {
            p.end_step(o, unit, fe);
        }
    }
}

impl Plant for SixDof {
    fn step(&mut self, thrust_cmd_n: [f64; 3], dt_s: f64) {
        let (tau, fe) = self.thrust_over_step(thrust_cmd_n, dt_s);
        let o = rk4::<_, Inlined>(&self.k, self.env.current_m_s, &self.x, tau, dt_s);
        let unit = unit_quaternion(&o);
        self.end_step(o, unit, fe);
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

    fn as_any_mut(&mut self) -> Option<&mut dyn std::any::Any> {
        Some(self)
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

    /// Two different plants (mass, current, start, commands; one meets the surface) stepped
    /// side by side end with the bits of each stepped alone.
    #[test]
    fn side_by_side_steps_are_the_bits_of_single_steps() {
        let plant = |j: u32| {
            let mut params = VehicleParams::OBSERVER;
            params.mass_kg *= 1.0 + 0.1 * j as f32;
            params.buoyancy_offset_n = 2.0 * j as f32;
            let env = Environment {
                current_m_s: [0.1, -0.07 * f64::from(j), 0.02],
            };
            let start = PlantState {
                eta: [0.0, 0.0, 0.3, 0.0, 0.0, 0.4 * f64::from(j)],
                nu: [0.0; 6],
            };
            let mut p = SixDof::new(&params, env, true, start);
            p.set_bounds(true, None);
            p
        };
        let cmd = |j: u32, i: usize| {
            let t = (i / 10) as f64 * 0.01 + f64::from(j);
            [
                8.0 * (0.3 * t).sin(),
                6.0 * (0.2 * t).cos(),
                3.0 * (0.5 * t).sin() - 8.0 * f64::from(j),
            ]
        };
        let (mut a, mut b) = (plant(0), plant(1));
        let (mut la, mut lb) = (plant(0), plant(1));
        for i in 0..5_000 {
            a.step(cmd(0, i), 0.001);
            b.step(cmd(1, i), 0.001);
            SixDof::step_lanes(&mut [&mut la, &mut lb], [cmd(0, i), cmd(1, i)], 0.001);
        }
        assert_eq!(
            b.contact(),
            Some(Boundary::Surface),
            "the test reaches the surface"
        );
        for (one, two) in [(&a, &la), (&b, &lb)] {
            let bits = |p: &SixDof| p.x.map(f64::to_bits);
            assert_eq!(bits(one), bits(two));
            assert_eq!(one.thrust_n(), two.thrust_n());
            assert_eq!(one.contact(), two.contact());
        }
        assert_ne!(a.x, b.x);
    }
}
