//! The firmware with its estimator on board: sensor readings and fixes over the
//! tether, refusals with a reason that leave the estimate unchanged, the sensor failsafe.

// Test code: a failed expectation should stop the test.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use controller_core::nav::onboard::{OnboardConfig, PressureDepth};
use controller_core::nav::{DvlFix, HeadingFix, ImuSample, PositionFix, Refusal, GRAVITY_M_S2};
use controller_core::reference::Reference;
use controller_core::state::NavState;
use firmware::protocol::{
    fault, Board, Command, Mode, NackReason, NavSample, Reply, Status, Telemetry,
};
use firmware::Config;
use rov_tests::{app, nacked, FakeClock, TestApp, Topside};

const NEUTRAL_US: f32 = 1500.0;

fn telemetry(replies: &[Reply]) -> Option<Telemetry> {
    replies.iter().rev().find_map(|r| match r {
        Reply::Telemetry(t) => Some(*t),
        _ => None,
    })
}

fn status(a: &mut TestApp, t: &mut Topside, t_us: u64) -> Status {
    let (_, r) = t.send(a, &Command::Heartbeat { t_us });
    r.iter()
        .find_map(|r| match r {
            Reply::Status(s) => Some(*s),
            _ => None,
        })
        .expect("a Status answers the heartbeat")
}

fn level_imu(t_us: u64) -> Command {
    Command::Imu(ImuSample {
        t_us,
        gyro_rad_s: [0.0; 3],
        accel_m_s2: [0.0, 0.0, -GRAVITY_M_S2],
    })
}

/// A lock-step firmware with its estimator started at the origin, 2 m deep, at t = 0.
fn started() -> (TestApp, FakeClock, Topside) {
    let (mut a, c) = app(Config::lockstep(Board::Host));
    let mut t = Topside::default();
    t.send(&mut a, &Command::Heartbeat { t_us: 0 });
    let initial = NavState {
        z_m: 2.0,
        ..NavState::default()
    };
    let (seq, r) = t.send(
        &mut a,
        &Command::StartNav {
            t_us: 0,
            initial,
            config: OnboardConfig::default(),
        },
    );
    assert!(r.contains(&Reply::Ack { seq }), "{r:?}");
    (a, c, t)
}

/// Feed `n` control periods of 20 ms from `t0_us`: an IMU sample each, a pressure reading at
/// 2 m every fifth, and a `Step`; returns the last telemetry.
fn fly(a: &mut TestApp, t: &mut Topside, t0_us: u64, n: u64) -> Telemetry {
    let p = PressureDepth::SEA_WATER;
    let mut last = None;
    for k in 1..=n {
        let t_us = t0_us + k * 20_000;
        t.send(a, &Command::Heartbeat { t_us });
        let (seq, r) = t.send(a, &level_imu(t_us));
        assert_eq!(nacked(&r, seq), None);
        if k % 5 == 0 {
            let (seq, r) = t.send(
                a,
                &Command::Pressure {
                    t_us,
                    pressure_pa: p.pressure_pa(2.0),
                },
            );
            assert_eq!(nacked(&r, seq), None);
        }
        let (_, r) = t.send(a, &Command::Step { t_us });
        last = telemetry(&r);
    }
    last.expect("each Step is answered by Telemetry")
}

#[test]
fn the_estimate_is_in_telemetry_and_its_counters_in_status() {
    let (mut a, _c, mut t) = started();
    let tel = fly(&mut a, &mut t, 0, 50);
    assert!((tel.nav.z_m - 2.0).abs() < 0.01, "{:?}", tel.nav);
    assert!(tel.nav_pos_std_m.iter().all(|s| *s > 0.0 && *s < 1.0));
    assert_eq!(tel.faults & fault::SENSOR_LOST, 0);
    let st = status(&mut a, &mut t, 1_000_000);
    assert_eq!(st.nav_health.imu_samples, 50);
    assert_eq!(st.nav_health.depth_fused, 10);
}

