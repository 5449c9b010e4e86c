//! The motor test: one thruster at the pulse asked for, the others neutral, for the window;
//! armed only; ended by its window (with a disarm), a command, a lost link or a disarm;
//! nothing of it after an arming or a restart.
#![allow(clippy::panic, clippy::unwrap_used, clippy::indexing_slicing)]

use super::*;
use crate::protocol::{Command, ManualThrust, Mode, MotorTest, NackReason, NavSample};
use controller_core::alloc::ESC_NEUTRAL_US;
use controller_core::controller::Gains;
use controller_core::params::Vehicle;

const PERIOD_US: u64 = 10_000;

fn autopilot() -> Autopilot {
    let c = Controller::new(Vehicle::observer(), Gains::default()).unwrap_or_else(|e| {
        panic!("the Observer's controller: {e}");
    });
    Autopilot::new(c, Failsafe::DEFAULT)
}

fn send(a: &mut Autopilot, t: u64, seq: &mut u16, cmd: &Command) -> Result<(), NackReason> {
    *seq = seq.wrapping_add(1);
    a.handle(t, *seq, cmd)
}

/// Heartbeat and a navigation state at `t` (the vehicle at rest at 2 m).
fn keep_alive(a: &mut Autopilot, t: u64, seq: &mut u16) {
    assert_eq!(send(a, t, seq, &Command::Heartbeat { t_us: t }), Ok(()));
    let state = NavState {
        z_m: 2.0,
        ..NavState::default()
    };
    let nav = Command::Nav(NavSample { t_us: t, state });
    assert_eq!(send(a, t, seq, &nav), Ok(()));
}

/// Armed in `mode` at `t`.
fn armed_in(mode: Mode) -> (Autopilot, u64, u16) {
    let mut a = autopilot();
    let (t, mut seq) = (1_000_000, 0);
    keep_alive(&mut a, t, &mut seq);
    assert_eq!(send(&mut a, t, &mut seq, &Command::SetMode(mode)), Ok(()));
    assert_eq!(send(&mut a, t, &mut seq, &Command::Arm), Ok(()));
    (a, t, seq)
}

fn test(thruster: u8, pulse_us: u16, window_ms: u16) -> Command {
    Command::MotorTest(MotorTest {
        thruster,
        pulse_us,
        window_ms,
    })
}

/// The pulses of the steps from `*t` for `steps` periods, with the heartbeat and navigation
/// before each.
fn fly(a: &mut Autopilot, t: &mut u64, seq: &mut u16, steps: u32) -> Vec<[f32; 3]> {
    (0..steps)
        .map(|_| {
            *t += PERIOD_US;
            keep_alive(a, *t, seq);
            a.step(*t).pulse_us
        })
        .collect()
}

#[test]
fn one_thruster_turns_at_its_pulse_the_others_neutral_for_the_window_then_it_disarms() {
    for thruster in 0..3u8 {
        let (mut a, mut t, mut seq) = armed_in(Mode::Manual);
        assert_eq!(
            send(&mut a, t, &mut seq, &test(thruster, 1650, 300)),
            Ok(())
        );
        let start = t;
        let pulses = fly(&mut a, &mut t, &mut seq, 40);
        for (k, p) in pulses.iter().enumerate() {
            let at_us = (k as u64 + 1) * PERIOD_US;
            let within = start + at_us < start + 300_000;
            for (i, &pi) in p.iter().enumerate() {
                let want = if within && i == usize::from(thruster) {
                    1650.0
                } else {
                    ESC_NEUTRAL_US
                };
                assert_eq!(pi, want, "thruster {thruster}, output {i}, {at_us} us in");
            }
        }
        assert!(!a.armed(), "the window's end disarms (ArduSub's timeout)");
        assert_eq!(a.motor_test(), None);
    }
}

#[test]
fn the_thrust_reported_is_the_tested_thrusters_own() {
    let (mut a, mut t, mut seq) = armed_in(Mode::Manual);
    assert_eq!(send(&mut a, t, &mut seq, &test(2, 1300, 500)), Ok(()));
    t += PERIOD_US;
    keep_alive(&mut a, t, &mut seq);
    let out = a.step(t);
    let f = out.allocation.thrust_n;
    assert!(f[2] < -1.0, "the vertical thruster reverses: {f:?}");
    assert_eq!((f[0], f[1]), (0.0, 0.0));
    assert_eq!(out.allocation.achieved.heave_n, f[2]);
}

