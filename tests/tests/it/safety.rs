//! Every safety requirement of the firmware, on the host with fake PWM, serial and clock.

// Test code: a failed expectation should stop the test.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use controller_core::controller::Gains;
use controller_core::reference::{PaperPolynomial, Reference};
use controller_core::state::NavState;
use firmware::protocol::{
    encode_with_version, fault, Board, Command, Law, ManualThrust, Mode, NackReason, NavSample,
    Plane, Reply, Telemetry, MAX_FRAME_LEN,
};
use firmware::{Config, Timing};
use proptest::prelude::*;
use rov_tests::{app, nacked, pulses_us, FakeClock, TestApp, Topside, PWM_MAX_DUTY};

const NEUTRAL_DUTY: u16 = 1500; // 1500 us of a 20 000 us period at 1 us per step

fn fixed() -> (TestApp, FakeClock, Topside) {
    let (a, c) = app(Config::fixed_rate(Board::Host));
    (a, c, Topside::default())
}

fn nav(t_us: u64) -> Command {
    Command::Nav(NavSample {
        t_us,
        state: NavState::default(),
    })
}

fn acked(replies: &[Reply], seq: u16) -> bool {
    replies.contains(&Reply::Ack { seq })
}

fn duties(a: &mut TestApp) -> [u16; 3] {
    let (p, _, _) = a.parts_mut();
    [
        p[0].duty().unwrap_or(0),
        p[1].duty().unwrap_or(0),
        p[2].duty().unwrap_or(0),
    ]
}

/// Heartbeat and a fresh nav at the clock's time, then arm; asserts the Ack.
fn arm(a: &mut TestApp, c: &FakeClock, t: &mut Topside) {
    t.send(a, &Command::Heartbeat { t_us: c.get_us() });
    t.send(a, &nav(c.get_us()));
    let (seq, r) = t.send(a, &Command::Arm);
    assert!(acked(&r, seq), "arm refused: {r:?}");
    assert!(a.autopilot().armed());
}

/// Hold `pos_m` with the XY tracking law, armed; asserts each Ack.
fn hold_point(a: &mut TestApp, c: &FakeClock, t: &mut Topside, pos_m: [f32; 3]) {
    let (s, r) = t.send(
        a,
        &Command::SetReference {
            reference: Reference::Hold { pos_m },
            start_us: None,
        },
    );
    assert!(acked(&r, s));
    arm(a, c, t);
    let (s, r) = t.send(
        a,
        &Command::SetMode(Mode::Track {
            plane: Plane::Xy,
            law: Law::Tracking,
        }),
    );
    assert!(acked(&r, s), "{r:?}");
}

fn last_telemetry(r: &[Reply]) -> Option<Telemetry> {
    r.iter().rev().find_map(|r| match r {
        Reply::Telemetry(t) => Some(*t),
        _ => None,
    })
}

#[test]
fn boots_disarmed_with_neutral_outputs_and_says_hello() {
    let (mut a, c, mut t) = fixed();
    // Written once by `new`, before anything else.
    {
        let (p, _, _) = a.parts_mut();
        assert_eq!(p[0].writes, vec![NEUTRAL_DUTY]);
        assert_eq!(p[1].writes, vec![NEUTRAL_DUTY]);
        assert_eq!(p[2].writes, vec![NEUTRAL_DUTY]);
    }
    a.hello();
    let r = t.replies(&mut a);
    assert!(matches!(
        r.as_slice(),
        [Reply::Hello {
            protocol: firmware::protocol::PROTOCOL_VERSION,
            board: Board::Host,
            lockstep: false,
            control_period_us: 20_000,
            pwm_hz: 50
        }]
    ));
    for _ in 0..100 {
        c.advance_us(10_000);
        a.tick();
    }
    assert!(!a.autopilot().armed());
    assert_eq!(a.autopilot().mode(), Mode::Idle);
    let (p, _, _) = a.parts_mut();
    for o in p.iter() {
        assert!(o.writes.iter().all(|d| *d == NEUTRAL_DUTY));
    }
    let tel = last_telemetry(&t.replies(&mut a)).expect("periodic telemetry");
    assert!(!tel.armed);
    assert_eq!(tel.pulse_us, [1500; 3]);
    assert_ne!(tel.faults & fault::HEARTBEAT_LOST, 0);
}

#[test]
fn pwm_duty_follows_the_period() {
    let mut cfg = Config::fixed_rate(Board::Host);
    cfg.pwm_hz = 400;
    let (mut a, _c) = app(cfg);
    // 1500 us of a 2500 us period.
    assert_eq!(duties(&mut a), [12_000; 3]);
    for hz in [49u16, 401, 0] {
        let mut cfg = Config::fixed_rate(Board::Host);
        cfg.pwm_hz = hz;
        let r = firmware::App::new(
            [
                rov_tests::FakePwm::new(PWM_MAX_DUTY),
                rov_tests::FakePwm::new(PWM_MAX_DUTY),
                rov_tests::FakePwm::new(PWM_MAX_DUTY),
            ],
            rov_tests::FakeSerial::default(),
            FakeClock::default(),
            rov_tests::controller(),
            cfg,
        );
        assert!(matches!(r, Err(firmware::ConfigError::PwmFrequency)));
    }
}

#[test]
fn arming_needs_a_fresh_heartbeat_and_nav() {
    let (mut a, c, mut t) = fixed();
    c.set_us(1_000_000);
    let (s, r) = t.send(&mut a, &Command::Arm);
    assert_eq!(nacked(&r, s), Some(NackReason::NoHeartbeat));
    t.send(&mut a, &Command::Heartbeat { t_us: 0 });
    let (s, r) = t.send(&mut a, &Command::Arm);
    assert_eq!(nacked(&r, s), Some(NackReason::NavStale));
    t.send(&mut a, &nav(1_000_000));
    c.advance_us(250_000); // nav now 0.25 s old
    t.send(&mut a, &Command::Heartbeat { t_us: 0 });
    let (s, r) = t.send(&mut a, &Command::Arm);
    assert_eq!(nacked(&r, s), Some(NackReason::NavStale));
    assert!(!a.autopilot().armed());
    t.send(&mut a, &nav(1_250_000));
    c.advance_us(600_000); // heartbeat now 0.6 s old, nav fresh after this:
    t.send(&mut a, &nav(1_850_000));
    let (s, r) = t.send(&mut a, &Command::Arm);
    assert_eq!(nacked(&r, s), Some(NackReason::NoHeartbeat));
    t.send(&mut a, &Command::Heartbeat { t_us: 0 });
    let (s, r) = t.send(&mut a, &Command::Arm);
    assert!(acked(&r, s));
    assert!(a.autopilot().armed());
}

