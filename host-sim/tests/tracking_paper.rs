//! The paper's reference (`x_r = y_r = z_r = h_r t^5 / (t^5 + (t_f - t)^5)`, `h_r = 10 m`,
//! `t_f = 100 s`) with the tracking laws on the nominal 6-DOF plant with thruster limits.
//! Issue 3 bounds: final position error <= 1 cm, max <= 5 cm after the first 10 s.

mod tracking_common;

use controller_core::controller::ControlMode;
use controller_core::params::VehicleParams;
use controller_core::reference::{PaperPolynomial, Reference};
use host_sim::plant::Environment;
use tracking_common::{at_rest, run};

#[test]
fn tracking_xz_paper_reference() {
    let r = Reference::Paper(PaperPolynomial::PAPER);
    let m = run(
        ControlMode::TrackingXz,
        &r,
        at_rest([0.0; 3], 0.0),
        &VehicleParams::OBSERVER,
        Environment::default(),
        120.0,
    );
    println!("tracking XZ, paper reference, 120 s: {m:?}");
    assert!(m.finite);
    assert!(m.final_err_m <= 0.01, "{m:?}");
    assert!(m.max_err_after_10s_m <= 0.05, "{m:?}");
}

#[test]
fn tracking_xy_paper_reference() {
    let r = Reference::Paper(PaperPolynomial::PAPER);
    let m = run(
        ControlMode::TrackingXy,
        &r,
        at_rest([0.0; 3], core::f64::consts::FRAC_PI_4),
        &VehicleParams::OBSERVER,
        Environment::default(),
        120.0,
    );
    println!("tracking XY, paper reference, 120 s: {m:?}");
    assert!(m.finite);
    assert!(m.final_err_m <= 0.01, "{m:?}");
    assert!(m.max_err_after_10s_m <= 0.05, "{m:?}");
}
