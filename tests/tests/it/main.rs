//! The cross-crate tests in one binary: each module was a test binary of its own, and
//! linking each against the simulator cost more than running it.
//!
//! `cargo test -p rov-tests --test it MODULE::` runs one module (e.g. `safety::`).

mod board_startup;
mod compass_cal;
mod compass_swing;
mod fuzz;
mod nav_ready;
mod onboard_nav;
mod qemu;
mod safety;
mod serial_115200;
mod session;
