//! A compass calibration set while the estimator runs (the end of a calibration turn) carries
//! the heading and the compass-bias state with it: the corrected readings that follow agree
//! with the estimate, none is gated, nothing is reset, the heading does not move.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use controller_core::nav::compass_cal::CompassCalibration;
use controller_core::nav::onboard::{OnboardConfig, OnboardNav};
use controller_core::nav::{HeadingFix, ImuSample, PositionFix, GRAVITY_M_S2};
use controller_core::params::Vehicle;
use controller_core::state::NavState;

const HEADING_RAD: f32 = 0.5;
const HARD_IRON_RAD: f32 = 0.1745; // 10 deg
const PHASE_RAD: f32 = 0.7;

/// The raw compass at the (constant) heading: `psi + A sin(psi + phase)` plus a fixed
/// pattern of noise (+-0.02 rad).
fn raw_reading(k: u64) -> f32 {
    let noise = [
        0.013f32, -0.021, 0.004, 0.017, -0.009, -0.015, 0.022, -0.002,
    ];
    HEADING_RAD + HARD_IRON_RAD * (HEADING_RAD + PHASE_RAD).sin() + noise[(k % 8) as usize]
}

/// `seconds` at rest: IMU at 100 Hz, compass at 10 Hz, a USBL fix at the origin every 1 s.
fn run(nav: &mut OnboardNav, from_us: u64, seconds: u64) -> u64 {
    let mut t = from_us;
    for k in 1..=seconds * 100 {
        t = from_us + k * 10_000;
        let imu = ImuSample {
            t_us: t,
            gyro_rad_s: [0.0; 3],
            accel_m_s2: [0.0, 0.0, -GRAVITY_M_S2],
        };
        nav.imu(t, &imu, [0.0; 3]).unwrap();
        if k % 10 == 0 {
            let _ = nav.heading(&HeadingFix {
                t_us: t,
                yaw_rad: raw_reading(k / 10),
                std_rad: 0.02,
            });
        }
        if k % 100 == 0 {
            let _ = nav.position(&PositionFix {
                t_us: t,
                north_m: 0.0,
                east_m: 0.0,
                std_m: 0.3,
            });
        }
    }
    t
}

#[test]
fn a_calibration_swapped_in_carries_the_heading_and_the_bias() {
    let start = NavState {
        yaw_rad: HEADING_RAD,
        z_m: 2.0,
        ..NavState::default()
    };
    let mut nav =
        OnboardNav::new(Vehicle::observer(), OnboardConfig::default(), &start, 0, 0).unwrap();
    // Uncalibrated: the bias state takes up the deviation at this heading.
    let t = run(&mut nav, 0, 60);
    let before = nav.estimator().clone();
    let (b_before, _) = before.compass_bias_rad();
    let deviation = HARD_IRON_RAD * (HEADING_RAD + PHASE_RAD).sin();
    assert!(
        (b_before - deviation).abs() < 0.05,
        "bias {b_before} vs deviation {deviation}"
    );
    let yaw_before = before.state().yaw_rad;
    // The turn's fit: the deviation exactly.
    nav.set_compass_calibration(&CompassCalibration {
        sin_rad: HARD_IRON_RAD * PHASE_RAD.cos(),
        cos_rad: HARD_IRON_RAD * PHASE_RAD.sin(),
    })
    .unwrap();
    assert_eq!(
        nav.estimator().state().yaw_rad,
        yaw_before,
        "the heading stays"
    );
    let (b_after, _) = nav.estimator().compass_bias_rad();
    assert!(
        (b_after - (b_before - deviation)).abs() < 0.01,
        "bias after the swap {b_after}, expected {}",
        b_before - deviation
    );
    run(&mut nav, t, 30);
    let h0 = before.health();
    let h1 = nav.estimator().health();
    eprintln!("before {h0:?}\nafter {h1:?}");
    assert_eq!(h1.resets, h0.resets, "no reset after the swap");
    assert_eq!(h1.other_outliers, h0.other_outliers, "no heading gated");
    assert_eq!(h1.position_outliers, h0.position_outliers, "no fix refused");
    assert_eq!(h1.heading_fused - h0.heading_fused, 300);
    let yaw_after = nav.estimator().state().yaw_rad;
    assert!(
        (yaw_after - yaw_before).abs() < 0.01,
        "heading moved {} rad",
        yaw_after - yaw_before
    );
}

#[test]
fn a_calibration_set_before_any_heading_leaves_the_bias_prior() {
    let mut nav = OnboardNav::new(
        Vehicle::observer(),
        OnboardConfig::default(),
        &NavState::default(),
        0,
        0,
    )
    .unwrap();
    nav.set_compass_calibration(&CompassCalibration {
        sin_rad: 0.1,
        cos_rad: 0.05,
    })
    .unwrap();
    assert_eq!(nav.estimator().compass_bias_rad().0, 0.0);
}

/// A compass whose bias jumps (a thruster's field, a hard iron at a new heading) while the
/// gyro carries the heading: after the run of gated fixes the bias takes the jump and the
/// heading stays.
#[test]
fn a_jump_in_the_compass_bias_moves_the_bias_not_the_heading() {
    let start = NavState {
        yaw_rad: HEADING_RAD,
        z_m: 2.0,
        ..NavState::default()
    };
    let mut nav =
        OnboardNav::new(Vehicle::observer(), OnboardConfig::default(), &start, 0, 0).unwrap();
    let t = run(&mut nav, 0, 60);
    let yaw_before = nav.estimator().state().yaw_rad;
    let (b_before, _) = nav.estimator().compass_bias_rad();
    let resets = nav.estimator().health().resets;
    let jump = 0.15f32;
    for k in 1..=300u64 {
        let tk = t + k * 10_000;
        let imu = ImuSample {
            t_us: tk,
            gyro_rad_s: [0.0; 3],
            accel_m_s2: [0.0, 0.0, -GRAVITY_M_S2],
        };
        nav.imu(tk, &imu, [0.0; 3]).unwrap();
        if k % 10 == 0 {
            let _ = nav.heading(&HeadingFix {
                t_us: tk,
                yaw_rad: raw_reading(k / 10) + jump,
                std_rad: 0.02,
            });
        }
    }
    assert!(
        nav.estimator().health().resets > resets,
        "the gate saw the jump"
    );
    let yaw_after = nav.estimator().state().yaw_rad;
    let (b_after, _) = nav.estimator().compass_bias_rad();
    eprintln!("heading {yaw_before} -> {yaw_after}, bias {b_before} -> {b_after}");
    assert!(
        (yaw_after - yaw_before).abs() < 0.02,
        "heading moved to {yaw_after}"
    );
    assert!((b_after - b_before - jump).abs() < 0.02, "bias {b_after}");
}
