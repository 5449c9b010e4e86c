//! The `f64` planar plants: agreement with the core's independent `f32` models, equilibria,
//! thruster lag and limits, RK4 convergence.

use controller_core::model;
use controller_core::params::{Vehicle, VehicleParams};
use controller_core::state::{BodyForces, XyState, XzState};
use proptest::prelude::*;
use sim_world::plant::xy::{self as pxy, XyPlant};
use sim_world::plant::xz::{self as pxz, XzPlant};
use sim_world::plant::{Environment, Plant, PlantParams, PlantState};

fn params() -> PlantParams {
    PlantParams::from_vehicle(&VehicleParams::OBSERVER)
}

/// `|a - b| <= tol * scale` where `scale` is the size of the terms that were summed: f32
/// round-off is relative to the largest term, not to the (possibly cancelled) result.
fn close(a: f64, b: f64, scale: f64) -> bool {
    (a - b).abs() <= 2e-6 * (1.0 + scale)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// The core's f32 XZ model (eqs. 1-2 corrected) and the plant's f64 derivatives agree to
    /// f32 precision over random states and forces.
    #[test]
    fn xz_core_model_matches_plant(
        th in -1.5f64..1.5, u in -2.0f64..2.0, w in -2.0f64..2.0, q in -2.0f64..2.0,
        t1 in -40.0f64..40.0, t3 in -40.0f64..40.0, off in -5.0f64..5.0,
    ) {
        let mut vp = VehicleParams::OBSERVER;
        vp.buoyancy_offset_n = off as f32;
        let v = vp.validate().unwrap();
        let p = PlantParams::from_vehicle(&vp);
        let s = [1.0, 2.0, th, u, w, q];
        let d = pxz::derivatives(&p, &s, [t1, 0.0, t3], [0.0; 3]);
        let cs = XzState { x_m: 1.0, z_m: 2.0, pitch_rad: th as f32, u_m_s: u as f32, w_m_s: w as f32, q_rad_s: q as f32 };
        let cd = model::xz::derivative(&v, &cs, &BodyForces { surge_n: t1 as f32, yaw_n_m: 0.0, heave_n: t3 as f32 });
        let core = [cd.x_m, cd.z_m, cd.pitch_rad, cd.u_m_s, cd.w_m_s, cd.q_rad_s].map(f64::from);
        // Scale: the largest force in the sums divided by the smallest inertia in play.
        let force = t1.abs() + t3.abs() + p.weight_n() * 0.03 + 20.0 * (u * u + w * w + q * q + 1.0);
        let scale = [2.0, 2.0, 2.0, force, force, force / 0.2];
        for i in 0..6 {
            prop_assert!(close(core[i], d[i], scale[i]),
                "state {} ({}): core {} vs plant {}", i, pxz::STATE_NAMES[i], core[i], d[i]);
        }
    }

    /// The same for the XY model (eq. 34 reduced).
    #[test]
    fn xy_core_model_matches_plant(
        psi in -3.2f64..3.2, u in -2.0f64..2.0, vv in -2.0f64..2.0, r in -2.0f64..2.0,
        t1 in -40.0f64..40.0, t2 in -5.0f64..5.0,
    ) {
        let v = Vehicle::observer();
        let p = params();
        let s = [1.0, 2.0, psi, u, vv, r];
        let d = pxy::derivatives(&p, &s, [t1, t2, 0.0], [0.0; 3]);
        let cs = XyState { x_m: 1.0, y_m: 2.0, yaw_rad: psi as f32, u_m_s: u as f32, v_m_s: vv as f32, r_rad_s: r as f32 };
        let cd = model::xy::derivative(&v, &cs, &BodyForces { surge_n: t1 as f32, yaw_n_m: t2 as f32, heave_n: 0.0 });
        let core = [cd.x_m, cd.y_m, cd.yaw_rad, cd.u_m_s, cd.v_m_s, cd.r_rad_s].map(f64::from);
        let force = t1.abs() + t2.abs() + 20.0 * (u * u + vv * vv + r * r + 1.0);
        let scale = [2.0, 2.0, 2.0, force, force, force / 0.2];
        for i in 0..6 {
            prop_assert!(close(core[i], d[i], scale[i]),
                "state {} ({}): core {} vs plant {}", i, pxy::STATE_NAMES[i], core[i], d[i]);
        }
    }

    /// A constant current seen from a vehicle drifting with it: no relative flow, so no
    /// hydrodynamic force; the vehicle keeps drifting at the current's velocity.
    #[test]
    fn drifting_with_the_current_is_an_equilibrium(cx in -0.3f64..0.3, cy in -0.3f64..0.3, psi in -3.0f64..3.0) {
        let p = params();
        let (s, c) = psi.sin_cos();
        // Body velocity equal to the current expressed in the body frame.
        let st = [0.0, 0.0, psi, c * cx + s * cy, -s * cx + c * cy, 0.0];
        let d = pxy::derivatives(&p, &st, [0.0; 3], [cx, cy, 0.0]);
        prop_assert!((d[0] - cx).abs() < 1e-12 && (d[1] - cy).abs() < 1e-12);
        for (i, di) in d.iter().enumerate().skip(2) {
            prop_assert!(di.abs() < 1e-12, "d[{}] = {}", i, di);
        }
    }
}

