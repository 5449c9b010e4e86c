//! The tracking laws against a constant ocean current and a buoyancy offset, and recovery
//! from a large initial offset under thruster saturation, on the 6-DOF plant with limits.
//! The controller always uses the nominal model (no current, neutral buoyancy); the integral
//! actions remove the offsets. The asserted bounds are the measured values rounded up
//! (docs/tracking.md lists the measured numbers).

use crate::tracking_common;

use controller_core::controller::ControlMode;
use controller_core::controller::Gains;
use controller_core::params::VehicleParams;
use controller_core::reference::{PaperPolynomial, Reference};
use sim_world::plant::Environment;
use sim_world::plant::PlantState;
use tracking_common::{at_rest, run, run_with, Metrics};

fn plant(offset_n: f32) -> VehicleParams {
    VehicleParams {
        buoyancy_offset_n: offset_n,
        ..VehicleParams::OBSERVER
    }
}

fn env(c: [f64; 3]) -> Environment {
    Environment { current_m_s: c }
}

fn circle() -> Reference {
    Reference::Circle {
        center_m: [0.0, 5.0, 2.0],
        radius_m: 5.0,
        speed_m_s: 0.25,
    }
}

fn report(name: &str, m: &Metrics) {
    println!("{name}: {m:?}");
    assert!(m.finite, "{name}");
    assert!(m.max_thrust_n <= 20.0 + 1e-9, "{name}");
}

fn observer_on() -> Gains {
    let mut g = Gains::default();
    g.tracking.current_observer_rad_s = 1.0;
    g
}

fn observer_off() -> Gains {
    let mut g = Gains::default();
    g.tracking.current_observer_rad_s = 0.0;
    g
}

/// Runs a case with the current observer off and on (1 rad/s, the default) and checks both
/// against their measured RMS bounds.
#[allow(clippy::too_many_arguments)]
fn both(
    name: &str,
    mode: ControlMode,
    r: &Reference,
    start: PlantState,
    p: &VehicleParams,
    e: Environment,
    t: f64,
    rms_off: f64,
    rms_on: f64,
) -> (Metrics, Metrics) {
    let off = run_with(observer_off(), mode, r, start, p, e, t);
    report(&format!("{name}, observer off"), &off);
    let on = run_with(observer_on(), mode, r, start, p, e, t);
    report(&format!("{name}, observer on"), &on);
    assert!(off.rms_last_80_m <= rms_off, "{name} off: {off:?}");
    assert!(on.rms_last_80_m <= rms_on, "{name} on: {on:?}");
    (off, on)
}

#[test]
fn tracking_3d_circle_current_02_buoyancy_5n() {
    // Measured RMS: 0.064 m (observer off), 0.056 m (on). Misses the 2 cm nominal bound.
    both(
        "3-D circle, current [0.2, 0, 0] m/s, +5 N",
        ControlMode::Tracking3d,
        &circle(),
        at_rest([0.0, 0.0, 2.0], 0.0),
        &plant(5.0),
        env([0.2, 0.0, 0.0]),
        150.0,
        0.07,
        0.062,
    );
}

#[test]
fn tracking_3d_circle_current_01_diag_buoyancy_minus5n() {
    // Measured RMS: 0.0215 m (off), 0.0058 m (on).
    let c = 0.1 / 2f64.sqrt();
    both(
        "3-D circle, current 0.1 m/s at 45 deg, -5 N",
        ControlMode::Tracking3d,
        &circle(),
        at_rest([0.0, 0.0, 2.0], 0.0),
        &plant(-5.0),
        env([c, c, 0.0]),
        150.0,
        0.024,
        0.0065,
    );
}

#[test]
fn tracking_3d_lawnmower_cross_current() {
    // Measured RMS: 0.071 m (off), 0.062 m (on).
    let r = Reference::Lawnmower {
        start_m: [0.0, 0.0, 3.0],
        heading_rad: 0.0,
        leg_length_m: 15.0,
        spacing_m: 5.0,
        legs: 3,
        speed_m_s: 0.25,
    };
    both(
        "3-D lawnmower, cross current [0, 0.2, 0] m/s, +5 N",
        ControlMode::Tracking3d,
        &r,
        at_rest([0.0, 0.0, 3.0], 0.0),
        &plant(5.0),
        env([0.0, 0.2, 0.0]),
        250.0,
        0.078,
        0.068,
    );
}

#[test]
fn tracking_xz_paper_current_and_buoyancy() {
    let m = run(
        ControlMode::TrackingXz,
        &Reference::Paper(PaperPolynomial::PAPER),
        at_rest([0.0; 3], 0.0),
        &plant(5.0),
        env([-0.2, 0.0, 0.0]),
        120.0,
    );
    report("XZ paper reference, current [-0.2, 0, 0] m/s, +5 N", &m);
    // Measured: final 0.6 um, max after 10 s 0.030 m, RMS 0.011 m.
    assert!(m.final_err_m <= 1e-3, "{m:?}");
    assert!(m.max_err_after_10s_m <= 0.032, "{m:?}");
    assert!(m.rms_last_80_m <= 0.012, "{m:?}");
}

#[test]
fn tracking_xy_paper_current() {
    // Measured: RMS 0.046 m, final 0.0013 m (off); RMS 0.032 m, final 0.0053 m (on) before
    // the current handling; RMS 0.017 m, final 0.0056 m (on) after it. The reference
    // ends in a hold, where a weather-vane swing dies out slowly (docs/tracking.md): the
    // final bound was 10 mm while the swing did not die out (8.6 mm), and is 6 mm again.
    let (off, on) = both(
        "XY paper reference, current [0, -0.2, 0] m/s",
        ControlMode::TrackingXy,
        &Reference::Paper(PaperPolynomial::PAPER),
        at_rest([0.0; 3], core::f64::consts::FRAC_PI_4),
        &plant(0.0),
        env([0.0, -0.2, 0.0]),
        120.0,
        0.05,
        0.02,
    );
    assert!(off.final_err_m <= 0.002, "{off:?}");
    assert!(on.final_err_m <= 0.006, "{on:?}");
}

