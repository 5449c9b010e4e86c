//! The tracking laws against a constant ocean current and a buoyancy offset, and recovery
//! from a large initial offset under thruster saturation, on the 6-DOF plant with limits.
//! The controller always uses the nominal model (no current, neutral buoyancy); the integral
//! actions remove the offsets. The asserted bounds are the measured values rounded up
//! (docs/tracking.md lists the measured numbers).

mod tracking_common;

use controller_core::controller::ControlMode;
use controller_core::params::VehicleParams;
use controller_core::reference::{PaperPolynomial, Reference};
use host_sim::plant::Environment;
use tracking_common::{at_rest, run, Metrics};

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

#[test]
fn tracking_3d_circle_current_02_buoyancy_5n() {
    let m = run(
        ControlMode::Tracking3d,
        &circle(),
        at_rest([0.0, 0.0, 2.0], 0.0),
        &plant(5.0),
        env([0.2, 0.0, 0.0]),
        150.0,
    );
    report("3-D circle, current [0.2, 0, 0] m/s, +5 N", &m);
    // Measured: RMS 0.163 m, final 0.44 m (misses the 2 cm nominal bound by far).
    assert!(m.rms_last_80_m <= 0.18, "{m:?}");
}

#[test]
fn tracking_3d_circle_current_01_diag_buoyancy_minus5n() {
    let c = 0.1 / 2f64.sqrt();
    let m = run(
        ControlMode::Tracking3d,
        &circle(),
        at_rest([0.0, 0.0, 2.0], 0.0),
        &plant(-5.0),
        env([c, c, 0.0]),
        150.0,
    );
    report("3-D circle, current 0.1 m/s at 45 deg, -5 N", &m);
    // Measured: RMS 0.040 m, final 0.023 m.
    assert!(m.rms_last_80_m <= 0.045, "{m:?}");
}

#[test]
fn tracking_3d_lawnmower_cross_current() {
    let r = Reference::Lawnmower {
        start_m: [0.0, 0.0, 3.0],
        heading_rad: 0.0,
        leg_length_m: 15.0,
        spacing_m: 5.0,
        legs: 3,
        speed_m_s: 0.25,
    };
    let m = run(
        ControlMode::Tracking3d,
        &r,
        at_rest([0.0, 0.0, 3.0], 0.0),
        &plant(5.0),
        env([0.0, 0.2, 0.0]),
        250.0,
    );
    report("3-D lawnmower, cross current [0, 0.2, 0] m/s, +5 N", &m);
    // Measured: RMS 0.188 m, final 0.092 m.
    assert!(m.rms_last_80_m <= 0.2, "{m:?}");
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
    // Measured: final 1.4e-6 m, max after 10 s 0.071 m, RMS 0.030 m.
    assert!(m.final_err_m <= 1e-3, "{m:?}");
    assert!(m.max_err_after_10s_m <= 0.075, "{m:?}");
    assert!(m.rms_last_80_m <= 0.032, "{m:?}");
}

#[test]
fn tracking_xy_paper_current() {
    let m = run(
        ControlMode::TrackingXy,
        &Reference::Paper(PaperPolynomial::PAPER),
        at_rest([0.0; 3], core::f64::consts::FRAC_PI_4),
        &plant(0.0),
        env([0.0, -0.2, 0.0]),
        120.0,
    );
    report("XY paper reference, current [0, -0.2, 0] m/s", &m);
    // Measured: final 0.0105 m, RMS 0.085 m.
    assert!(m.final_err_m <= 0.015, "{m:?}");
    assert!(m.rms_last_80_m <= 0.09, "{m:?}");
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
    // Measured: final 0.9 mm, RMS over the last 80 % 0.060 m (the first 30 s of recovery).
    assert!(m.final_err_m <= 0.002, "{m:?}");
    assert!(m.rms_last_80_m <= 0.065, "{m:?}");
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
    // Measured: final 6e-7 m, RMS 1.1 mm.
    assert!(m.final_err_m <= 1e-3, "{m:?}");
    assert!(m.rms_last_80_m <= 0.002, "{m:?}");
}
