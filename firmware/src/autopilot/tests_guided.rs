//! GUIDED: its entry's guards, a target's checks, the go-to flown and held, and a stick
//! that stops it.
#![allow(clippy::unwrap_used)]

use super::*;
use crate::health::HealthParams;
use crate::protocol::{ManualThrust, Mode, NackReason, NavSample};
use controller_core::controller::Gains;
use controller_core::params::Vehicle;

const T0: u64 = 1_000_000;
const PERIOD_US: u64 = 20_000;

fn alive(a: &mut Autopilot, t: u64, seq: &mut u16) {
    *seq += 1;
    a.handle(t, *seq, &Command::Heartbeat { t_us: t }).unwrap();
    let state = NavState {
        z_m: 2.0,
        ..NavState::default()
    };
    *seq += 1;
    a.handle(t, *seq, &Command::Nav(NavSample { t_us: t, state }))
        .unwrap();
}

fn send(a: &mut Autopilot, t: u64, seq: &mut u16, cmd: &Command) -> Result<(), NackReason> {
    *seq += 1;
    a.handle(t, *seq, cmd)
}

fn target(pos_m: [f32; 3]) -> Command {
    Command::GuidedTarget { pos_m }
}

/// Alive at rest at 2 m deep, `params` in force, in GUIDED and armed.
fn armed_in_guided(params: HealthParams) -> (Autopilot, u64, u16) {
    let c = Controller::new(Vehicle::observer(), Gains::default()).unwrap();
    let mut a = Autopilot::new(c, Failsafe::DEFAULT);
    let (t, mut seq) = (T0, 0);
    send(&mut a, t, &mut seq, &Command::SetHealth(params)).unwrap();
    alive(&mut a, t, &mut seq);
    send(&mut a, t, &mut seq, &Command::SetMode(Mode::Guided)).unwrap();
    // Disarmed: a target is refused (never flown after an arming).
    let ahead = target([5.0, 0.0, 2.0]);
    assert_eq!(send(&mut a, t, &mut seq, &ahead), Err(NackReason::NotArmed));
    send(&mut a, t, &mut seq, &Command::Arm).unwrap();
    (a, t, seq)
}

#[test]
fn guided_needs_a_fresh_navigation_state() {
    let c = Controller::new(Vehicle::observer(), Gains::default()).unwrap();
    let mut a = Autopilot::new(c, Failsafe::DEFAULT);
    let r = a.handle(T0, 1, &Command::SetMode(Mode::Guided));
    assert_eq!(r, Err(NackReason::NavStale));
    assert_eq!(a.mode(), Mode::Idle);
}

#[test]
fn armed_in_guided_the_vehicle_holds_where_it_is_until_a_target() {
    let (mut a, t, _) = armed_in_guided(HealthParams::DEFAULT);
    assert_eq!(a.guided_point(), Some([0.0, 0.0, 2.0]));
    let out = a.step(t);
    assert!(out.law_ran);
    // At rest on the point: the law asks for little (the net buoyancy's heave only).
    assert!(out.requested.surge_n.abs() < 0.5, "{:?}", out.requested);
}

#[test]
fn a_target_is_checked_and_a_refused_one_changes_nothing() {
    let params = HealthParams {
        depth_limit_m: 10.0,
        ..HealthParams::DEFAULT
    };
    let (mut a, t, mut seq) = armed_in_guided(params);
    let cases = [
        ([f32::NAN, 0.0, 2.0], NackReason::NonFinite),
        ([0.0, 1000.5, 2.0], NackReason::OutOfRange),
        ([0.0, 0.0, -0.5], NackReason::OutOfRange),
        ([0.0, 0.0, 100.5], NackReason::OutOfRange),
        ([5.0, 0.0, 12.0], NackReason::DepthLimit),
    ];
    for (pos_m, why) in cases {
        assert_eq!(
            send(&mut a, t, &mut seq, &target(pos_m)),
            Err(why),
            "{pos_m:?}"
        );
        assert_eq!(a.guided_point(), Some([0.0, 0.0, 2.0]));
    }
    // Outside GUIDED: refused by name.
    send(&mut a, t, &mut seq, &Command::SetMode(Mode::Hold)).unwrap();
    let r = send(&mut a, t, &mut seq, &target([5.0, 0.0, 2.0]));
    assert_eq!(r, Err(NackReason::NotInGuided));
    assert_eq!(a.guided_point(), None);
}

#[test]
fn a_target_ahead_is_flown_to_and_a_stick_stops_the_go_to_where_the_vehicle_is() {
    let (mut a, mut t, mut seq) = armed_in_guided(HealthParams::DEFAULT);
    assert_eq!(send(&mut a, t, &mut seq, &target([5.0, 0.0, 2.0])), Ok(()));
    assert_eq!(a.guided_point(), Some([5.0, 0.0, 2.0]));
    t += PERIOD_US;
    alive(&mut a, t, &mut seq);
    let out = a.step(t);
    // 5 m ahead: the law pushes ahead with both horizontal thrusters.
    let [f1, f2, _] = out.allocation.thrust_n;
    assert!(f1 > 1.0 && f2 > 1.0, "{f1} {f2}");
    // Sticks: centred first (the gate opens), then surge ahead stops the go-to here.
    let centred = Command::ManualThrust(ManualThrust::default());
    send(&mut a, t, &mut seq, &centred).unwrap();
    assert_eq!(a.guided_point(), Some([5.0, 0.0, 2.0]));
    let ahead = Command::ManualThrust(ManualThrust {
        surge: 0.5,
        ..ManualThrust::default()
    });
    send(&mut a, t, &mut seq, &ahead).unwrap();
    assert_eq!(a.guided_point(), Some([0.0, 0.0, 2.0]));
    assert_eq!(a.mode(), Mode::Guided);
    t += PERIOD_US;
    alive(&mut a, t, &mut seq);
    let out = a.step(t);
    assert!(out.requested.surge_n.abs() < 0.5, "{:?}", out.requested);
}

#[test]
fn a_stick_held_through_the_entry_does_not_stop_the_go_to() {
    let (mut a, t, mut seq) = armed_in_guided(HealthParams::DEFAULT);
    send(&mut a, t, &mut seq, &target([5.0, 0.0, 2.0])).unwrap();
    let ahead = Command::ManualThrust(ManualThrust {
        surge: 0.5,
        ..ManualThrust::default()
    });
    send(&mut a, t, &mut seq, &ahead).unwrap();
    assert_eq!(a.guided_point(), Some([5.0, 0.0, 2.0]));
}
