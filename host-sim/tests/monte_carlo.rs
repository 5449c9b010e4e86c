//! Monte Carlo: reproducible for a seed, different for another seed, perturbations bounded.

use controller_core::params::VehicleParams;
use host_sim::monte_carlo::{perturb_params, random_current, run_batch, McConfig};
use host_sim::scenario::{Plane, Scenario};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

const SHORT: &str = r#"
name = "mc-short"
plane = "xy"
controller = "paper"
duration_s = 4.0
[reference]
kind = "paper"
t_f_s = 20.0
[initial]
x_m = 0.2
[disturbance]
current_m_s = [0.1, 0.0, 0.0]
noise = true
delay_s = 0.01
"#;

fn cfg(seed: u64) -> McConfig {
    McConfig {
        runs: 8,
        seed,
        perturb: 0.2,
        progress: false,
    }
}

#[test]
fn batch_is_reproducible_for_a_seed() {
    let sc = Scenario::from_toml(SHORT, "short").unwrap();
    let (a, ra) = run_batch(&sc, &cfg(7)).unwrap();
    let (b, rb) = run_batch(&sc, &cfg(7)).unwrap();
    assert_eq!(a.runs, 8);
    assert_eq!(
        serde_json::to_string(&ra).unwrap(),
        serde_json::to_string(&rb).unwrap()
    );
    assert_eq!(a.rms_position_error_m, b.rms_position_error_m);
    assert_eq!(a.max_abs_thruster_force_n, b.max_abs_thruster_force_n);
    let (_, rc) = run_batch(&sc, &cfg(8)).unwrap();
    assert_ne!(
        serde_json::to_string(&ra).unwrap(),
        serde_json::to_string(&rc).unwrap(),
        "another seed must give other runs"
    );
    // Currents have the scenario's magnitude, in the plane.
    for r in &ra {
        let c = r.current_m_s;
        assert!(((c[0] * c[0] + c[1] * c[1]).sqrt() - 0.1).abs() < 1e-12 && c[2] == 0.0);
    }
}

#[test]
fn perturbation_is_bounded_and_touches_every_parameter() {
    let base = VehicleParams::OBSERVER;
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for _ in 0..200 {
        let p = perturb_params(&base, 0.2, &mut rng);
        p.validate().expect("perturbed set must stay physical");
        let pairs = [
            (base.mass_kg, p.mass_kg),
            (base.x_udot_kg, p.x_udot_kg),
            (base.y_vdot_kg, p.y_vdot_kg),
            (base.z_wdot_kg, p.z_wdot_kg),
            (base.m_qdot_kg_m2, p.m_qdot_kg_m2),
            (base.n_rdot_kg_m2, p.n_rdot_kg_m2),
            (base.x_u, p.x_u),
            (base.y_v, p.y_v),
            (base.z_w, p.z_w),
            (base.m_q, p.m_q),
            (base.n_r, p.n_r),
            (base.x_uu, p.x_uu),
            (base.y_vv, p.y_vv),
            (base.z_ww, p.z_ww),
            (base.m_qq, p.m_qq),
            (base.n_rr, p.n_rr),
            (base.i_x_kg_m2, p.i_x_kg_m2),
            (base.i_y_kg_m2, p.i_y_kg_m2),
            (base.i_z_kg_m2, p.i_z_kg_m2),
            (base.z_g_m, p.z_g_m),
        ];
        for (b, q) in pairs {
            let k = q / b - 1.0;
            assert!(k.abs() <= 0.2 + 1e-5, "{b} -> {q}");
            assert_ne!(b, q);
        }
        // The thrusters and gravity are not hydrodynamic or inertial: unchanged.
        assert_eq!(p.thrust_max_forward_n, base.thrust_max_forward_n);
        assert_eq!(p.gravity_m_s2, base.gravity_m_s2);
    }
    let c = random_current(Plane::ThreeD, 0.2, &mut rng);
    assert!(((c[0] * c[0] + c[1] * c[1]).sqrt() - 0.2).abs() < 1e-12 && c[2] == 0.0);
}