#[test]
fn xz_drifting_with_the_current_is_an_equilibrium() {
    let p = params();
    for (cx, cz) in [(0.2, 0.0), (-0.1, 0.05), (0.0, -0.2)] {
        let st = [0.0, 0.0, 0.0, cx, cz, 0.0];
        let d = pxz::derivatives(&p, &st, [0.0; 3], [cx, 0.0, cz]);
        assert!((d[0] - cx).abs() < 1e-12 && (d[1] - cz).abs() < 1e-12);
        for (i, di) in d.iter().enumerate().skip(2) {
            assert!(di.abs() < 1e-12, "d[{i}] = {di}");
        }
    }
}

#[test]
fn xz_rest_is_an_equilibrium_when_neutral() {
    let mut plant = XzPlant::new(
        &VehicleParams::OBSERVER,
        Environment::default(),
        true,
        PlantState::default(),
    );
    for _ in 0..10_000 {
        plant.step([0.0; 3], 1e-3);
    }
    let s = plant.state();
    assert!(
        s.eta.iter().chain(s.nu.iter()).all(|v| v.abs() < 1e-12),
        "{s:?}"
    );
}

#[test]
fn xz_buoyancy_offset_makes_it_rise() {
    let mut vp = VehicleParams::OBSERVER;
    vp.buoyancy_offset_n = 5.0;
    let mut plant = XzPlant::new(&vp, Environment::default(), true, PlantState::default());
    for _ in 0..60_000 {
        plant.step([0.0; 3], 1e-3);
    }
    // Terminal heave speed: Z_w w + Z_ww w^2 = 5 N upwards (w < 0 means up).
    let p = params();
    let w_term = -(-p.z_w + (p.z_w * p.z_w + 4.0 * p.z_ww * 5.0).sqrt()) / (2.0 * p.z_ww);
    let s = plant.state();
    assert!(
        (s.nu[2] - w_term).abs() < 1e-4,
        "w = {} vs {}",
        s.nu[2],
        w_term
    );
    assert!(s.eta[2] < -20.0);
}

#[test]
fn xz_pitch_is_pendulum_stable() {
    let init = PlantState {
        eta: [0.0, 0.0, 0.0, 0.0, 0.3, 0.0],
        ..PlantState::default()
    };
    let mut plant = XzPlant::new(&VehicleParams::OBSERVER, Environment::default(), true, init);
    let mut max_th: f64 = 0.0;
    for _ in 0..200_000 {
        plant.step([0.0; 3], 1e-3);
        max_th = max_th.max(plant.state().eta[4].abs());
    }
    assert!(max_th <= 0.3 + 1e-9, "pitch grew: {max_th}");
    assert!(plant.state().eta[4].abs() < 0.3, "pitch did not decay");
}