#[test]
fn bad_fixes_are_refused_with_a_reason_and_change_nothing() {
    let (mut a, _c, mut t) = started();
    // 4 s: longer than the estimator's 2.56 s history, so a fix can be too old.
    fly(&mut a, &mut t, 0, 200);
    let before = a.autopilot().nav_state();
    let health = a.autopilot().onboard_nav().unwrap().estimator().health();
    let fix = PositionFix {
        t_us: 3_900_000,
        north_m: 0.1,
        east_m: 0.1,
        std_m: 0.5,
    };
    let cases = [
        (
            Command::UsblFix(PositionFix {
                north_m: f32::NAN,
                ..fix
            }),
            Refusal::NonFinite,
        ),
        (
            Command::UsblFix(PositionFix {
                north_m: 1.0e7,
                ..fix
            }),
            Refusal::OutOfRange,
        ),
        (
            Command::UsblFix(PositionFix {
                t_us: 9_000_000,
                ..fix
            }),
            Refusal::InFuture,
        ),
        (
            Command::UsblFix(PositionFix { t_us: 1, ..fix }),
            Refusal::TooOld,
        ),
        (
            Command::UsblFix(PositionFix { std_m: 0.0, ..fix }),
            Refusal::BadAccuracy,
        ),
        (
            Command::DvlFix(DvlFix {
                t_us: 4_000_000,
                velocity_m_s: [f32::INFINITY, 0.0],
                std_m_s: 0.01,
            }),
            Refusal::NonFinite,
        ),
        (
            Command::Compass(HeadingFix {
                t_us: 4_000_000,
                yaw_rad: 0.0,
                std_rad: -1.0,
            }),
            Refusal::BadAccuracy,
        ),
        (
            Command::Pressure {
                t_us: 4_000_000,
                pressure_pa: f32::NAN,
            },
            Refusal::NonFinite,
        ),
    ];
    for (cmd, why) in cases {
        let (seq, r) = t.send(&mut a, &cmd);
        assert_eq!(
            nacked(&r, seq),
            Some(NackReason::NavRefused(why)),
            "{cmd:?}"
        );
        assert_eq!(a.autopilot().nav_state(), before, "{cmd:?}");
    }
    let after = a.autopilot().onboard_nav().unwrap().estimator().health();
    assert_eq!(after.invalid, health.invalid + 8);
    // A good fix is taken.
    let (seq, r) = t.send(&mut a, &Command::UsblFix(fix));
    assert!(r.contains(&Reply::Ack { seq }), "{r:?}");
}

#[test]
fn the_two_sources_do_not_mix() {
    // Sensor readings without the estimator: refused.
    let (mut a, _c) = app(Config::lockstep(Board::Host));
    let mut t = Topside::default();
    let (seq, r) = t.send(&mut a, &level_imu(20_000));
    assert_eq!(nacked(&r, seq), Some(NackReason::NavSource));
    // A `Nav` while it runs: refused; after `StopNav`, taken again.
    let (mut a, _c, mut t) = started();
    let nav = Command::Nav(NavSample {
        t_us: 20_000,
        state: NavState::default(),
    });
    let (seq, r) = t.send(&mut a, &nav);
    assert_eq!(nacked(&r, seq), Some(NackReason::NavSource));
    t.send(&mut a, &Command::StopNav);
    let (seq, r) = t.send(&mut a, &nav);
    assert_eq!(nacked(&r, seq), None);
    assert!(telemetry(&r).is_some());
    // A `Step` is a lock-step command (another firmware: another session).
    let (mut a, _c) = app(Config::fixed_rate(Board::Host));
    let mut t = Topside::default();
    let (seq, r) = t.send(&mut a, &Command::Step { t_us: 0 });
    assert_eq!(nacked(&r, seq), Some(NackReason::Unsupported));
}

#[test]
fn a_quiet_imu_puts_the_thrusters_to_neutral_with_sensor_lost() {
    let (mut a, _c, mut t) = started();
    fly(&mut a, &mut t, 0, 25);
    for cmd in [
        Command::SetReference {
            reference: Reference::Hold {
                pos_m: [1.0, 0.0, 2.0],
            },
            start_us: None,
        },
        Command::SetMode(Mode::Hold),
        Command::Arm,
    ] {
        let (seq, r) = t.send(&mut a, &cmd);
        assert!(r.contains(&Reply::Ack { seq }), "{cmd:?}: {r:?}");
    }
    let tel = fly(&mut a, &mut t, 500_000, 10);
    assert!(tel.armed && tel.faults & fault::SENSOR_LOST == 0);
    // The IMU stops; heartbeats and steps go on.
    let mut lost_at = None;
    for k in 1..=20u64 {
        let t_us = 700_000 + k * 20_000;
        t.send(&mut a, &Command::Heartbeat { t_us });
        let (_, r) = t.send(&mut a, &Command::Step { t_us });
        let tel = telemetry(&r).unwrap();
        if tel.faults & fault::SENSOR_LOST != 0 {
            assert!(tel.pulse_us.iter().all(|&p| f32::from(p) == NEUTRAL_US));
            lost_at.get_or_insert(k * 20_000);
        }
    }
    // Within the IMU timeout (0.1 s) plus one step.
    let lost_after_us = lost_at.expect("SENSOR_LOST raised");
    assert!(lost_after_us <= 120_000, "{lost_after_us}");
}

/// The board's own sensors, as the fixed-rate loop reads them: a level IMU and a pressure at
/// 2 m, until the test makes the IMU stop answering or read absurd values.
#[derive(Debug, Clone, Default)]
struct FakeSensors(std::rc::Rc<std::cell::Cell<ImuState>>);

#[derive(Debug, Clone, Copy, Default, PartialEq)]
enum ImuState {
    #[default]
    Answers,
    Silent,
    Absurd,
}