/// Manual thrust, heartbeats stop while manual commands keep coming: neutral from 0.5 s,
/// disarmed from 1 s, and heartbeats alone do not re-arm.
#[test]
fn heartbeat_loss_neutral_then_disarm_then_explicit_rearm() {
    let (mut a, c, mut t) = fixed();
    arm(&mut a, &c, &mut t);
    let (s, r) = t.send(&mut a, &Command::SetMode(Mode::Manual));
    assert!(acked(&r, s));
    t.send(&mut a, &Command::ManualThrust(ManualThrust::default()));
    let hb_at = c.get_us();
    let push = ManualThrust {
        surge: 0.5,
        yaw: 0.0,
        heave: -0.3,
    };
    let mut neutral_at = None;
    let mut disarmed_at = None;
    for _ in 0..80 {
        c.advance_us(20_000);
        t.send(&mut a, &Command::ManualThrust(push));
        let age = c.get_us() - hb_at;
        let p = pulses_us(&mut a);
        let neutral = p == [1500.0; 3];
        if age < 500_000 {
            assert!(!neutral, "thrust expected at {age} us: {p:?}");
            assert!(p[0] > 1500.0 && p[1] > 1500.0 && p[2] < 1500.0);
        } else {
            assert!(neutral, "neutral expected at {age} us");
            neutral_at.get_or_insert(age);
            assert_ne!(a.last_output().faults & fault::HEARTBEAT_LOST, 0);
        }
        if age >= 1_000_000 {
            assert!(!a.autopilot().armed());
            assert_ne!(a.last_output().faults & fault::LINK_DISARMED, 0);
            disarmed_at.get_or_insert(age);
        } else {
            assert!(a.autopilot().armed(), "still armed at {age} us");
        }
    }
    assert_eq!(neutral_at, Some(500_000));
    assert_eq!(disarmed_at, Some(1_000_000));
    // Link back: still disarmed, neutral, until an explicit Arm.
    for _ in 0..10 {
        c.advance_us(20_000);
        t.send(&mut a, &Command::Heartbeat { t_us: 0 });
        t.send(&mut a, &Command::ManualThrust(push));
        assert!(!a.autopilot().armed());
        assert_eq!(pulses_us(&mut a), [1500.0; 3]);
    }
    t.send(&mut a, &nav(c.get_us()));
    // The arming in a stick mode is refused while the stick is off centre.
    let (s, r) = t.send(&mut a, &Command::Arm);
    assert_eq!(nacked(&r, s), Some(NackReason::SticksNotCentred));
    t.send(&mut a, &Command::ManualThrust(ManualThrust::default()));
    let (s, r) = t.send(&mut a, &Command::Arm);
    assert!(acked(&r, s));
    c.advance_us(20_000);
    t.send(&mut a, &Command::ManualThrust(push));
    assert!(pulses_us(&mut a)[0] > 1500.0);
    assert_eq!(a.last_output().faults & fault::LINK_DISARMED, 0);
}

#[test]
fn stale_nav_while_tracking_goes_neutral_with_a_fault() {
    let (mut a, c, mut t) = fixed();
    hold_point(&mut a, &c, &mut t, [5.0, 5.0, 0.0]);
    let last_nav = c.get_us();
    for _ in 0..20 {
        c.advance_us(20_000);
        t.send(&mut a, &Command::Heartbeat { t_us: 0 });
        let age = c.get_us() - last_nav;
        let stale = a.last_output().faults & fault::NAV_STALE != 0;
        assert_eq!(stale, age > 200_000, "age {age}");
        if stale {
            assert_eq!(pulses_us(&mut a), [1500.0; 3]);
            assert!(!a.last_output().law_ran);
        } else {
            assert!(a.last_output().law_ran);
        }
    }
    // Fresh nav: tracking resumes, the flag clears.
    t.send(&mut a, &nav(c.get_us()));
    c.advance_us(20_000);
    t.send(&mut a, &Command::Heartbeat { t_us: 0 });
    assert_eq!(a.last_output().faults & fault::NAV_STALE, 0);
    assert!(a.last_output().law_ran);
    assert!(a.autopilot().armed());
}

#[test]
fn disarm_is_immediate() {
    let (mut a, c, mut t) = fixed();
    arm(&mut a, &c, &mut t);
    t.send(&mut a, &Command::SetMode(Mode::Manual));
    // The sticks seen at centre since the change of mode: the next stick acts.
    t.send(&mut a, &Command::ManualThrust(ManualThrust::default()));
    t.send(
        &mut a,
        &Command::ManualThrust(ManualThrust {
            surge: 1.0,
            yaw: 1.0,
            heave: 1.0,
        }),
    );
    c.advance_us(20_000);
    a.tick();
    assert_ne!(pulses_us(&mut a), [1500.0; 3]);
    let (s, r) = t.send(&mut a, &Command::Disarm);
    assert!(acked(&r, s));
    assert_eq!(pulses_us(&mut a), [1500.0; 3]);
}

fn snapshot(a: &TestApp) -> String {
    format!("{:?}", a.autopilot())
}

