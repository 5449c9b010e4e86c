//! The arming gate and the stick gate: a stick held off centre never arms the vehicle, and
//! after an arming, a change of mode or a restart the pilot's thrust waits for the sticks to
//! be seen at centre.
#![allow(clippy::panic, clippy::unwrap_used)]

use super::*;
use crate::protocol::{Command, ManualThrust, Mode, NackReason, NavSample};
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

fn sticks(surge: f32, yaw: f32, heave: f32) -> Command {
    Command::ManualThrust(ManualThrust { surge, yaw, heave })
}

/// Heartbeat and a navigation state at `t` (the vehicle at rest at 2 m).
fn keep_alive(a: &mut Autopilot, t: u64, seq: &mut u16) {
    *seq = seq.wrapping_add(1);
    assert_eq!(a.handle(t, *seq, &Command::Heartbeat { t_us: t }), Ok(()));
    let state = NavState {
        z_m: 2.0,
        ..NavState::default()
    };
    *seq = seq.wrapping_add(1);
    let nav = Command::Nav(NavSample { t_us: t, state });
    assert_eq!(a.handle(t, *seq, &nav), Ok(()));
}

fn send(a: &mut Autopilot, t: u64, seq: &mut u16, cmd: &Command) -> Result<(), NackReason> {
    *seq = seq.wrapping_add(1);
    a.handle(t, *seq, cmd)
}

/// Largest distance of a pulse from neutral over `steps` periods from `*t`, sending `cmd`
/// (with the heartbeat and navigation) before every step.
fn fly(a: &mut Autopilot, t: &mut u64, seq: &mut u16, cmd: &Command, steps: u32) -> f32 {
    let mut worst = 0.0f32;
    for _ in 0..steps {
        *t += PERIOD_US;
        keep_alive(a, *t, seq);
        assert_eq!(send(a, *t, seq, cmd), Ok(()));
        let out = a.step(*t);
        for p in out.pulse_us {
            worst = worst.max((p - ESC_NEUTRAL_US).abs());
        }
    }
    worst
}

/// A vehicle just booted, alive, in `mode`, disarmed, at `t`.
fn booted(mode: Mode) -> (Autopilot, u64, u16) {
    let mut a = autopilot();
    let (mut t, mut seq) = (1_000_000, 0);
    keep_alive(&mut a, t, &mut seq);
    assert_eq!(send(&mut a, t, &mut seq, &Command::SetMode(mode)), Ok(()));
    t += PERIOD_US;
    keep_alive(&mut a, t, &mut seq);
    (a, t, seq)
}

#[test]
fn arming_is_refused_while_the_latest_stick_state_is_off_centre_whatever_its_age() {
    for mode in [Mode::Manual, Mode::Stabilize, Mode::DepthHold] {
        let (mut a, mut t, mut seq) = booted(mode);
        // Full ahead while disarmed, then the sticks go quiet for 2 s (the surface forwards
        // nothing while disarmed): the latest state received is still off centre.
        assert_eq!(send(&mut a, t, &mut seq, &sticks(1.0, 0.0, 0.0)), Ok(()));
        for _ in 0..200 {
            t += PERIOD_US;
            keep_alive(&mut a, t, &mut seq);
            a.step(t);
        }
        assert_eq!(
            send(&mut a, t, &mut seq, &Command::Arm),
            Err(NackReason::SticksNotCentred),
            "{mode:?}"
        );
        assert!(!a.armed());
        // Centred: the arming is taken.
        assert_eq!(send(&mut a, t, &mut seq, &sticks(0.0, 0.0, 0.0)), Ok(()));
        assert_eq!(send(&mut a, t, &mut seq, &Command::Arm), Ok(()), "{mode:?}");
    }
}

#[test]
fn a_stick_held_at_an_arming_without_stick_state_gives_no_thrust_until_centred() {
    let (mut a, mut t, mut seq) = booted(Mode::Manual);
    // No stick state before the arming (the surface forwarded none).
    assert_eq!(send(&mut a, t, &mut seq, &Command::Arm), Ok(()));
    let ahead = sticks(1.0, 0.0, 0.0);
    // 1 s of full ahead: neutral throughout (the stick counts as centred).
    assert_eq!(fly(&mut a, &mut t, &mut seq, &ahead, 100), 0.0);
    // Centred once, then ahead: thrust.
    assert_eq!(
        fly(&mut a, &mut t, &mut seq, &sticks(0.0, 0.0, 0.0), 1),
        0.0
    );
    assert!(fly(&mut a, &mut t, &mut seq, &ahead, 5) > 300.0);
}

#[test]
fn a_change_of_mode_with_the_stick_held_gives_no_thrust_until_centred() {
    let (mut a, mut t, mut seq) = booted(Mode::Manual);
    assert_eq!(send(&mut a, t, &mut seq, &sticks(0.0, 0.0, 0.0)), Ok(()));
    assert_eq!(send(&mut a, t, &mut seq, &Command::Arm), Ok(()));
    let ahead = sticks(1.0, 0.0, 0.0);
    assert!(fly(&mut a, &mut t, &mut seq, &ahead, 5) > 300.0);
    // Into Stabilize and back to Manual with the stick held full ahead.
    for mode in [Mode::Stabilize, Mode::Manual] {
        assert_eq!(send(&mut a, t, &mut seq, &Command::SetMode(mode)), Ok(()));
        let worst = fly(&mut a, &mut t, &mut seq, &ahead, 100);
        // Stabilize holds heading and depth with centred sticks: a small law output, never
        // the stick's full ahead.
        assert!(worst < 100.0, "{mode:?}: {worst} us from neutral");
        assert!(fly(&mut a, &mut t, &mut seq, &sticks(0.0, 0.0, 0.0), 1) < 100.0);
        assert!(fly(&mut a, &mut t, &mut seq, &ahead, 5) > 300.0, "{mode:?}");
    }
}

#[test]
fn after_a_restart_a_held_stick_gives_no_thrust_until_centred() {
    // A restart is a new autopilot, booted disarmed and with no stick state: armed, the
    // stick that arrives next, full astern with some yaw, gives nothing.
    let (mut a, mut t, mut seq) = booted(Mode::Manual);
    assert_eq!(send(&mut a, t, &mut seq, &Command::Arm), Ok(()));
    let astern = sticks(-1.0, 0.5, 0.0);
    assert_eq!(fly(&mut a, &mut t, &mut seq, &astern, 100), 0.0);
}

#[test]
fn a_centred_stick_seen_at_the_arming_lets_the_next_stick_act() {
    let (mut a, mut t, mut seq) = booted(Mode::Manual);
    assert_eq!(send(&mut a, t, &mut seq, &sticks(0.01, -0.02, 0.0)), Ok(()));
    assert_eq!(send(&mut a, t, &mut seq, &Command::Arm), Ok(()));
    assert!(fly(&mut a, &mut t, &mut seq, &sticks(1.0, 0.0, 0.0), 5) > 300.0);
}
