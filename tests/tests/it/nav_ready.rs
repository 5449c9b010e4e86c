//! On the firmware: the modes that need a position (`Track`, `Hold`, AUTO and
//! what the ground station's GUIDED and POSHOLD map to) are refused with the reason until the
//! on-board estimate is ready (`OnboardNav::position_ready`), like ArduSub's "EKF not ready".

// Test code: a failed expectation should stop the test.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use controller_core::nav::onboard::{OnboardConfig, PressureDepth};
use controller_core::nav::{ImuSample, NotReady, PositionFix, GRAVITY_M_S2};
use controller_core::state::NavState;
use firmware::protocol::{Board, Command, Mode, NackReason};
use firmware::Config;
use rov_tests::{app, nacked, TestApp, Topside};

/// One second of 50 Hz IMU samples at rest, pressures at 2 m, and a USBL fix of the origin
/// at its end (when `fix`), from `t0_us`.
fn second(a: &mut TestApp, t: &mut Topside, t0_us: u64, fix: bool) {
    let p = PressureDepth::SEA_WATER;
    for k in 1..=50u64 {
        let t_us = t0_us + k * 20_000;
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
                    pressure_pa: p.pressure_pa(2.0),
                },
            );
        }
        t.send(a, &Command::Step { t_us });
    }
    if fix {
        let (seq, r) = t.send(
            a,
            &Command::UsblFix(PositionFix {
                t_us: t0_us + 1_000_000,
                north_m: 0.0,
                east_m: 0.0,
                std_m: 0.3,
            }),
        );
        assert_eq!(nacked(&r, seq), None);
    }
}

#[test]
fn position_modes_are_refused_until_the_estimate_is_ready_then_accepted() {
    let (mut a, _c) = app(Config::lockstep(Board::Host));
    let mut t = Topside::default();
    t.send(&mut a, &Command::Heartbeat { t_us: 0 });
    // The launch point known to 5 m only.
    let mut config = OnboardConfig::default();
    config.nav.initial_position_std_m = 5.0;
    let (seq, r) = t.send(
        &mut a,
        &Command::StartNav {
            t_us: 0,
            initial: NavState {
                x_m: 3.0,
                z_m: 2.0,
                ..NavState::default()
            },
            config,
        },
    );
    assert_eq!(nacked(&r, seq), None);
    second(&mut a, &mut t, 0, false);
    let onboard = a.autopilot().onboard_nav().unwrap();
    assert_eq!(onboard.position_ready(), Err(NotReady::PositionUncertain));
    for mode in [Mode::Hold, Mode::Auto] {
        let (seq, r) = t.send(&mut a, &Command::SetMode(mode));
        assert_eq!(
            nacked(&r, seq),
            Some(NackReason::NavNotReady(NotReady::PositionUncertain)),
            "{mode:?}"
        );
    }
    // Modes without a position are not held back.
    let (seq, r) = t.send(&mut a, &Command::SetMode(Mode::DepthHold));
    assert_eq!(nacked(&r, seq), None);
    // A few USBL fixes: ready, and Hold is accepted.
    for s in 1..=3u64 {
        second(&mut a, &mut t, s * 1_000_000, true);
    }
    assert_eq!(
        a.autopilot().onboard_nav().unwrap().position_ready(),
        Ok(())
    );
    let (seq, r) = t.send(&mut a, &Command::SetMode(Mode::Hold));
    assert_eq!(nacked(&r, seq), None, "{r:?}");
}
