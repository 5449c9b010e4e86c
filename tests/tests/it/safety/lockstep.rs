//! Lock-step: the firmware on the host's time stamps; the timing reported.

use super::*;

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