/// Every refused command is Nacked with its reason and changes nothing.
#[test]
fn invalid_values_are_nacked_and_change_nothing() {
    let (mut a, c, mut t) = fixed();
    t.send(
        &mut a,
        &Command::SetReference {
            reference: Reference::Paper(PaperPolynomial::PAPER),
            start_us: None,
        },
    );
    arm(&mut a, &c, &mut t);
    let bad_nav = |f: &dyn Fn(&mut NavState)| {
        let mut s = NavState::default();
        f(&mut s);
        Command::Nav(NavSample { t_us: 0, state: s })
    };
    let mut g_nan = Gains::default();
    g_nan.paper_xz.k = f32::NAN;
    let mut g_neg = Gains::default();
    g_neg.paper_xy.k = -1.0;
    let mut g_trk_nan = Gains::default();
    g_trk_nan.tracking.xy_kd = f32::NAN;
    let cases: Vec<(Command, NackReason)> = vec![
        (bad_nav(&|s| s.x_m = f32::NAN), NackReason::NonFinite),
        (
            bad_nav(&|s| s.yaw_rad = f32::INFINITY),
            NackReason::NonFinite,
        ),
        (
            bad_nav(&|s| s.r_rad_s = f32::NEG_INFINITY),
            NackReason::NonFinite,
        ),
        (bad_nav(&|s| s.u_m_s = 1e3), NackReason::OutOfRange),
        (bad_nav(&|s| s.z_m = -1e9), NackReason::OutOfRange),
        (
            Command::SetPaperGains {
                xz: g_nan.paper_xz,
                xy: g_nan.paper_xy,
            },
            NackReason::NonFinite,
        ),
        (
            Command::SetPaperGains {
                xz: g_neg.paper_xz,
                xy: g_neg.paper_xy,
            },
            NackReason::NotPositive,
        ),
        (
            Command::SetTrackingGains(g_trk_nan.tracking),
            NackReason::NonFinite,
        ),
        (
            Command::SetReference {
                reference: Reference::Paper(PaperPolynomial {
                    h_r_m: f32::NAN,
                    t_f_s: 100.0,
                }),
                start_us: None,
            },
            NackReason::NonFinite,
        ),
        (
            Command::SetReference {
                reference: Reference::Paper(PaperPolynomial {
                    h_r_m: 1.0,
                    t_f_s: 0.0,
                }),
                start_us: None,
            },
            NackReason::NotPositive,
        ),
        (
            Command::SetReference {
                reference: Reference::Hold {
                    pos_m: [0.0, f32::INFINITY, 0.0],
                },
                start_us: Some(5),
            },
            NackReason::NonFinite,
        ),
        (
            Command::ManualThrust(ManualThrust {
                surge: 1.5,
                yaw: 0.0,
                heave: 0.0,
            }),
            NackReason::OutOfRange,
        ),
        (
            Command::ManualThrust(ManualThrust {
                surge: 0.0,
                yaw: f32::NAN,
                heave: 0.0,
            }),
            NackReason::NonFinite,
        ),
        (
            Command::SetMode(Mode::Track {
                plane: Plane::ThreeD,
                law: Law::Paper,
            }),
            NackReason::Unsupported,
        ),
    ];
    for (cmd, want) in cases {
        let before = snapshot(&a);
        let (s, r) = t.deliver(&mut a, &cmd);
        assert_eq!(nacked(&r, s), Some(want), "{cmd:?} -> {r:?}");
        assert_eq!(snapshot(&a), before, "{cmd:?} changed the state");
    }
    // Nav going back in time.
    t.send(&mut a, &nav(c.get_us() + 10));
    let before = snapshot(&a);
    let (s, r) = t.deliver(&mut a, &nav(c.get_us()));
    assert_eq!(nacked(&r, s), Some(NackReason::OutOfRange));
    assert_eq!(snapshot(&a), before);
    // Tracking without a reference (fresh app, its session open).
    let (mut b, _c2, mut t2) = fixed();
    t2.open(&mut b);
    let before = snapshot(&b);
    let (s, r) = t2.deliver(
        &mut b,
        &Command::SetMode(Mode::Track {
            plane: Plane::Xy,
            law: Law::Tracking,
        }),
    );
    assert_eq!(nacked(&r, s), Some(NackReason::NoReference));
    assert_eq!(snapshot(&b), before);
    // Hold without a nav.
    let (s, r) = t2.deliver(&mut b, &Command::SetMode(Mode::Hold));
    assert_eq!(nacked(&r, s), Some(NackReason::NavStale));
    assert_eq!(snapshot(&b), before);
}

#[test]
fn other_protocol_version_is_nacked() {
    let (mut a, _c, mut t) = fixed();
    let mut buf = [0u8; MAX_FRAME_LEN];
    let f = encode_with_version(9, 0, 1234, &Command::Arm, &mut buf).unwrap();
    a.parts_mut().1.rx.extend(f.iter().copied());
    a.tick();
    let r: Vec<Reply> = t
        .replies(&mut a)
        .into_iter()
        .filter(|r| !matches!(r, Reply::Telemetry(_)))
        .collect();
    assert_eq!(
        r,
        vec![Reply::Nack {
            seq: 1234,
            reason: NackReason::UnsupportedVersion
        }]
    );
    assert_eq!(a.link_stats().dropped.version, 1);
    assert!(!a.autopilot().armed());
}