#[test]
fn a_renewed_request_keeps_it_going_and_a_refused_one_changes_nothing() {
    let (mut a, mut t, mut seq) = armed_in(Mode::Stabilize);
    assert_eq!(send(&mut a, t, &mut seq, &test(0, 1700, 500)), Ok(()));
    // Renewed every 0.4 s for 2 s: the thruster turns throughout.
    for _ in 0..5 {
        let pulses = fly(&mut a, &mut t, &mut seq, 40);
        assert!(pulses.iter().all(|p| p[0] == 1700.0), "{pulses:?}");
        assert_eq!(send(&mut a, t, &mut seq, &test(0, 1700, 500)), Ok(()));
    }
    // Out of range: refused, the test in force goes on.
    for bad in [
        test(3, 1700, 500),
        test(0, 1950, 500),
        test(0, 1700, 501),
        test(0, 1700, 0),
    ] {
        assert_eq!(send(&mut a, t, &mut seq, &bad), Err(NackReason::OutOfRange));
    }
    assert_eq!(a.motor_test().map(|m| m.pulse_us), Some(1700));
    assert!(fly(&mut a, &mut t, &mut seq, 10)
        .iter()
        .all(|p| p[0] == 1700.0));
}

#[test]
fn refused_disarmed_and_never_acts_after_an_arming() {
    let mut a = autopilot();
    let (mut t, mut seq) = (1_000_000, 0);
    keep_alive(&mut a, t, &mut seq);
    assert_eq!(
        send(&mut a, t, &mut seq, &Command::SetMode(Mode::Manual)),
        Ok(())
    );
    assert_eq!(
        send(&mut a, t, &mut seq, &test(1, 1800, 500)),
        Err(NackReason::NotArmed)
    );
    assert_eq!(send(&mut a, t, &mut seq, &Command::Arm), Ok(()));
    assert_eq!(a.motor_test(), None);
    let pulses = fly(&mut a, &mut t, &mut seq, 20);
    assert!(
        pulses.iter().all(|p| *p == [ESC_NEUTRAL_US; 3]),
        "{pulses:?}"
    );
}

#[test]
fn any_other_command_ends_it_and_flight_goes_on() {
    let stick = |surge| {
        Command::ManualThrust(ManualThrust {
            surge,
            yaw: 0.0,
            heave: 0.0,
        })
    };
    for (ender, armed_after) in [
        (Command::SetMode(Mode::Manual), true),
        (Command::SetMode(Mode::Idle), true),
        (stick(0.5), true),
        (Command::MissionClear, true),
        (Command::Disarm, false),
    ] {
        let (mut a, mut t, mut seq) = armed_in(Mode::Manual);
        assert_eq!(send(&mut a, t, &mut seq, &test(1, 1800, 500)), Ok(()));
        // A centred stick and the keep-alives do not end it.
        assert_eq!(send(&mut a, t, &mut seq, &stick(0.0)), Ok(()));
        assert!(fly(&mut a, &mut t, &mut seq, 5)
            .iter()
            .all(|p| p[1] == 1800.0));
        assert_eq!(send(&mut a, t, &mut seq, &ender), Ok(()), "{ender:?}");
        assert_eq!(a.motor_test(), None, "{ender:?}");
        let pulses = fly(&mut a, &mut t, &mut seq, 5);
        assert!(
            pulses.iter().all(|p| p[1] != 1800.0),
            "{ender:?}: {pulses:?}"
        );
        assert_eq!(a.armed(), armed_after, "{ender:?}");
    }
}

#[test]
fn a_lost_heartbeat_ends_it_at_once() {
    let (mut a, mut t, mut seq) = armed_in(Mode::Manual);
    assert_eq!(send(&mut a, t, &mut seq, &test(2, 1750, 500)), Ok(()));
    let last_heartbeat = t;
    // Navigation only, no heartbeat: from the neutral timeout (0.5 s) the output is neutral
    // and the test is over.
    let mut turned_after_loss = 0;
    for _ in 0..60 {
        t += PERIOD_US;
        let nav = Command::Nav(NavSample {
            t_us: t,
            state: NavState::default(),
        });
        assert_eq!(send(&mut a, t, &mut seq, &nav), Ok(()));
        let out = a.step(t);
        let lost = t - last_heartbeat >= Failsafe::DEFAULT.heartbeat_neutral_us;
        if lost && out.pulse_us[2] != ESC_NEUTRAL_US {
            turned_after_loss += 1;
        }
    }
    assert_eq!(turned_after_loss, 0);
    assert_eq!(a.motor_test(), None);
}

#[test]
fn a_new_session_or_a_restart_ends_it() {
    let (mut a, t, mut seq) = armed_in(Mode::Manual);
    assert_eq!(send(&mut a, t, &mut seq, &test(0, 1600, 500)), Ok(()));
    a.new_session();
    assert_eq!(a.motor_test(), None);
    // A restart: a new autopilot knows no test.
    assert_eq!(autopilot().motor_test(), None);
}
