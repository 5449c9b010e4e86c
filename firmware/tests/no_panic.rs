//! Link-time proof that the decoder and the control path cannot panic.
//!
//! With the `no-panic` feature, `FrameDecoder::push` (COBS, CRC and postcard decoding of a
//! command), `Autopilot::handle` (every command's validation) and `Autopilot::step`
//! (failsafes, control law, allocation) carry `#[no_panic]`: if the optimizer cannot remove
//! every panic path from them, *linking this test fails*. `no-panic-step` adds per-function
//! probes of controller-core (`tests/no_panic_core.rs`) that name the culprit. Optimized
//! builds only:
//!
//! ```text
//! cargo test -p firmware --release --features no-panic --test no_panic
//! cargo test -p firmware --release --features no-panic-step --test no_panic --test no_panic_core
//! ```
//!
//! Without the feature this file is empty.
#![cfg(feature = "no-panic")]
// Test code: a failed expectation should stop the test.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use controller_core::controller::{Controller, Gains};
use controller_core::params::Vehicle;
use firmware::protocol::{Command, Decoded, FrameDecoder, Mode};
use firmware::{Autopilot, Failsafe};
use std::hint::black_box;

#[test]
fn decoder_and_control_step_link_without_panics() {
    let mut d = FrameDecoder::<Command>::new();
    let mut frames = 0;
    for b in black_box([0u8, 3, 1, 2, 0, 9, 9, 9, 0]) {
        if let Some(Decoded::Frame { .. }) = d.push(b) {
            frames += 1;
        }
    }
    assert_eq!(frames, 0);
    let c = Controller::new(Vehicle::observer(), Gains::default()).unwrap();
    let mut a = Autopilot::new(c, Failsafe::DEFAULT);
    let _ = a.handle(black_box(0), 0, &black_box(Command::Heartbeat { t_us: 0 }));
    let _ = a.handle(black_box(0), 1, &black_box(Command::SetMode(Mode::Manual)));
    let out = a.step(black_box(20_000));
    assert_eq!(out.pulse_us, [1500.0; 3]);
}
