//! The 6-DOF plant against the planar models of MODEL_NOTES sections 3 and 4 when the motion
//! is restricted to a plane, energy, equilibrium, current, thruster lag and limits.
#![allow(clippy::indexing_slicing)]

use controller_core::params::VehicleParams;
use sim_world::plant::six_dof::SixDof;
use sim_world::plant::{Environment, Plant, PlantState};

fn p64() -> [f64; 8] {
    let p = VehicleParams::OBSERVER;
    let m = f64::from(p.mass_kg);
    [
        m,
        m - f64::from(p.x_udot_kg),
        m - f64::from(p.y_vdot_kg),
        m - f64::from(p.z_wdot_kg),
        f64::from(p.i_y_kg_m2) - f64::from(p.m_qdot_kg_m2),
        f64::from(p.i_z_kg_m2) - f64::from(p.n_rdot_kg_m2),
        m * f64::from(p.z_g_m),
        m * f64::from(p.gravity_m_s2),
    ]
}

fn close(a: f64, b: f64, what: &str) {
    assert!((a - b).abs() < 1e-9 * (1.0 + b.abs()), "{what}: {a} vs {b}");
}

/// Pure XZ motion: `u_dot`, `w_dot`, `q_dot` are those of the coupled planar model, and the
/// out-of-plane derivatives are zero.
#[test]
fn xz_motion_matches_the_planar_model() {
    let p = VehicleParams::OBSERVER;
    let [_, mx, _, mz, jy, _, auq, w_n] = p64();
    let f = |x: f32| f64::from(x);
    for &(th, u, w, q, f1, f3, off) in &[
        (0.1, 0.4, -0.2, 0.3, 7.0, -3.0, 0.0),
        (-0.3, -0.2, 0.5, -0.8, -4.0, 12.0, 5.0),
        (0.05, 1.0, 0.1, 0.0, 15.0, 0.0, -5.0),
    ] {
        let pp = VehicleParams {
            buoyancy_offset_n: off as f32,
            ..p
        };
        let s = PlantState {
            eta: [1.0, 0.0, 2.0, 0.0, th, 0.0],
            nu: [u, 0.0, w, 0.0, q, 0.0],
        };
        let plant = SixDof::new(&pp, Environment::default(), false, s);
        let d = plant.derivative([f1, f1, f3]);
        let b = w_n + off;
        let (st, ct) = th.sin_cos();
        let zx = f(p.z_wdot_kg) - f(p.x_udot_kg);
        let fu = -(f(p.x_u) + f(p.x_uu) * u.abs()) * u - mz * w * q - (w_n - b) * st + 2.0 * f1;
        let fq = -(f(p.m_q) + f(p.m_qq) * q.abs()) * q
            - auq * w * q
            - zx * u * w
            - f(p.z_g_m) * w_n * st;
        let delta = mx * jy - auq * auq;
        let ud = (jy * fu - auq * fq) / delta;
        let qd = (mx * fq - auq * fu) / delta;
        let wd = (-(f(p.z_w) + f(p.z_ww) * w.abs()) * w
            + (w_n - b) * ct
            + mx * u * q
            + auq * q * q
            + f3)
            / mz;
        close(d[7], ud, "u_dot");
        close(d[9], wd, "w_dot");
        close(d[11], qd, "q_dot");
        close(d[0], ct * u + st * w, "x_dot");
        close(d[2], -st * u + ct * w, "z_dot");
        for (i, name) in [(1, "y_dot"), (8, "v_dot"), (10, "p_dot"), (12, "r_dot")] {
            assert!(d[i].abs() < 1e-12, "{name} = {}", d[i]);
        }
    }
}

/// Pure XY motion: the surge, sway and yaw balances are those of MODEL_NOTES section 4 (the
/// CG offset adds the surge-pitch and sway-roll inertia couplings, which the balance includes).
#[test]
fn xy_motion_matches_the_planar_model() {
    let p = VehicleParams::OBSERVER;
    let [_, m11, m22, _, _, m33, auq, _] = p64();
    let f = |x: f32| f64::from(x);
    for &(psi, u, v, r, f1, f2) in &[
        (0.4, 0.5, -0.1, 0.2, 6.0, 2.0),
        (-2.0, -0.3, 0.2, -0.5, -5.0, 9.0),
    ] {
        let s = PlantState {
            eta: [0.0, 0.0, 1.0, 0.0, 0.0, psi],
            nu: [u, v, 0.0, 0.0, 0.0, r],
        };
        let plant = SixDof::new(&p, Environment::default(), false, s);
        let d = plant.derivative([f1, f2, 0.0]);
        let l = f(p.thruster_lever_arm_m);
        let surge = m22 * v * r - (f(p.x_u) + f(p.x_uu) * u.abs()) * u + f1 + f2;
        let sway = -m11 * u * r - (f(p.y_v) + f(p.y_vv) * v.abs()) * v;
        let yaw = (m11 - m22) * u * v - (f(p.n_r) + f(p.n_rr) * r.abs()) * r + l * (f1 - f2);
        close(m11 * d[7] + auq * d[11], surge, "surge balance");
        close(m22 * d[8] - auq * d[10], sway, "sway balance");
        close(m33 * d[12], yaw, "yaw balance");
        let (sp, cp) = psi.sin_cos();
        close(d[0], cp * u - sp * v, "x_dot");
        close(d[1], sp * u + cp * v, "y_dot");
    }
}

