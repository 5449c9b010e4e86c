//! Boot, the PWM period, arming, the link and navigation failsafes, disarming.

use super::*;

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