impl firmware::Sensors for FakeSensors {
    fn imu(&mut self, now_us: u64) -> Option<ImuSample> {
        let accel_z = match self.0.get() {
            ImuState::Answers => -GRAVITY_M_S2,
            ImuState::Silent => return None,
            ImuState::Absurd => 1.0e6,
        };
        Some(ImuSample {
            t_us: now_us,
            gyro_rad_s: [0.0; 3],
            accel_m_s2: [0.0, 0.0, accel_z],
        })
    }

    fn pressure_pa(&mut self, _now_us: u64) -> Option<f32> {
        Some(PressureDepth::SEA_WATER.pressure_pa(2.0))
    }
}

#[test]
fn the_board_reads_its_own_sensors_and_a_quiet_or_absurd_imu_is_a_failsafe() {
    use firmware::protocol::{Decoded, FrameDecoder};
    use firmware::App;
    use rov_tests::{controller, FakePwm, FakeSerial, PWM_MAX_DUTY};
    let clock = FakeClock::default();
    let sensors = FakeSensors::default();
    let pwm = [
        FakePwm::new(PWM_MAX_DUTY),
        FakePwm::new(PWM_MAX_DUTY),
        FakePwm::new(PWM_MAX_DUTY),
    ];
    let mut a = App::with_sensors(
        pwm,
        FakeSerial::default(),
        clock.clone(),
        controller(),
        Config::fixed_rate(Board::Host),
        sensors.clone(),
    )
    .unwrap();
    let mut top = Topside::default();
    top.open(&mut a);
    let mut decoder = FrameDecoder::<Reply>::new();
    let mut send = |a: &mut App<_, FakeSerial, _, _>, cmd: &Command| {
        let (_, f) = top.frame(cmd);
        a.parts_mut().1.rx.extend(f);
        a.tick();
    };
    let initial = NavState {
        x_m: 1.0,
        z_m: 2.0,
        ..NavState::default()
    };
    send(&mut a, &Command::Heartbeat { t_us: 0 });
    send(
        &mut a,
        &Command::StartNav {
            t_us: 0,
            initial,
            config: OnboardConfig::default(),
        },
    );
    for cmd in [Command::SetMode(Mode::Hold), Command::Arm] {
        send(&mut a, &cmd);
    }
    // 2 s of 50 Hz loop passes with heartbeats; the estimator runs on the fake sensors.
    let mut run = |a: &mut App<_, FakeSerial, _, _>, ms: u64| {
        let mut faults_at = Vec::new();
        for _ in 0..ms / 5 {
            clock.advance_us(5_000);
            if clock.get_us() % 100_000 == 0 {
                send(
                    a,
                    &Command::Heartbeat {
                        t_us: clock.get_us(),
                    },
                );
            }
            a.tick();
            faults_at.push((
                clock.get_us(),
                a.last_output().faults,
                a.last_output().pulse_us,
            ));
        }
        faults_at
    };
    let faults_at = run(&mut a, 2_000);
    let est = a.autopilot().nav_state();
    assert!(a.autopilot().armed());
    assert!(
        (est.z_m - 2.0).abs() < 0.02 && (est.x_m - 1.0).abs() < 0.05,
        "{est:?}"
    );
    let health = a.autopilot().onboard_nav().unwrap().estimator().health();
    assert!(health.imu_samples >= 99, "{health:?}");
    assert!(health.depth_fused >= 19, "{health:?}");
    assert!(faults_at
        .iter()
        .all(|(_, f, _)| f & fault::SENSOR_LOST == 0));
    for (state, name) in [(ImuState::Silent, "silent"), (ImuState::Absurd, "absurd")] {
        sensors.0.set(state);
        let t0 = clock.get_us();
        let faults_at = run(&mut a, 500);
        let lost = faults_at
            .iter()
            .find(|(_, f, _)| f & fault::SENSOR_LOST != 0)
            .unwrap_or_else(|| panic!("{name} IMU: no SENSOR_LOST"));
        assert!(
            lost.0 - t0 <= 125_000,
            "{name}: SENSOR_LOST after {} us",
            lost.0 - t0
        );
        assert!(
            lost.2.iter().all(|&p| p == NEUTRAL_US),
            "{name}: {:?}",
            lost.2
        );
        sensors.0.set(ImuState::Answers);
        run(&mut a, 500);
        assert_eq!(
            a.last_output().faults & fault::SENSOR_LOST,
            0,
            "{name}: recovers"
        );
    }
    // Every reply decodes (the fixed-rate telemetry carries the estimate).
    let bytes = std::mem::take(&mut a.parts_mut().1.tx);
    let mut tel = None;
    for b in bytes {
        if let Some(Decoded::Frame {
            msg: Reply::Telemetry(t),
            ..
        }) = decoder.push(b)
        {
            tel = Some(t);
        }
    }
    assert!((tel.unwrap().nav.z_m - 2.0).abs() < 0.05);
}
