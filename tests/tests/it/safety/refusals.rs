//! Refused commands: each Nacked with its reason, nothing changed (values, protocol version,
//! vehicle descriptions, failsafe timeouts, bounds).

use super::*;

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
    let f = encode_with_version(
        firmware::protocol::PROTOCOL_VERSION + 1,
        0,
        1234,
        &Command::Arm,
        &mut buf,
    )
    .unwrap();
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
