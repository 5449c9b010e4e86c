//! The compass calibration (`COMPASS_DEV_SIN` / `COMPASS_DEV_COS` at the ground
//! station) reaches the vehicle as `SetCompassCal`; the on-board estimator takes the
//! deviation off every heading; a calibration out of range, not finite, or sent while armed
//! is refused with the reason and the one in force stays.

// Test code: a failed expectation should stop the test.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use controller_core::nav::compass_cal::{CalRefusal, CompassCalibration};
use controller_core::nav::onboard::{OnboardConfig, PressureDepth};
use controller_core::nav::{HeadingFix, ImuSample, GRAVITY_M_S2};
use controller_core::state::NavState;
use firmware::protocol::{Board, Command, NackReason};
use firmware::Config;
use rov_tests::{app, nacked, TestApp, Topside};

fn set(a: &mut TestApp, t: &mut Topside, cal: CompassCalibration) -> Option<NackReason> {
    let (seq, r) = t.send(a, &Command::SetCompassCal(cal));
    nacked(&r, seq)
}

/// 5 degrees of hard iron in the cosine: at heading 0 the compass reads 5 degrees.
const FIVE_DEG_COS: CompassCalibration = CompassCalibration {
    sin_rad: 0.0,
    cos_rad: 0.087_266_46,
};

/// Start the estimator at heading 0 and feed it 10 s of a still vehicle whose compass reads
/// `reading_rad`; the estimate's heading at the end.
fn heading_after_readings(a: &mut TestApp, t: &mut Topside, reading_rad: f32) -> f32 {
    let (seq, r) = t.send(
        a,
        &Command::StartNav {
            t_us: 0,
            initial: NavState {
                z_m: 2.0,
                ..NavState::default()
            },
            config: OnboardConfig::default(),
        },
    );
    assert_eq!(nacked(&r, seq), None);
    for k in 1..=500u64 {
        let t_us = k * 20_000;
        t.send(a, &Command::Heartbeat { t_us });
        t.send(
            a,
            &Command::Imu(ImuSample {
                t_us,
                gyro_rad_s: [0.0; 3],
                accel_m_s2: [0.0, 0.0, -GRAVITY_M_S2],
            }),
        );
        if k % 5 == 0 {
            t.send(
                a,
                &Command::Pressure {
                    t_us,
                    pressure_pa: PressureDepth::SEA_WATER.pressure_pa(2.0),
                },
            );
        }
        t.send(a, &Command::Step { t_us });
        if k % 5 == 0 {
            let (seq, r) = t.send(
                a,
                &Command::Compass(HeadingFix {
                    t_us,
                    yaw_rad: reading_rad,
                    std_rad: 0.02,
                }),
            );
            assert_eq!(nacked(&r, seq), None);
        }
    }
    a.autopilot()
        .onboard_nav()
        .unwrap()
        .estimator()
        .state()
        .yaw_rad
}

#[test]
fn the_estimator_takes_the_calibrations_deviation_off_each_heading() {
    // Calibrated: a reading of 5 degrees at heading 0 is heading 0; nothing moves.
    let (mut a, _c) = app(Config::lockstep(Board::Host));
    let mut t = Topside::default();
    assert_eq!(set(&mut a, &mut t, FIVE_DEG_COS), None);
    let calibrated = heading_after_readings(&mut a, &mut t, 5f32.to_radians());
    assert_eq!(
        a.autopilot().onboard_nav().unwrap().compass_calibration(),
        FIVE_DEG_COS
    );
    // Not calibrated: the same readings pull the heading (and the bias state) away.
    let (mut b, _c) = app(Config::lockstep(Board::Host));
    let mut t = Topside::default();
    let raw = heading_after_readings(&mut b, &mut t, 5f32.to_radians());
    println!(
        "heading after 10 s of 5 deg readings at heading 0: calibrated {:.3} deg, not {:.3} deg",
        calibrated.to_degrees(),
        raw.to_degrees()
    );
    assert!(calibrated.abs() < 0.1f32.to_radians(), "{calibrated}");
    assert!(raw > 0.5f32.to_radians(), "{raw}");
    // The filter splits the 5 degrees between the heading and its bias state (1.0 deg
    // measured): well clear of the calibrated 0.
}

#[test]
fn bad_calibrations_are_refused_with_the_reason_and_the_old_one_stays() {
    let (mut a, _c) = app(Config::lockstep(Board::Host));
    let mut t = Topside::default();
    assert_eq!(set(&mut a, &mut t, FIVE_DEG_COS), None);
    let too_large = CompassCalibration {
        sin_rad: 0.4,
        cos_rad: 0.4,
    };
    assert_eq!(
        set(&mut a, &mut t, too_large),
        Some(NackReason::CompassCal(CalRefusal::OutOfRange))
    );
    let nan = CompassCalibration {
        sin_rad: f32::NAN,
        cos_rad: 0.0,
    };
    assert_eq!(
        set(&mut a, &mut t, nan),
        Some(NackReason::CompassCal(CalRefusal::NonFinite))
    );
    assert_eq!(a.autopilot().compass_calibration(), FIVE_DEG_COS);
}

#[test]
fn a_calibration_is_refused_while_armed() {
    let (mut a, _c) = app(Config::lockstep(Board::Host));
    let mut t = Topside::default();
    heading_after_readings(&mut a, &mut t, 0.0);
    let (seq, r) = t.send(&mut a, &Command::Arm);
    assert_eq!(nacked(&r, seq), None, "{r:?}");
    assert_eq!(set(&mut a, &mut t, FIVE_DEG_COS), Some(NackReason::Armed));
    assert_eq!(
        a.autopilot().compass_calibration(),
        CompassCalibration::NONE
    );
}