/// Lock-step: the firmware's clock is the host's time stamps; each nav is answered by a
/// telemetry frame naming it; the failsafes run in host time whatever the board clock does.
#[test]
fn lockstep_runs_on_host_time() {
    let (mut a, c) = app(Config::lockstep(Board::Host));
    let mut t = Topside::default();
    let mut t_us = 10_000_000u64;
    t.send(&mut a, &Command::Heartbeat { t_us });
    t.send(&mut a, &nav(t_us));
    let (s, r) = t.send(&mut a, &Command::Arm);
    assert!(acked(&r, s));
    t.send(&mut a, &Command::SetMode(Mode::Manual));
    t.send(&mut a, &Command::ManualThrust(ManualThrust::default()));
    let hb_at = t_us;
    for i in 0..60u64 {
        t_us += 20_000;
        c.set_us(i * 1_000_000_000); // wild board clock: must not matter
        t.send(
            &mut a,
            &Command::ManualThrust(ManualThrust {
                surge: 0.2,
                yaw: 0.1,
                heave: 0.0,
            }),
        );
        let (s, r) = t.send(&mut a, &nav(t_us));
        let tel = last_telemetry(&r).expect("telemetry answers nav");
        assert_eq!(r.len(), 1);
        assert_eq!(tel.nav_seq, s);
        assert_eq!(tel.t_us, t_us);
        let age = t_us - hb_at;
        assert_eq!(tel.armed, age < 1_000_000, "age {age}");
        assert_eq!(tel.pulse_us == [1500; 3], age >= 500_000, "age {age}");
    }
    assert!(!a.autopilot().armed());
    // A refused nav from the far future does not move the clock.
    let far = Command::Nav(NavSample {
        t_us: t_us + 3_600_000_000,
        state: NavState {
            u_m_s: 1e3,
            ..NavState::default()
        },
    });
    let (s, r) = t.send(&mut a, &far);
    // The stamp is refused first (an hour ahead of the host's clock).
    assert_eq!(nacked(&r, s), Some(NackReason::ClockAhead));
    assert_eq!(a.now_us(), t_us);
    let (s, r) = t.send(&mut a, &nav(t_us + 20_000));
    assert_eq!(
        last_telemetry(&r).map(|t| (t.nav_seq, t.t_us)),
        Some((s, t_us + 20_000))
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// Whatever the manual command or navigation state, the thrusts stay within the limits
    /// and the pulses within 1100-1900 us.
    #[test]
    fn thrust_and_pulses_always_within_limits(
        surge in -1.0f32..=1.0, yaw in -1.0f32..=1.0, heave in -1.0f32..=1.0,
        x in -1e4f32..1e4, y in -1e4f32..1e4, psi in -10.0f32..10.0,
        u in -19.0f32..19.0, r in -49.0f32..49.0,
    ) {
        let (mut a, c, mut t) = fixed();
        t.send(&mut a, &Command::SetReference {
            reference: Reference::Paper(PaperPolynomial::PAPER), start_us: None });
        arm(&mut a, &c, &mut t);
        let lim = *a.autopilot().controller().limits();
        let state = NavState { x_m: x, y_m: y, yaw_rad: psi, u_m_s: u, r_rad_s: r, ..NavState::default() };
        for mode in [Mode::Manual, Mode::Track { plane: Plane::Xy, law: Law::Paper },
                     Mode::Track { plane: Plane::Xz, law: Law::Paper },
                     Mode::Track { plane: Plane::ThreeD, law: Law::Tracking }, Mode::Hold] {
            t.send(&mut a, &Command::SetMode(mode));
            t.send(&mut a, &Command::ManualThrust(ManualThrust { surge, yaw, heave }));
            for _ in 0..3 {
                c.advance_us(20_000);
                t.send(&mut a, &Command::Heartbeat { t_us: 0 });
                t.send(&mut a, &Command::Nav(NavSample { t_us: c.get_us(), state }));
                let out = *a.last_output();
                for f in out.allocation.thrust_n {
                    prop_assert!(f <= lim.max_forward_n && f >= -lim.max_reverse_n);
                }
                for p in pulses_us(&mut a) {
                    prop_assert!((1100.0..=1900.0).contains(&p), "pulse {}", p);
                }
            }
        }
    }
}

#[test]
fn timing_enum_is_reported() {
    let (mut a, _c) = app(Config::lockstep(Board::Host));
    a.hello();
    let r = Topside::default().replies(&mut a);
    assert!(matches!(
        r[0],
        Reply::Hello {
            lockstep: true,
            control_period_us: 0,
            ..
        }
    ));
    assert_eq!(Config::lockstep(Board::Host).timing, Timing::LockStep);
}

/// STABILIZE / ALT_HOLD: refused without a fresh nav; the pilot's thrust with the
/// heading and depth held; neutral with `MANUAL_STALE` when the sticks stop, `NAV_STALE`
/// when the navigation does.
#[test]
fn pilot_assisted_modes_need_nav_and_sticks() {
    let (mut a, c, mut t) = fixed();
    for mode in [Mode::Stabilize, Mode::DepthHold] {
        let (s, r) = t.send(&mut a, &Command::SetMode(mode));
        assert_eq!(nacked(&r, s), Some(NackReason::NavStale), "{mode:?}");
    }
    arm(&mut a, &c, &mut t);
    let (s, r) = t.send(&mut a, &Command::SetMode(Mode::DepthHold));
    assert!(acked(&r, s), "{r:?}");
    // Sticks centred, a fresh nav 0.3 m below where the mode began, turned 0.2 rad: the hold
    // pushes up and turns back.
    let sticks = Command::ManualThrust(ManualThrust::default());
    t.send(&mut a, &sticks);
    c.advance_us(20_000);
    t.send(&mut a, &nav(c.get_us()));
    t.send(&mut a, &Command::Heartbeat { t_us: 0 });
    let off = Command::Nav(NavSample {
        t_us: c.get_us() + 1,
        state: NavState {
            z_m: 0.3,
            yaw_rad: 0.2,
            ..NavState::default()
        },
    });
    t.send(&mut a, &off);
    t.send(&mut a, &sticks);
    c.advance_us(20_000);
    t.send(&mut a, &Command::Heartbeat { t_us: 0 });
    let out = *a.last_output();
    assert!(out.law_ran && out.faults == 0, "{out:?}");
    assert!(
        out.requested.heave_n < 0.0 && out.requested.yaw_n_m < 0.0,
        "{out:?}"
    );
    assert!((out.errors.z_m - 0.3).abs() < 1e-6 && (out.errors.yaw_rad - 0.2).abs() < 1e-6);
    // The sticks stop: neutral after 0.5 s, with the flag.
    for _ in 0..30 {
        c.advance_us(20_000);
        t.send(&mut a, &nav(c.get_us()));
        t.send(&mut a, &Command::Heartbeat { t_us: 0 });
    }
    assert_ne!(a.last_output().faults & fault::MANUAL_STALE, 0);
    assert_eq!(pulses_us(&mut a), [1500.0; 3]);
    // Sticks again, but the navigation stops: neutral with NAV_STALE.
    for _ in 0..15 {
        c.advance_us(20_000);
        t.send(&mut a, &sticks);
        t.send(&mut a, &Command::Heartbeat { t_us: 0 });
    }
    assert_ne!(a.last_output().faults & fault::NAV_STALE, 0);
    assert_eq!(pulses_us(&mut a), [1500.0; 3]);
}

/// Missions: uploaded item by item, replaced only when complete, bad items refused
/// with the mission in use unchanged, AUTO refused without one, flown and counted when given.
#[test]
fn missions_are_uploaded_whole_refused_with_a_reason_and_flown_in_auto() {
    let (mut a, c, mut t) = fixed();
    arm(&mut a, &c, &mut t);
    let (s, r) = t.send(&mut a, &Command::SetMode(Mode::Auto));
    assert_eq!(
        nacked(&r, s),
        Some(NackReason::NoReference),
        "no mission yet"
    );
    let wp = |index: u16, pos_m: [f32; 3]| Command::MissionItem {
        index,
        count: 3,
        pos_m,
        speed_m_s: 0.25,
    };
    let square = [[5.0, 0.0, 1.0], [5.0, 5.0, 1.0], [0.0, 5.0, 1.0]];
    for (i, p) in square.iter().enumerate() {
        let (s, r) = t.send(&mut a, &wp(i as u16, *p));
        assert!(acked(&r, s), "{r:?}");
        assert_eq!(a.autopilot().mission_len(), if i == 2 { 3 } else { 0 });
    }
    // A second upload with a bad item: refused, the mission in use stays.
    let bad = [
        (wp(0, [f32::NAN, 0.0, 1.0]), NackReason::NonFinite),
        (wp(0, [1.0, 0.0, 500.0]), NackReason::OutOfRange),
        (wp(0, [1.0, 0.0, -1.0]), NackReason::OutOfRange),
        (wp(2, [1.0, 0.0, 1.0]), NackReason::OutOfRange),
        (
            Command::MissionItem {
                index: 0,
                count: 40,
                pos_m: [1.0, 0.0, 1.0],
                speed_m_s: 0.25,
            },
            NackReason::OutOfRange,
        ),
    ];
    for (cmd, why) in bad {
        let (s, r) = t.send(&mut a, &cmd);
        assert_eq!(nacked(&r, s), Some(why), "{cmd:?}");
        assert_eq!(a.autopilot().mission_len(), 3);
    }
    // AUTO: the law flies the path; the count of reached waypoints climbs to 3.
    t.send(&mut a, &nav(c.get_us()));
    let (s, r) = t.send(&mut a, &Command::SetMode(Mode::Auto));
    assert!(acked(&r, s), "{r:?}");
    let (s, r) = t.send(&mut a, &Command::MissionClear);
    assert_eq!(
        nacked(&r, s),
        Some(NackReason::Unsupported),
        "not while flying it"
    );
    // Nor a new mission (it was acknowledged and the old one flown on).
    let (s, r) = t.send(&mut a, &wp(0, [1.0, 1.0, 1.0]));
    assert_eq!(
        nacked(&r, s),
        Some(NackReason::Unsupported),
        "no new mission while AUTO flies one"
    );
    assert_eq!(a.autopilot().mission_len(), 3);
    let mut reached = 0;
    for _ in 0..5_000 {
        c.advance_us(20_000);
        t.send(&mut a, &nav(c.get_us()));
        t.send(&mut a, &Command::Heartbeat { t_us: 0 });
        let now = a.autopilot().mission_reached(c.get_us());
        assert!(now >= reached);
        reached = now;
        assert!(a.last_output().law_ran);
    }
    assert_eq!(reached, 3);
}

/// The vehicle's description and the failsafe timeouts come over the tether: refused with a
/// reason (nothing changes) when unsafe, while armed, or non-finite; accepted ones take effect.
#[test]
fn vehicle_description_and_failsafe_timeouts_over_the_tether() {
    use controller_core::params::VehicleParams;
    use firmware::Failsafe;
    let (mut a, c, mut t) = fixed();
    // What the two commands may change (a send also runs the loop's control steps).
    let settings = |a: &TestApp| {
        (
            a.autopilot().controller().clone(),
            *a.autopilot().failsafe(),
        )
    };
    let nacks = |a: &mut TestApp, t: &mut Topside, cmd: Command| {
        let before = settings(a);
        let (s, r) = t.send(a, &cmd);
        let why = nacked(&r, s);
        assert_eq!(settings(a), before, "{cmd:?} changed the state");
        why
    };
    let with = |f: &dyn Fn(&mut VehicleParams)| {
        let mut p = VehicleParams::OBSERVER;
        f(&mut p);
        Command::SetVehicle(p)
    };
    for (cmd, want) in [
        (with(&|p| p.mass_kg = f32::NAN), NackReason::NonFinite),
        (with(&|p| p.mass_kg = -10.0), NackReason::NotPositive),
        // Buoyancy the vertical thruster could not hold with half its thrust to spare.
        (with(&|p| p.buoyancy_offset_n = 8.0), NackReason::OutOfRange),
        (
            with(&|p| p.pulse.deadband_us = 500.0),
            NackReason::NonPhysical,
        ),
        (
            with(&|p| p.thrust_max_reverse_n = 1.0),
            NackReason::NonPhysical,
        ),
    ] {
        assert_eq!(nacks(&mut a, &mut t, cmd), Some(want), "{cmd:?}");
    }
    let fs = |f: &dyn Fn(&mut Failsafe)| {
        let mut x = Failsafe::DEFAULT;
        f(&mut x);
        Command::SetFailsafe(x)
    };
    for cmd in [
        fs(&|f| f.manual_stale_us = 10_000),
        fs(&|f| f.heartbeat_neutral_us = 3_000_000),
        fs(&|f| f.nav_stale_us = 5_000_000),
        fs(&|f| f.heartbeat_disarm_us = 400_000),
    ] {
        assert_eq!(
            nacks(&mut a, &mut t, cmd),
            Some(NackReason::OutOfRange),
            "{cmd:?}"
        );
    }

    // Accepted: a heavier vehicle (the controller's model changes, the tracking gains
    // derived from the old one follow it) ...
    let (s, r) = t.send(&mut a, &with(&|p| p.mass_kg = 14.0));
    assert!(acked(&r, s), "{r:?}");
    let controller = a.autopilot().controller();
    assert_eq!(controller.vehicle().params().mass_kg, 14.0);
    assert_eq!(
        *controller.gains(),
        controller_core::controller::Gains::for_vehicle(controller.vehicle())
    );
    // ... and a shorter navigation timeout, which then trips earlier.
    let (s, r) = t.send(&mut a, &fs(&|f| f.nav_stale_us = 100_000));
    assert!(acked(&r, s), "{r:?}");
    assert_eq!(a.autopilot().failsafe().nav_stale_us, 100_000);
    hold_point(&mut a, &c, &mut t, [1.0, 0.0, 0.0]);
    let last_nav = c.get_us();
    for _ in 0..8 {
        c.advance_us(20_000);
        t.send(&mut a, &Command::Heartbeat { t_us: 0 });
        let stale = a.last_output().faults & fault::NAV_STALE != 0;
        assert_eq!(stale, c.get_us() - last_nav > 100_000);
    }
    // Armed: a new description is refused, the one in force stays.
    assert_eq!(
        nacks(&mut a, &mut t, with(&|p| p.mass_kg = 12.0)),
        Some(NackReason::Armed)
    );
    assert_eq!(a.autopilot().controller().vehicle().params().mass_kg, 14.0);
}

// ---- The safety probes, each a test ---------------------------------------------------

/// Keep the link and the navigation fresh for `steps` control periods of 20 ms.
fn fly(a: &mut TestApp, c: &FakeClock, t: &mut Topside, steps: u32) {
    for _ in 0..steps {
        c.advance_us(20_000);
        t.send(a, &nav(c.get_us()));
        t.send(a, &Command::Heartbeat { t_us: 0 });
    }
}

/// The probe "arming obeys a stale stick": a full stick sent while disarmed does not act
/// after the arming. While it is fresh, the arming is refused (ArduSub's throttle check);
/// once stale, the arming is taken and the thrusters wait for input sent after it.
#[test]
fn arming_does_not_obey_a_stick_sent_while_disarmed() {
    let (mut a, c, mut t) = fixed();
    t.send(&mut a, &Command::Heartbeat { t_us: 0 });
    t.send(&mut a, &nav(c.get_us()));
    let (s, r) = t.send(&mut a, &Command::SetMode(Mode::Manual));
    assert!(acked(&r, s), "{r:?}");
    let full = ManualThrust {
        surge: 1.0,
        yaw: 1.0,
        heave: 1.0,
    };
    t.send(&mut a, &Command::ManualThrust(full));
    let (s, r) = t.send(&mut a, &Command::Arm);
    assert_eq!(nacked(&r, s), Some(NackReason::SticksNotCentred));
    assert!(!a.autopilot().armed());
    // The stick goes stale (0.6 s, nothing new): still the latest state received, still
    // refused; centred, the arming is taken, and 20 ms later the outputs are neutral (no
    // input since the arming).
    fly(&mut a, &c, &mut t, 30);
    let (s, r) = t.send(&mut a, &Command::Arm);
    assert_eq!(nacked(&r, s), Some(NackReason::SticksNotCentred));
    t.send(&mut a, &Command::ManualThrust(ManualThrust::default()));
    fly(&mut a, &c, &mut t, 30);
    let (s, r) = t.send(&mut a, &Command::Arm);
    assert!(acked(&r, s), "{r:?}");
    fly(&mut a, &c, &mut t, 1);
    assert_eq!(pulses_us(&mut a), [1500.0; 3]);
    assert_ne!(a.last_output().faults & fault::MANUAL_STALE, 0);
    // A centred stick sent while disarmed is no obstacle; input after the arming acts.
    t.send(&mut a, &Command::Disarm);
    t.send(&mut a, &Command::ManualThrust(ManualThrust::default()));
    let (s, r) = t.send(&mut a, &Command::Arm);
    assert!(acked(&r, s), "{r:?}");
    t.send(&mut a, &Command::ManualThrust(full));
    fly(&mut a, &c, &mut t, 1);
    assert!(pulses_us(&mut a)[0] > 1500.0);
}

/// The probe "re-arming resumes an old reference": tracking a line, disarm, 60 s later arm.
/// The reference was dropped at the disarm: the arming in the tracking mode is refused
/// `NoReference` (outputs stay neutral); sent again, the line starts at the arming.
#[test]
fn rearming_does_not_resume_an_old_reference() {
    let (mut a, c, mut t) = fixed();
    let line = Command::SetReference {
        reference: Reference::Line {
            start_m: [0.0, 0.0, 0.0],
            heading_rad: 0.0,
            speed_m_s: 0.5,
        },
        start_us: None,
    };
    let (s, r) = t.send(&mut a, &line);
    assert!(acked(&r, s));
    arm(&mut a, &c, &mut t);
    let track = Command::SetMode(Mode::Track {
        plane: Plane::Xy,
        law: Law::Tracking,
    });
    let (s, r) = t.send(&mut a, &track);
    assert!(acked(&r, s));
    fly(&mut a, &c, &mut t, 50);
    assert!(a.last_output().law_ran);
    t.send(&mut a, &Command::Disarm);
    fly(&mut a, &c, &mut t, 3_000); // 60 s
    let (s, r) = t.send(&mut a, &Command::Arm);
    assert_eq!(nacked(&r, s), Some(NackReason::NoReference));
    assert!(!a.autopilot().armed());
    assert_eq!(pulses_us(&mut a), [1500.0; 3]);
    // Sent again (start "now", at the vehicle): the first step's error is small.
    let (s, r) = t.send(&mut a, &line);
    assert!(acked(&r, s));
    fly(&mut a, &c, &mut t, 50); // 1 s between the reference and the arming
    let (s, r) = t.send(&mut a, &Command::Arm);
    assert!(acked(&r, s), "{r:?}");
    fly(&mut a, &c, &mut t, 1);
    let e = a.last_output().errors;
    assert!(a.last_output().law_ran);
    assert!(e.x_m.abs() < 0.05, "first error {e:?}");
}

/// The probe "AUTO armed 120 s after it was set jumps 10 m along the path": the path starts
/// at the arming, where the vehicle is.
#[test]
fn auto_armed_late_starts_its_path_at_the_arming() {
    let (mut a, c, mut t) = fixed();
    for (i, p) in [[20.0, 0.0, 0.0], [20.0, 20.0, 0.0]].iter().enumerate() {
        let (s, r) = t.send(
            &mut a,
            &Command::MissionItem {
                index: i as u16,
                count: 2,
                pos_m: *p,
                speed_m_s: 0.1,
            },
        );
        assert!(acked(&r, s), "{r:?}");
    }
    t.send(&mut a, &Command::Heartbeat { t_us: 0 });
    t.send(&mut a, &nav(c.get_us()));
    let (s, r) = t.send(&mut a, &Command::SetMode(Mode::Auto));
    assert!(acked(&r, s), "{r:?}");
    fly(&mut a, &c, &mut t, 6_000); // 120 s
    let (s, r) = t.send(&mut a, &Command::Arm);
    assert!(acked(&r, s), "{r:?}");
    fly(&mut a, &c, &mut t, 1);
    let e = a.last_output().errors;
    assert!(a.last_output().law_ran);
    assert!(
        e.x_m.abs() < 0.05 && e.y_m.abs() < 0.05,
        "the path starts 120 s along: {e:?}"
    );
}

/// The probe "a replayed frame is obeyed": after `Disarm`, the same `Arm` and `ManualThrust`
/// bytes sent again are refused `Replayed` and counted; the vehicle stays disarmed.
#[test]
fn a_replayed_frame_is_refused_and_counted() {
    let (mut a, c, mut t) = fixed();
    t.send(&mut a, &Command::Heartbeat { t_us: 0 });
    t.send(&mut a, &nav(c.get_us()));
    t.send(&mut a, &Command::SetMode(Mode::Manual));
    let (arm_seq, arm_bytes) = t.frame(&Command::Arm);
    a.parts_mut().1.rx.extend(arm_bytes.clone());
    a.tick();
    assert!(acked(&t.replies(&mut a), arm_seq));
    t.send(&mut a, &Command::ManualThrust(ManualThrust::default()));
    let push = ManualThrust {
        surge: 1.0,
        yaw: 0.0,
        heave: 0.0,
    };
    let (_, push_bytes) = t.frame(&Command::ManualThrust(push));
    a.parts_mut().1.rx.extend(push_bytes.clone());
    fly(&mut a, &c, &mut t, 1);
    assert!(pulses_us(&mut a)[0] > 1500.0);
    t.send(&mut a, &Command::Disarm);
    // The recorded bytes again.
    a.parts_mut().1.rx.extend(arm_bytes);
    a.parts_mut().1.rx.extend(push_bytes);
    a.tick();
    let r = t.replies(&mut a);
    assert_eq!(nacked(&r, arm_seq), Some(NackReason::Replayed), "{r:?}");
    fly(&mut a, &c, &mut t, 5);
    assert!(!a.autopilot().armed());
    assert_eq!(pulses_us(&mut a), [1500.0; 3]);
    assert_eq!(a.link_stats().replayed, 2);
}

/// Sessions: nothing but `OpenSession` is taken outside one; a restarted topside (a new
/// session, its numbers and its clock from 0) is welcome at once, and the old session's
/// frames are refused `NoSession` from then on.
#[test]
fn a_session_is_needed_and_a_restarted_topside_is_welcome_at_once() {
    let (mut a, c) = app(Config::fixed_rate(Board::Host));
    // A frame in no session: refused, nothing changes.
    let mut buf = [0u8; MAX_FRAME_LEN];
    let f = firmware::protocol::encode(0, 5, &Command::Heartbeat { t_us: 0 }, &mut buf).unwrap();
    a.parts_mut().1.rx.extend(f.iter().copied());
    a.tick();
    let mut old = Topside::default();
    let r = old.replies(&mut a);
    assert_eq!(nacked(&r, 5), Some(NackReason::NoSession), "{r:?}");
    assert_eq!(a.link_stats().no_session, 1);
    // The first topside: a session, a Nav stream at 100 s of its clock.
    c.set_us(1_000_000);
    for k in 0..10 {
        c.advance_us(20_000);
        let (s, r) = old.send(&mut a, &nav(100_000_000 + k * 20_000));
        assert_eq!(nacked(&r, s), None, "{r:?}");
        old.send(&mut a, &Command::Heartbeat { t_us: 0 });
    }
    // It restarts: a new session, its clock from 0. Taken at once.
    let mut new = Topside {
        opened: 7, // another nonce
        ..Topside::default()
    };
    let (s, r) = new.send(&mut a, &nav(0));
    assert_eq!(nacked(&r, s), None, "{r:?}");
    let (s, r) = new.send(&mut a, &Command::Heartbeat { t_us: 0 });
    assert_eq!(nacked(&r, s), None);
    let (s, r) = new.send(&mut a, &Command::Arm);
    assert!(acked(&r, s), "{r:?}");
    // The old one's frames: refused, whatever their number.
    let (s, r) = old.send(&mut a, &Command::Disarm);
    assert_eq!(nacked(&r, s), Some(NackReason::NoSession));
    assert!(a.autopilot().armed());
}

/// The probe "one Nav stamped an hour ahead locks out 10 s": refused `ClockAhead`, and the
/// next good one is taken (fixed-rate, the vehicle's own clock).
#[test]
fn a_nav_stamped_an_hour_ahead_is_refused_and_locks_nothing_out() {
    let (mut a, c, mut t) = fixed();
    t.send(&mut a, &Command::Heartbeat { t_us: 0 });
    let t0 = 50_000_000;
    for k in 0..5 {
        c.advance_us(20_000);
        let (s, r) = t.send(&mut a, &nav(t0 + k * 20_000));
        assert_eq!(nacked(&r, s), None);
    }
    let (s, r) = t.send(&mut a, &nav(t0 + 3_600_000_000));
    assert_eq!(nacked(&r, s), Some(NackReason::ClockAhead));
    c.advance_us(20_000);
    let (s, r) = t.send(&mut a, &nav(t0 + 5 * 20_000));
    assert_eq!(nacked(&r, s), None, "the next good Nav: {r:?}");
    let (s, r) = t.send(&mut a, &Command::Arm);
    assert!(acked(&r, s), "{r:?}");
    // Within the tolerance the stamps may run ahead (jitter, drift); beyond, not.
    c.advance_us(20_000);
    let (s, r) = t.send(&mut a, &nav(t0 + 6 * 20_000 + 400_000));
    assert_eq!(nacked(&r, s), None);
    let (s, r) = t.send(&mut a, &nav(t0 + 6 * 20_000 + 1_000_000));
    assert_eq!(nacked(&r, s), Some(NackReason::ClockAhead));
}

/// The probe "one Heartbeat an hour ahead disables the link failsafe in lock-step": refused
/// `ClockAhead`; 5 s without heartbeats then disarm as specified.
#[test]
fn a_heartbeat_an_hour_ahead_does_not_disable_the_link_failsafe() {
    let (mut a, _c) = app(Config::lockstep(Board::Host));
    let mut t = Topside::default();
    let mut t_us = 1_000_000u64;
    t.send(&mut a, &Command::Heartbeat { t_us });
    t.send(&mut a, &nav(t_us));
    t.send(&mut a, &Command::SetMode(Mode::Manual));
    let (s, r) = t.send(&mut a, &Command::Arm);
    assert!(acked(&r, s));
    let (s, r) = t.send(
        &mut a,
        &Command::Heartbeat {
            t_us: t_us + 3_600_000_000,
        },
    );
    assert_eq!(nacked(&r, s), Some(NackReason::ClockAhead));
    let push = ManualThrust {
        surge: 0.5,
        yaw: 0.0,
        heave: 0.0,
    };
    let hb_at = t_us;
    let mut disarmed_at = None;
    for _ in 0..250 {
        t_us += 20_000;
        t.send(&mut a, &Command::ManualThrust(push));
        let (_, r) = t.send(&mut a, &nav(t_us));
        let tel = last_telemetry(&r).expect("telemetry");
        if !tel.armed {
            disarmed_at.get_or_insert(t_us - hb_at);
        }
    }
    assert_eq!(disarmed_at, Some(1_000_000));
}

/// The tether's `Imu` and `Pressure` only on a board without sensors of its own;
/// an `Imu` an hour ahead (emulated board, lock-step) is refused and does not move the
/// estimator's clock.
#[test]
fn tether_sensor_readings_only_without_own_sensors_and_never_an_hour_ahead() {
    use controller_core::nav::onboard::OnboardConfig;
    use controller_core::nav::ImuSample;
    let imu = |t_us| {
        Command::Imu(ImuSample {
            t_us,
            gyro_rad_s: [0.0; 3],
            accel_m_s2: [0.0, 0.0, -9.81],
        })
    };
    // A board with its own sensors (the trait's default): refused `OwnSensors`.
    #[derive(Debug, Clone, Copy)]
    struct Own;
    impl firmware::Sensors for Own {
        fn imu(&mut self, _: u64) -> Option<ImuSample> {
            None
        }
        fn pressure_pa(&mut self, _: u64) -> Option<f32> {
            None
        }
    }
    let clock = FakeClock::default();
    let pwm = || rov_tests::FakePwm::new(PWM_MAX_DUTY);
    let mut b = firmware::App::with_sensors(
        [pwm(), pwm(), pwm()],
        rov_tests::FakeSerial::default(),
        clock.clone(),
        rov_tests::controller(),
        Config::lockstep(Board::Stm32f4),
        Own,
    )
    .unwrap();
    let mut t = Topside::default();
    t.open(&mut b);
    for cmd in [
        imu(0),
        Command::Pressure {
            t_us: 0,
            pressure_pa: 1e5,
        },
    ] {
        let (s, f) = t.frame(&cmd);
        b.on_bytes(&f);
        let r = t.replies(&mut b);
        assert_eq!(nacked(&r, s), Some(NackReason::OwnSensors), "{cmd:?}");
    }
    // The emulated board: taken, but not an hour ahead.
    let (mut a, _c) = app(Config::lockstep(Board::QemuNetduinoPlus2));
    let mut t = Topside::default();
    t.send(&mut a, &Command::Heartbeat { t_us: 0 });
    let (s, r) = t.send(
        &mut a,
        &Command::StartNav {
            t_us: 0,
            initial: NavState::default(),
            config: OnboardConfig::default(),
        },
    );
    assert!(acked(&r, s), "{r:?}");
    let (s, r) = t.send(&mut a, &imu(20_000));
    assert_eq!(nacked(&r, s), None, "{r:?}");
    let (s, r) = t.send(&mut a, &imu(3_600_000_000));
    assert_eq!(nacked(&r, s), Some(NackReason::ClockAhead));
    let est_t = a.autopilot().onboard_nav().unwrap().estimator().time_us();
    assert!(est_t <= 20_000, "the estimator's clock moved to {est_t}");
    let (s, r) = t.send(&mut a, &imu(40_000));
    assert_eq!(nacked(&r, s), None, "the next good sample: {r:?}");
}

/// `SetFailsafe` only while disarmed (timeouts are not relaxed mid-dive).
#[test]
fn failsafe_timeouts_are_not_changed_while_armed() {
    let (mut a, c, mut t) = fixed();
    arm(&mut a, &c, &mut t);
    let relaxed = firmware::Failsafe {
        heartbeat_neutral_us: 2_000_000,
        heartbeat_disarm_us: 10_000_000,
        ..firmware::Failsafe::DEFAULT
    };
    let (s, r) = t.send(&mut a, &Command::SetFailsafe(relaxed));
    assert_eq!(nacked(&r, s), Some(NackReason::Armed));
    assert_eq!(*a.autopilot().failsafe(), firmware::Failsafe::DEFAULT);
    t.send(&mut a, &Command::Disarm);
    let (s, r) = t.send(&mut a, &Command::SetFailsafe(relaxed));
    assert!(acked(&r, s), "{r:?}");
}

/// The probe "a vehicle description moves neutral" and "unsafe descriptions are accepted":
/// refused with a reason, nothing changes; the disarmed and link-lost outputs stay at the
/// ESC's 1500 us whatever the description.
#[test]
fn descriptions_cannot_move_neutral_or_describe_an_unflyable_vehicle() {
    use controller_core::params::VehicleParams;
    let (mut a, c, mut t) = fixed();
    t.open(&mut a);
    let with = |f: &dyn Fn(&mut VehicleParams)| {
        let mut p = VehicleParams::OBSERVER;
        f(&mut p);
        Command::SetVehicle(p)
    };
    for cmd in [
        with(&|p| {
            p.pulse.min_us = 500.0;
            p.pulse.neutral_us = 1100.0;
        }),
        with(&|p| p.pulse.neutral_us = 1150.0),
        with(&|p| p.pulse.max_us = 2400.0),
        with(&|p| {
            p.thrust_max_forward_n = 1e-3;
            p.thrust_max_reverse_n = 1e-3;
        }),
        with(&|p| p.x_uu = 1e5),
        with(&|p| p.y_v = 1e5),
        with(&|p| p.mass_kg = 1e-3),
        with(&|p| p.mass_kg = 200.0),
        with(&|p| p.i_z_kg_m2 = 1e-6),
        with(&|p| p.x_udot_kg = -1e3),
        with(&|p| p.thruster_time_constant_s = 30.0),
    ] {
        let before = snapshot(&a);
        let (s, r) = t.deliver(&mut a, &cmd);
        assert_eq!(nacked(&r, s), Some(NackReason::OutOfRange), "{cmd:?}");
        assert_eq!(snapshot(&a), before);
    }
    // The Observer itself, and a heavier vehicle, are flyable.
    let (s, r) = t.send(&mut a, &with(&|p| p.mass_kg = 14.0));
    assert!(acked(&r, s), "{r:?}");
    // Disarmed, then armed with the link lost: 1500 us.
    fly(&mut a, &c, &mut t, 2);
    assert_eq!(pulses_us(&mut a), [1500.0; 3]);
    arm(&mut a, &c, &mut t);
    c.advance_us(1_200_000);
    a.tick();
    assert!(!a.autopilot().armed());
    assert_eq!(pulses_us(&mut a), [1500.0; 3]);
}

/// The probe "targets without bounds": references, targets and gains out of the vehicle's
/// range are refused (a GUIDED target 50 m above the surface, a hold at 1e30 / 1e6 m up,
/// gains of 1e30); missions were bounded already.
#[test]
fn references_and_gains_have_bounds() {
    let (mut a, _c, mut t) = fixed();
    t.open(&mut a);
    let r = |reference| Command::SetReference {
        reference,
        start_us: None,
    };
    for cmd in [
        r(Reference::Hold {
            pos_m: [0.0, 0.0, -50.0],
        }),
        r(Reference::Hold {
            pos_m: [1e30, 0.0, -1e6],
        }),
        r(Reference::Hold {
            pos_m: [0.0, 0.0, 150.0],
        }),
        r(Reference::Hold {
            pos_m: [2_000.0, 0.0, 1.0],
        }),
        r(Reference::Line {
            start_m: [0.0, 0.0, 1.0],
            heading_rad: 0.0,
            speed_m_s: 5.0,
        }),
        r(Reference::Circle {
            center_m: [995.0, 0.0, 1.0],
            radius_m: 10.0,
            speed_m_s: 0.2,
        }),
        r(Reference::Helix {
            center_m: [0.0, 0.0, 1.0],
            radius_m: 5.0,
            speed_m_s: 0.2,
            depth_rate_m_s: 3.0,
        }),
        r(Reference::Paper(PaperPolynomial {
            h_r_m: -10.0,
            t_f_s: 100.0,
        })),
        r(Reference::Paper(PaperPolynomial {
            h_r_m: 10.0,
            t_f_s: 1.0,
        })),
    ] {
        let before = snapshot(&a);
        let (s, rep) = t.deliver(&mut a, &cmd);
        assert_eq!(nacked(&rep, s), Some(NackReason::OutOfRange), "{cmd:?}");
        assert_eq!(snapshot(&a), before);
    }
    for bad in [1e30f32, 5e3] {
        let mut g = Gains::default();
        g.tracking.xy_kp = bad;
        let (s, rep) = t.send(&mut a, &Command::SetTrackingGains(g.tracking));
        assert_eq!(nacked(&rep, s), Some(NackReason::OutOfRange), "{bad}");
        let mut g = Gains::default();
        g.paper_xz.c1w = bad;
        let (s, rep) = t.send(
            &mut a,
            &Command::SetPaperGains {
                xz: g.paper_xz,
                xy: g.paper_xy,
            },
        );
        assert_eq!(nacked(&rep, s), Some(NackReason::OutOfRange), "{bad}");
    }
    assert_eq!(*a.autopilot().controller().gains(), Gains::default());
    // In range: taken.
    let (s, rep) = t.send(&mut a, &r(Reference::Paper(PaperPolynomial::PAPER)));
    assert!(acked(&rep, s), "{rep:?}");
}
