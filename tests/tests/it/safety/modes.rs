//! The pilot-assisted modes and missions.

use super::*;

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