#[test]
fn energy_decays_without_thrust() {
    let s = PlantState {
        eta: [0.0, 0.0, 5.0, 0.3, -0.2, 1.0],
        nu: [0.6, -0.3, 0.2, 0.5, -0.4, 0.7],
    };
    let mut plant = SixDof::new(&VehicleParams::OBSERVER, Environment::default(), true, s);
    let e0 = plant.energy_j();
    let mut prev = e0;
    for _ in 0..30_000 {
        plant.step([0.0; 3], 1e-3);
        let e = plant.energy_j();
        assert!(e <= prev + 1e-9 * e0, "energy rose: {prev} -> {e}");
        prev = e;
    }
    assert!(prev < 0.2 * e0, "{e0} -> {prev}");
}

#[test]
fn neutral_at_rest_stays_at_rest() {
    let s = PlantState {
        eta: [1.0, 2.0, 3.0, 0.0, 0.0, 0.5],
        nu: [0.0; 6],
    };
    let mut plant = SixDof::new(&VehicleParams::OBSERVER, Environment::default(), true, s);
    for _ in 0..60_000 {
        plant.step([0.0; 3], 1e-3);
    }
    let e = plant.state();
    for (a, b) in e.eta.iter().zip(s.eta.iter()) {
        assert!((a - b).abs() < 1e-12, "{e:?}");
    }
    assert!(e.nu.iter().all(|v| v.abs() < 1e-12), "{e:?}");
}

#[test]
fn positive_buoyancy_rises_at_the_drag_balanced_speed() {
    let p = VehicleParams {
        buoyancy_offset_n: 5.0,
        ..VehicleParams::OBSERVER
    };
    let mut plant = SixDof::new(&p, Environment::default(), true, PlantState::default());
    for _ in 0..30_000 {
        plant.step([0.0; 3], 1e-3);
    }
    let w = plant.state().nu[2];
    // (Z_w + Z_ww |w|) |w| = 5 N
    let (zw, zww) = (f64::from(p.z_w), f64::from(p.z_ww));
    let expect = -(-zw + (zw * zw + 4.0 * zww * 5.0).sqrt()) / (2.0 * zww);
    assert!((w - expect).abs() < 1e-6, "{w} vs {expect}");
}

#[test]
fn drifts_with_the_current() {
    let env = Environment {
        current_m_s: [0.15, -0.1, 0.0],
    };
    let mut plant = SixDof::new(&VehicleParams::OBSERVER, env, true, PlantState::default());
    for _ in 0..120_000 {
        plant.step([0.0; 3], 1e-3);
    }
    let s = plant.state();
    // Inertial velocity of the body = current (yaw may turn; compare in the inertial frame).
    let (sp, cp) = s.eta[5].sin_cos();
    let (u, v) = (s.nu[0], s.nu[1]);
    let vx = cp * u - sp * v;
    let vy = sp * u + cp * v;
    assert!((vx - 0.15).abs() < 1e-3 && (vy + 0.1).abs() < 1e-3, "{s:?}");
}

#[test]
fn thruster_lag_and_limits() {
    let mut plant = SixDof::new(
        &VehicleParams::OBSERVER,
        Environment::default(),
        true,
        PlantState::default(),
    );
    for _ in 0..100 {
        plant.step([10.0, 100.0, -100.0], 1e-3);
    }
    let f = plant.thrust_n();
    // T = 0.1 s as f32 widened: 0.10000000149 s.
    let k = 1.0 - (-0.1 / f64::from(0.1f32)).exp();
    assert!((f[0] - 10.0 * k).abs() < 1e-9, "{f:?}");
    assert!((f[1] - 20.0 * k).abs() < 1e-9, "{f:?}");
    assert!((f[2] + 15.0 * k).abs() < 1e-9, "{f:?}");
}
