//! Every safety requirement of the firmware, on the host with fake PWM, serial and clock: the
//! helpers here, the tests by concern in the files below.

// Test code: a failed expectation should stop the test.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

mod basics;
mod lockstep;
mod modes;
mod probes;
mod refusals;

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

fn snapshot(a: &TestApp) -> String {
    format!("{:?}", a.autopilot())
}

/// Keep the link and the navigation fresh for `steps` control periods of 20 ms.
fn fly(a: &mut TestApp, c: &FakeClock, t: &mut Topside, steps: u32) {
    for _ in 0..steps {
        c.advance_us(20_000);
        t.send(a, &nav(c.get_us()));
        t.send(a, &Command::Heartbeat { t_us: 0 });
    }
}
