//! The vehicle's thin node in the paper's layout (`docs/deployment.md`): the
//! boards and images of the [`firmware::node`] role. The role, its link and its traits are
//! the firmware crate's (shared with the topside, tested there); here are only
//!
//! - [`board`]: the node on an STM32F405 (QEMU `netduinoplus2`), linked into the node budget;
//! - [`emu_board`]: the emulated node, its sensors and its clock from the host
//!   (`firmware::harness`; the `node-emu` image).
//!
//! A crate of its own so that the node gets its own `opt-level` (root `Cargo.toml`).
#![no_std]

#[cfg(target_os = "none")]
pub mod board;
#[cfg(target_os = "none")]
pub mod emu_board;
