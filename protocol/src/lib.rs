//! The ROV's tether protocol, shared by the vehicle and the surface: [`messages`],
//! [`framing`], the streaming [`decoder`], the wire's limits that both ends check
//! ([`limits`]), and [`Client`], the surface's end of a session (no I/O of its own).
//!
//! `no_std`, no allocation; the firmware re-exports it as `firmware::protocol`.
//!
//! A frame on the wire is
//!
//! ```text
//! 0x00 ++ COBS( postcard(Envelope { version: u8, seq: u16, session: u32, msg }) ++ CRC-32/ISO-HDLC(le) ) ++ 0x00
//! ```
//!
//! - `postcard` gives a compact, stable serde encoding (varints, `f32` as 4 bytes LE,
//!   enums by variant index);
//! - the CRC-32 covers the whole postcard payload (the version and sequence number too) and is
//!   appended little-endian;
//! - COBS removes every zero byte so `0x00` only ever ends a frame: a receiver that loses
//!   bytes or joins mid-stream resynchronizes on the next zero. Frames start with a zero
//!   too, so a frame that follows garbage or a truncated frame is never glued to it (the
//!   decoder ignores the empty frame between two zeros).
//!
//! A payload is at most [`MAX_PAYLOAD_LEN`] bytes, so a frame is at most [`MAX_FRAME_LEN`]
//! bytes including its delimiters; both are compile-time constants and every message type is
//! tested to fit. Postcard's serde path writes and reads the payload, the `crc` crate checks
//! it, the `cobs` crate frames it: no part of the format is written by hand. The decoder ([`FrameDecoder`]) drops anything else and counts why
//! ([`DropCounters`]). Every message carries a sequence number so `Ack` / `Nack` (and the
//! lock-step `Telemetry`) can name the command they answer.
//!
//! `docs/protocol.md` has the message table and how the emulated board is driven.

#![cfg_attr(not(any(test, feature = "std")), no_std)]

pub mod client;
pub mod decoder;
pub mod framing;
pub mod health;
pub mod ident;
pub mod limits;
pub mod measured;
pub mod messages;
pub mod motor_test;
pub mod nack;

pub use client::{Answer, Client, ClientConfig, Event, Frame, SendError, Sent};
pub use decoder::{decode_frame, Decoded, DropCounters, DropReason, FrameDecoder};
pub use framing::{
    encode, encode_with_version, EncodeError, Envelope, Header, CRC, CRC_LEN, MAX_ENCODED_LEN,
    MAX_FRAME_LEN, MAX_PAYLOAD_LEN, PROTOCOL_VERSION,
};
pub use health::{BatteryStatus, FailsafeAction, HealthParams, HealthSample, SurfaceEnd};
pub use ident::{IdentAbort, IdentOutcome};
pub use measured::DvlReport;
pub use messages::*;
pub use motor_test::MotorTest;

#[cfg(test)]
mod tests;