#[test]
fn xy_surge_reaches_drag_balance_speed() {
    let mut plant = XyPlant::new(
        &VehicleParams::OBSERVER,
        Environment::default(),
        true,
        PlantState::default(),
    );
    for _ in 0..60_000 {
        plant.step([5.0, 5.0, 0.0], 1e-3);
    }
    let p = params();
    // X_u u + X_uu u^2 = 10 N.
    let u = (-p.x_u + (p.x_u * p.x_u + 4.0 * p.x_uu * 10.0).sqrt()) / (2.0 * p.x_uu);
    let s = plant.state();
    assert!((s.nu[0] - u).abs() < 1e-6, "u = {} vs {}", s.nu[0], u);
    assert!(s.nu[1].abs() < 1e-12 && s.nu[5].abs() < 1e-12 && s.eta[5].abs() < 1e-12);
    assert!((plant.thrust_n()[0] - 5.0).abs() < 1e-9);
}

#[test]
fn thrusters_lag_and_saturate() {
    let vp = VehicleParams::OBSERVER;
    let tau = f64::from(vp.thruster_time_constant_s);
    let mut plant = XyPlant::new(&vp, Environment::default(), true, PlantState::default());
    let steps = (tau / 1e-3).round() as usize;
    for _ in 0..steps {
        plant.step([100.0, -100.0, 0.0], 1e-3);
    }
    // After one time constant: 1 - 1/e of the limited command.
    let f = plant.thrust_n();
    let e = 1.0 - (-1.0f64).exp();
    assert!((f[0] - 20.0 * e).abs() < 1e-6, "{f:?}");
    assert!((f[1] + 15.0 * e).abs() < 1e-6, "{f:?}");
    for _ in 0..5000 {
        plant.step([100.0, -100.0, 0.0], 1e-3);
    }
    let f = plant.thrust_n();
    assert!((f[0] - 20.0).abs() < 1e-9 && (f[1] + 15.0).abs() < 1e-9);
    // Without limits the command passes through.
    let mut free = XyPlant::new(&vp, Environment::default(), false, PlantState::default());
    for _ in 0..5000 {
        free.step([100.0, -100.0, 0.0], 1e-3);
    }
    assert!((free.thrust_n()[0] - 100.0).abs() < 1e-6);
}

#[test]
fn rk4_converges_at_fourth_order() {
    // Same manoeuvre at three step sizes; the error ratio must be about 2^4.
    let run = |dt: f64| {
        let init = PlantState {
            eta: [0.0, 0.0, 0.0, 0.0, 0.2, 0.0],
            nu: [0.3, 0.0, 0.1, 0.0, 0.2, 0.0],
        };
        let mut vp = VehicleParams::OBSERVER;
        vp.thruster_time_constant_s = 0.1;
        let mut p = XzPlant::new(
            &vp,
            Environment {
                current_m_s: [0.1, 0.0, 0.05],
            },
            true,
            init,
        );
        let n = (2.0 / dt).round() as usize;
        let per = (0.1 / dt).round() as usize;
        for i in 0..n {
            // Piecewise-constant commands on a 0.1 s grid (the same for every dt).
            let k = (i / per) as f64;
            p.step([5.0 + k, -3.0, 2.0 - 0.5 * k], dt);
        }
        p.plane_state()
    };
    let a = run(0.02);
    let b = run(0.01);
    let c = run(0.005);
    let e1: f64 = a.iter().zip(c.iter()).map(|(x, y)| (x - y).abs()).sum();
    let e2: f64 = b.iter().zip(c.iter()).map(|(x, y)| (x - y).abs()).sum();
    let ratio = e1 / e2;
    assert!(ratio > 10.0, "convergence ratio {ratio} (e1 {e1}, e2 {e2})");
}
