//! ROV firmware library: the tether protocol, the vehicle state machine with its failsafes,
//! and the application loop generic over `embedded-hal` / `embedded-io` traits.
//!
//! Everything here builds and is tested on the host; the only hardware code is [`board`]
//! (compiled for `target_os = "none"` only), used by the two thin binaries `stm32f4` (the
//! real board) and `qemu` (the emulated `netduinoplus2`).
//!
//! - [`protocol`]: the `protocol` crate (messages, framing with postcard + CRC-32 + COBS, the
//!   streaming decoder), re-exported;
//! - [`autopilot`]: arming, modes, failsafes and the control step, no I/O;
//! - [`app`]: the loop: serial in, control, PWM out, telemetry;
//! - the paper's layout (`docs/deployment.md`): [`node_link`] (the wire between
//!   the surface and the vehicle), [`node`] (the vehicle's thin role), [`topside_link`] (the
//!   `App` at the surface, its thrusters and sensors over the node link).
#![cfg_attr(not(any(test, feature = "std")), no_std)]

pub mod app;
pub mod autopilot;
pub mod compass_swing;
pub mod harness;
pub mod health;
pub mod node;
pub mod node_link;
pub mod protocol;
pub mod sensors;
pub mod startup;
pub mod topside_link;

#[cfg(target_os = "none")]
pub mod board;
#[cfg(target_os = "none")]
pub mod emulated;
#[cfg(all(target_os = "none", feature = "topside-board"))]
pub mod topside_board;
#[cfg(all(target_os = "none", feature = "topside-board"))]
pub mod topside_emu_board;

pub use app::{App, Config, ConfigError, Monotonic, Timing};
pub use autopilot::{Autopilot, Failsafe, StepOutput};
pub use sensors::{BusSensors, NoSensors, Sensors};
pub use startup::{loop_pass, start_outputs, EscOutput, Watchdog};
