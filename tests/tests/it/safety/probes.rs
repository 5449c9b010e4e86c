//! The safety probes, each a test: stale sticks, old references, late AUTO, replayed frames,
//! sessions, clocks ahead, tether sensor readings.

use super::*;

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

/// A surface restarted mid-dive with the pilot's stick held (probe: the stick of the killed
/// surface still at 1743 us on the first `SERVO_OUTPUT_RAW` after the restart): the new
/// surface's `OpenSession` ends the old pilot input at once, and the new session's own held
/// stick gives no thrust until it is seen at centre. The surface in force renewing its
/// session (framed in it) is not a new surface: its stick keeps acting through the renewal.
#[test]
fn a_new_surface_ends_the_old_pilots_stick_and_a_renewal_keeps_it() {
    let (mut a, c, mut t) = fixed();
    t.send(&mut a, &Command::SetMode(Mode::Manual));
    arm(&mut a, &c, &mut t);
    let ahead = Command::ManualThrust(ManualThrust {
        surge: 0.8,
        ..ManualThrust::default()
    });
    let centred = Command::ManualThrust(ManualThrust::default());
    let period = |a: &mut TestApp, t: &mut Topside, sticks: &Command| {
        c.advance_us(20_000);
        t.send(a, &Command::Heartbeat { t_us: 0 });
        t.send(a, sticks);
    };
    period(&mut a, &mut t, &centred);
    period(&mut a, &mut t, &ahead);
    period(&mut a, &mut t, &ahead);
    let flying = pulses_us(&mut a);
    assert!(flying[0] > 1600.0 && flying[1] > 1600.0, "{flying:?}");

    // The surface in force renews its session: the stick acts in every period through it.
    let f = t.client.renew(0x5EED_AAAA, 0).unwrap();
    a.on_bytes(f.bytes());
    let r = t.replies(&mut a);
    assert!(
        r.iter().any(|r| matches!(
            r,
            Reply::Session {
                nonce: 0x5EED_AAAA,
                ..
            }
        )),
        "{r:?}"
    );
    assert_ne!(t.session(), 0);
    for _ in 0..5 {
        period(&mut a, &mut t, &ahead);
        assert_eq!(pulses_us(&mut a), flying, "the renewal changed the thrust");
    }

    // The surface is killed and another starts within the stale-stick time: neutral from
    // the step after its `OpenSession`, before it sends any stick.
    let mut new = Topside {
        opened: 9,
        ..Topside::default()
    };
    new.open(&mut a);
    c.advance_us(20_000);
    new.send(&mut a, &Command::Heartbeat { t_us: 0 });
    assert_eq!(
        pulses_us(&mut a),
        [1500.0; 3],
        "the old surface's stick acts"
    );
    assert!(a.autopilot().armed(), "the vehicle dives on, armed");
    // The new surface's pilot holds the stick: still neutral, until it is seen centred.
    for _ in 0..10 {
        period(&mut a, &mut new, &ahead);
        assert_eq!(
            pulses_us(&mut a),
            [1500.0; 3],
            "a held stick of the new session"
        );
    }
    // (Each period's step flies the stick of the period before.)
    period(&mut a, &mut new, &centred);
    period(&mut a, &mut new, &ahead);
    period(&mut a, &mut new, &ahead);
    assert_eq!(
        pulses_us(&mut a),
        flying,
        "the new pilot's stick after centre"
    );
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