#[test]
fn tracking_3d_recovers_from_large_offset_under_saturation() {
    let m = run(
        ControlMode::Tracking3d,
        &circle(),
        at_rest([-1.5, 1.0, 0.5], 0.8),
        &plant(0.0),
        env([0.0; 3]),
        150.0,
    );
    report("3-D circle from a 1.8 m / 0.8 rad offset", &m);
    // The recovery: the origin reaches the path in ~8 s, then the heading (the hand law's
    // zero dynamics) settles in a lightly damped swing of ~12 s period that decays ~4x per
    // cycle. Measured: final 0.004 mm, max 6.5 mm after 60 s, RMS over the last 80 %
    // (t >= 30 s) 11.05 mm. That RMS was 10.0 mm before the rest law (4e09b36), which starts
    // the vehicle on the line of sight instead of turning on the spot; its earlier bound of
    // 11 mm is now 12 mm, and the settling bound after 60 s is new.
    assert!(m.final_err_m <= 0.002, "{m:?}");
    assert!(m.max_err_after_60s_m <= 0.008, "{m:?}");
    assert!(m.rms_last_80_m <= 0.012, "{m:?}");
}

#[test]
fn tracking_xz_recovers_from_large_offset_under_saturation() {
    let m = run(
        ControlMode::TrackingXz,
        &Reference::Paper(PaperPolynomial::PAPER),
        at_rest([2.0, 0.0, -1.0], 0.0),
        &plant(0.0),
        env([0.0; 3]),
        120.0,
    );
    report("XZ paper reference from a 2 m / -1 m offset", &m);
    // Measured: final 6e-7 m, RMS 0.28 mm, peak thrust 13 N.
    assert!(m.final_err_m <= 1e-3, "{m:?}");
    assert!(m.rms_last_80_m <= 0.0004, "{m:?}");
}

/// Plant parameters (mass, inertias, added masses, drags, z_g) each scaled by a uniform
/// factor in [0.8, 1.2], a 0.1 m/s current in a random direction, circle-3d, 120 s; the
/// controller keeps the nominal model. 40 runs, deterministic seed. Returns sorted RMS errors
/// and the largest thrust.
fn perturbed(gains: Gains) -> (Vec<f64>, f64) {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let mut rms = vec![];
    let mut worst_thrust: f64 = 0.0;
    for _ in 0..40 {
        let mut k = || rng.random_range(0.8f32..1.2);
        let n = VehicleParams::OBSERVER;
        let p = VehicleParams {
            mass_kg: n.mass_kg * k(),
            x_udot_kg: n.x_udot_kg * k(),
            y_vdot_kg: n.y_vdot_kg * k(),
            z_wdot_kg: n.z_wdot_kg * k(),
            m_qdot_kg_m2: n.m_qdot_kg_m2 * k(),
            n_rdot_kg_m2: n.n_rdot_kg_m2 * k(),
            x_u: n.x_u * k(),
            y_v: n.y_v * k(),
            z_w: n.z_w * k(),
            m_q: n.m_q * k(),
            n_r: n.n_r * k(),
            x_uu: n.x_uu * k(),
            y_vv: n.y_vv * k(),
            z_ww: n.z_ww * k(),
            m_qq: n.m_qq * k(),
            n_rr: n.n_rr * k(),
            i_x_kg_m2: n.i_x_kg_m2 * k(),
            i_y_kg_m2: n.i_y_kg_m2 * k(),
            i_z_kg_m2: n.i_z_kg_m2 * k(),
            z_g_m: n.z_g_m * k(),
            ..n
        };
        let dir = rng.random_range(0.0..core::f64::consts::TAU);
        let m = run_with(
            gains,
            ControlMode::Tracking3d,
            &circle(),
            at_rest([0.0, 0.0, 2.0], 0.0),
            &p,
            env([0.1 * dir.cos(), 0.1 * dir.sin(), 0.0]),
            120.0,
        );
        assert!(m.finite);
        worst_thrust = worst_thrust.max(m.max_thrust_n);
        rms.push(m.rms_last_80_m);
    }
    rms.sort_by(f64::total_cmp);
    (rms, worst_thrust)
}

fn pct(v: &[f64], q: f64) -> f64 {
    v[((v.len() - 1) as f64 * q).round() as usize]
}

#[test]
fn tracking_3d_circle_perturbed_parameters_and_current() {
    for (name, g, p95_bound) in [
        ("observer off", observer_off(), 0.027),
        ("observer on", observer_on(), 0.027),
    ] {
        let (rms, thrust) = perturbed(g);
        println!(
            "3-D circle, +-20 % plant parameters, 0.1 m/s current, 40 runs, {name}: RMS p50 {:.4} p95 {:.4} max {:.4} m, max thrust {:.2} N",
            pct(&rms, 0.5),
            pct(&rms, 0.95),
            pct(&rms, 1.0),
            thrust
        );
        // Measured p95: 0.0246 m (off), 0.0245 m (on); max 0.026 / 0.042 m.
        assert!(pct(&rms, 0.95) <= p95_bound, "{name}");
        assert!(thrust <= 20.0 + 1e-9);
    }
}
