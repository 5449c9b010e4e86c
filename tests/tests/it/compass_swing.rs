//! The compass calibration turn (`StartCompassCal`, the ground station's
//! `MAV_CMD_DO_START_MAG_CAL`) is flown only armed in `Hold` with the on-board estimator:
//! refused disarmed (`NotArmed`), in the other modes (`NotInHold`: `Idle`, `DepthHold`;
//! AUTO and `Track` likewise), with a rate or limit out of range (`OutOfRange`), each
//! changing nothing; a mode change stops a turn in flight (`Aborted`) and the calibration in
//! force stays. The flown turn's fit is tested in closed loop in
//! `host-sim/tests/it/nav_compass_cal_flown.rs`.

// Test code: a failed expectation should stop the test.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use controller_core::nav::compass_cal::CompassCalibration;
use controller_core::nav::onboard::{OnboardConfig, PressureDepth};
use controller_core::nav::{HeadingFix, ImuSample, GRAVITY_M_S2};
use controller_core::state::NavState;
use firmware::compass_swing::SwingOutcome;
use firmware::protocol::{Board, Command, Mode, NackReason, Reply};
use firmware::Config;
use rov_tests::{app, TestApp, Topside};

fn sent(a: &mut TestApp, t: &mut Topside, cmd: &Command) -> Option<NackReason> {
    let (seq, r) = t.send(a, cmd);
    r.iter().find_map(|r| match r {
        Reply::Nack { seq: s, reason } if *s == seq => Some(*reason),
        _ => None,
    })
}

/// The estimator started at a known point and fed 1 s of a still vehicle (so it is fresh
/// and ready), up to `t_us`.
fn feed(a: &mut TestApp, t: &mut Topside, from_k: u64, to_k: u64) -> Option<SwingOutcome> {
    let mut outcome = None;
    for k in from_k..=to_k {
        let t_us = k * 20_000;
        let (_, r) = t.send(a, &Command::Heartbeat { t_us });
        for reply in &r {
            if let Reply::Status(st) = reply {
                outcome = Some(st.compass_swing);
            }
        }
        let imu = ImuSample {
            t_us,
            gyro_rad_s: [0.0; 3],
            accel_m_s2: [0.0, 0.0, -GRAVITY_M_S2],
        };
        t.send(a, &Command::Imu(imu));
        if k % 5 == 0 {
            let pressure_pa = PressureDepth::SEA_WATER.pressure_pa(2.0);
            t.send(a, &Command::Pressure { t_us, pressure_pa });
            let fix = HeadingFix {
                t_us,
                yaw_rad: 0.0,
                std_rad: 0.02,
            };
            t.send(a, &Command::Compass(fix));
        }
        t.send(a, &Command::Step { t_us });
    }
    outcome
}

fn start(rate: f32, limit: f32) -> Command {
    Command::StartCompassCal {
        yaw_rate_rad_s: rate,
        time_limit_s: limit,
    }
}

#[test]
fn the_turn_is_flown_only_armed_in_hold_and_a_mode_change_stops_it() {
    let (mut a, _c) = app(Config::lockstep(Board::Host));
    let mut t = Topside::default();
    let initial = NavState {
        z_m: 2.0,
        ..NavState::default()
    };
    let config = OnboardConfig::default();
    let start_nav = Command::StartNav {
        t_us: 0,
        initial,
        config,
    };
    assert_eq!(sent(&mut a, &mut t, &start_nav), None);
    feed(&mut a, &mut t, 1, 50);
    // Disarmed.
    assert_eq!(
        sent(&mut a, &mut t, &start(0.25, 60.0)),
        Some(NackReason::NotArmed)
    );
    // Armed in Idle, then in DepthHold: not a position-holding context.
    assert_eq!(sent(&mut a, &mut t, &Command::Arm), None);
    assert_eq!(
        sent(&mut a, &mut t, &start(0.25, 60.0)),
        Some(NackReason::NotInHold)
    );
    assert_eq!(
        sent(&mut a, &mut t, &Command::SetMode(Mode::DepthHold)),
        None
    );
    assert_eq!(
        sent(&mut a, &mut t, &start(0.25, 60.0)),
        Some(NackReason::NotInHold)
    );
    // In Hold: a rate or a limit out of range, NaN included.
    assert_eq!(sent(&mut a, &mut t, &Command::SetMode(Mode::Hold)), None);
    for (rate, limit) in [
        (1.0, 60.0),
        (0.01, 60.0),
        (f32::NAN, 60.0),
        (0.25, 0.0),
        (0.25, 1e4),
    ] {
        assert_eq!(
            sent(&mut a, &mut t, &start(rate, limit)),
            Some(NackReason::OutOfRange),
            "{rate} {limit}"
        );
    }
    assert_eq!(
        feed(&mut a, &mut t, 51, 52),
        Some(SwingOutcome::None),
        "nothing started"
    );
    // Accepted: it flies (a yaw moment) until a mode change stops it.
    assert_eq!(sent(&mut a, &mut t, &start(0.25, 60.0)), None);
    let flying = feed(&mut a, &mut t, 53, 60);
    assert!(
        matches!(flying, Some(SwingOutcome::Turning { .. })),
        "{flying:?}"
    );
    assert_eq!(
        sent(&mut a, &mut t, &Command::SetMode(Mode::DepthHold)),
        None
    );
    assert_eq!(feed(&mut a, &mut t, 61, 62), Some(SwingOutcome::Aborted));
    assert_eq!(
        a.autopilot().compass_calibration(),
        CompassCalibration::NONE,
        "the calibration in force stays"
    );
}
