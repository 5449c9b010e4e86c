//! The 3-D tracking law (hand-position XY law + depth by heave) on the nominal 6-DOF plant
//! with thruster limits, on the built-in scenarios' references (circle-3d, lawnmower-3d,
//! helix-3d). Bound: RMS position error <= 2 cm over the last 80 % of the run.

use crate::tracking_common;

use controller_core::controller::ControlMode;
use controller_core::params::VehicleParams;
use controller_core::reference::Reference;
use sim_world::plant::Environment;
use tracking_common::{at_rest, run, Metrics};

fn nominal(r: Reference, start: [f64; 3], t: f64) -> Metrics {
    run(
        ControlMode::Tracking3d,
        &r,
        at_rest(start, 0.0),
        &VehicleParams::OBSERVER,
        Environment::default(),
        t,
    )
}

fn circle() -> Reference {
    Reference::Circle {
        center_m: [0.0, 5.0, 2.0],
        radius_m: 5.0,
        speed_m_s: 0.25,
    }
}

#[test]
fn tracking_3d_circle() {
    let m = nominal(circle(), [0.0, 0.0, 2.0], 150.0);
    println!("tracking 3-D, circle-3d, 150 s: {m:?}");
    assert!(m.finite);
    assert!(m.rms_last_80_m <= 0.02, "{m:?}");
}

#[test]
fn tracking_3d_lawnmower() {
    let r = Reference::Lawnmower {
        start_m: [0.0, 0.0, 3.0],
        heading_rad: 0.0,
        leg_length_m: 15.0,
        spacing_m: 5.0,
        legs: 3,
        speed_m_s: 0.25,
    };
    let m = nominal(r, [0.0, 0.0, 3.0], 250.0);
    println!("tracking 3-D, lawnmower-3d, 250 s: {m:?}");
    assert!(m.finite);
    assert!(m.rms_last_80_m <= 0.02, "{m:?}");
}

#[test]
fn tracking_3d_helix() {
    let r = Reference::Helix {
        center_m: [0.0, 5.0, 1.0],
        radius_m: 5.0,
        speed_m_s: 0.25,
        depth_rate_m_s: 0.05,
    };
    let m = nominal(r, [0.0, 0.0, 1.0], 150.0);
    println!("tracking 3-D, helix-3d, 150 s: {m:?}");
    assert!(m.finite);
    assert!(m.rms_last_80_m <= 0.02, "{m:?}");
}

/// Faster than the scenarios: the yaw dynamics of the hand point need `eps > 0.28 U`
/// (`eps = 0.2 m` -> U < 0.7 m/s linearized; quadratic sway drag adds damping).
#[test]
fn tracking_3d_fast_line_from_offset_and_fast_circle() {
    for (v, line_final, line_rms, circle_rms) in
        // The 0.5 m/s line's RMS bound went from 12 to 13 mm with the current handling
        // (11.8 -> 12.1 mm: the start transient reads briefly as a current; the issue allows
        // still water 1 mm worse).
        [(0.5f32, 0.004, 0.013, 1e-4), (1.0, 0.035, 0.03, 3e-4)]
    {
        let line = Reference::Line {
            start_m: [0.0, 0.0, 1.0],
            heading_rad: 0.0,
            speed_m_s: v,
        };
        let m = run(
            ControlMode::Tracking3d,
            &line,
            at_rest([0.0, 0.3, 1.0], 0.3),
            &VehicleParams::OBSERVER,
            Environment::default(),
            120.0,
        );
        println!("tracking 3-D, line {v} m/s from 0.3 m / 0.3 rad, 120 s: {m:?}");
        assert!(
            m.final_err_m <= line_final && m.rms_last_80_m <= line_rms,
            "{m:?}"
        );
        let c = Reference::Circle {
            center_m: [0.0, 5.0, 1.0],
            radius_m: 5.0,
            speed_m_s: v,
        };
        let m = nominal(c, [0.0, 0.0, 1.0], 120.0);
        println!("tracking 3-D, circle R 5 m at {v} m/s, 120 s: {m:?}");
        assert!(m.rms_last_80_m <= circle_rms, "{m:?}");
    }
}
