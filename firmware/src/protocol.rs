//! The tether protocol: message types, framing and a streaming decoder.
//!
//! A frame on the wire is
//!
//! ```text
//! 0x00 ++ COBS( postcard(Envelope { version: u8, seq: u16, msg }) ++ CRC-32/ISO-HDLC(le) ) ++ 0x00
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
//! bytes including its delimiter; both are compile-time constants and every message type is
//! tested to fit. The decoder ([`FrameDecoder`]) drops anything else and counts why
//! ([`DropCounters`]). Every message carries a sequence number so `Ack` / `Nack` (and the
//! lock-step `Telemetry`) can name the command they answer.
//!
//! `docs/protocol.md` has the message table and how the emulated board is driven.

use crate::crc32;
use controller_core::law::paper_xy::PaperXyGains;
use controller_core::law::paper_xz::PaperXzGains;
use controller_core::law::tracking::TrackingGains;
use controller_core::reference::Reference;
use controller_core::state::{BodyForces, NavState, TrackingErrors};
use serde::{de::DeserializeOwned, Deserialize, Serialize};

/// Protocol version. Bump it on any change of a message layout; a frame with another
/// version is dropped (counted as [`DropReason::Version`]) and answered with
/// `Nack { reason: UnsupportedVersion }` when its sequence number can be read.
pub const PROTOCOL_VERSION: u8 = 3;

/// Largest postcard payload (envelope) in bytes, CRC not included.
pub const MAX_PAYLOAD_LEN: usize = 248;
/// Length of the CRC trailer.
pub const CRC_LEN: usize = 4;
/// Largest COBS-encoded frame, without the delimiter.
pub const MAX_ENCODED_LEN: usize = cobs_max_len(MAX_PAYLOAD_LEN + CRC_LEN);
/// Largest frame on the wire, both delimiters included.
pub const MAX_FRAME_LEN: usize = MAX_ENCODED_LEN + 2;

/// Worst-case COBS length of `n` bytes: one overhead byte per started 254-byte block.
pub const fn cobs_max_len(n: usize) -> usize {
    n + n / 254 + 1
}

/// Plane of a tracking mode.
#[cfg_attr(target_os = "none", derive(defmt::Format))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Plane {
    /// Vertical plane (surge and heave; x and depth).
    Xz,
    /// Horizontal plane (surge and yaw; x and y).
    Xy,
    /// 3-D: horizontal plane plus depth.
    ThreeD,
}

/// Which control law tracks.
#[cfg_attr(target_os = "none", derive(defmt::Format))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Law {
    /// The paper's backstepping laws (XZ and XY only).
    Paper,
    /// The tracking laws.
    Tracking,
}

/// Operating mode of the vehicle.
#[cfg_attr(target_os = "none", derive(defmt::Format))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Mode {
    /// No thrust (neutral pulses), armed or not.
    #[default]
    Idle,
    /// Open-loop thrust from [`Command::ManualThrust`].
    Manual,
    /// Follow the reference set by [`Command::SetReference`].
    Track {
        /// Plane.
        plane: Plane,
        /// Law.
        law: Law,
    },
    /// Hold the position of the latest `NavState` when the mode was entered
    /// (3-D tracking law on a fixed point).
    Hold,
}

/// A time-stamped navigation state (the state estimate sent by the topside or the plant).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct NavSample {
    /// Time of the estimate on the sender's clock, microseconds. In lock-step mode this is
    /// the firmware's clock.
    pub t_us: u64,
    /// The state.
    pub state: NavState,
}

/// Open-loop thrust, each component normalized to `[-1, 1]` of what the vehicle can make.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ManualThrust {
    /// Surge force, fraction of the largest surge force.
    pub surge: f32,
    /// Yaw moment, fraction of the largest yaw moment.
    pub yaw: f32,
    /// Heave force, fraction of the largest heave force (positive down).
    pub heave: f32,
}

impl ManualThrust {
    /// True when every component is finite and within `[-1, 1]`.
    pub fn is_valid(&self) -> bool {
        [self.surge, self.yaw, self.heave]
            .iter()
            .all(|v| v.is_finite() && (-1.0..=1.0).contains(v))
    }
}

/// Topside -> ROV messages.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Command {
    /// Keep-alive. `t_us` is the sender's clock (used as the firmware's clock in lock-step).
    Heartbeat {
        /// Sender's time, microseconds.
        t_us: u64,
    },
    /// Arm the thrusters (needs a fresh heartbeat and a fresh `NavState`).
    Arm,
    /// Disarm: neutral pulses at once.
    Disarm,
    /// Change the mode (resets the laws' integrators).
    SetMode(Mode),
    /// Set the reference to track.
    SetReference {
        /// The reference (validated by the core).
        reference: Reference,
        /// Firmware time at which the reference's `t = 0` is, microseconds; `None` = now.
        start_us: Option<u64>,
    },
    /// Replace both paper laws' gains (validated with the rest of the set; unchanged on
    /// error). Version 2: the gains travel as two messages, so that the largest `Command`
    /// (what every move of a decoded command copies) is 80 bytes, not 144.
    SetPaperGains {
        /// Paper XZ law.
        xz: PaperXzGains,
        /// Paper XY law.
        xy: PaperXyGains,
    },
    /// A navigation state. In lock-step mode it runs one control step and is answered by
    /// `Telemetry`.
    Nav(NavSample),
    /// Open-loop thrust for `Mode::Manual`.
    ManualThrust(ManualThrust),
    /// Replace the tracking laws' gains (validated with the rest of the set; unchanged on
    /// error).
    SetTrackingGains(TrackingGains),
}

/// Why a command was refused.
#[cfg_attr(target_os = "none", derive(defmt::Format))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum NackReason {
    /// The frame's protocol version is not [`PROTOCOL_VERSION`].
    UnsupportedVersion,
    /// CRC was right but the payload did not decode as a command.
    Malformed,
    /// A number was NaN or infinite.
    NonFinite,
    /// A number was outside its range.
    OutOfRange,
    /// A value that must be positive was not.
    NotPositive,
    /// A value that must not be negative was.
    Negative,
    /// Parameters that describe no physical vehicle.
    NonPhysical,
    /// Arming refused: no heartbeat within the arming window.
    NoHeartbeat,
    /// Arming or hold refused: no fresh `NavState`.
    NavStale,
    /// A tracking mode without a reference.
    NoReference,
    /// A combination the firmware does not offer (e.g. the paper law in 3-D).
    Unsupported,
}

impl From<controller_core::Error> for NackReason {
    fn from(e: controller_core::Error) -> Self {
        use controller_core::Error as E;
        match e {
            E::NonFinite(_) => NackReason::NonFinite,
            E::NotPositive(_) => NackReason::NotPositive,
            E::Negative(_) => NackReason::Negative,
            E::NonPhysical(_) => NackReason::NonPhysical,
            _ => NackReason::OutOfRange,
        }
    }
}

/// Fault flags in [`Telemetry::faults`] (a bit set).
pub mod fault {
    /// No heartbeat for the neutral timeout: thrust is neutral.
    pub const HEARTBEAT_LOST: u16 = 1 << 0;
    /// No heartbeat for the disarm timeout: the vehicle disarmed itself (sticky until armed).
    pub const LINK_DISARMED: u16 = 1 << 1;
    /// `NavState` too old while tracking or holding: thrust is neutral.
    pub const NAV_STALE: u16 = 1 << 2;
    /// Manual command too old: thrust is neutral.
    pub const MANUAL_STALE: u16 = 1 << 3;
    /// A PWM output reported an error.
    pub const PWM_ERROR: u16 = 1 << 4;
    /// The serial port reported an error.
    pub const SERIAL_ERROR: u16 = 1 << 5;
    /// The allocation saturated at least one thruster in the latest step.
    pub const SATURATED: u16 = 1 << 6;
    /// A control period was missed (fixed-rate mode).
    pub const OVERRUN: u16 = 1 << 7;
}

/// Link statistics, as counted by the firmware.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct LinkStats {
    /// Frames accepted (CRC and decoding good).
    pub rx_frames: u32,
    /// Frames dropped, by reason.
    pub dropped: DropCounters,
    /// Frames sent.
    pub tx_frames: u32,
    /// Nacks sent.
    pub nacks: u32,
}

/// What the ROV reports every control step (lock-step: the answer to each `NavState`) or
/// at the telemetry rate (fixed-rate mode). Version 3 keeps here what changes every step;
/// the link counters and other slow figures are in [`Status`], the answer to each
/// heartbeat.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Telemetry {
    /// Firmware time, microseconds.
    pub t_us: u64,
    /// Mode.
    pub mode: Mode,
    /// Armed.
    pub armed: bool,
    /// Sequence number of the latest `NavState` used (lock-step: the one this answers).
    pub nav_seq: u16,
    /// Tracking errors of the latest control step.
    pub errors: TrackingErrors,
    /// Generalized forces the law (or the manual command) asked for.
    pub requested: BodyForces,
    /// Generalized forces the commanded thrusts make.
    pub achieved: BodyForces,
    /// Thruster forces `[F1x, F2x, F3z]` commanded (zero when neutral).
    pub thrust_n: [f32; 3],
    /// Pulse widths actually written to the three PWM outputs, microseconds (read back from
    /// the duty cycles: what the ESCs see).
    pub pulse_us: [u16; 3],
    /// Fault flags ([`fault`]).
    pub faults: u16,
    /// Duration of the latest control iteration in clock ticks (microseconds on the
    /// STM32F4 board; instructions on the emulated board under `-icount shift=0`).
    pub loop_ticks: u32,
}

/// The slow half of the report: link counters and health, sent as the answer to each
/// accepted `Heartbeat` (so the topside sets its rate, and each one proves a round trip).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Status {
    /// Firmware time, microseconds.
    pub t_us: u64,
    /// Sequence number of the heartbeat this answers.
    pub heartbeat_seq: u16,
    /// Time stamp of the latest accepted `NavState` (0 before the first).
    pub nav_t_us: u64,
    /// Link counters.
    pub link: LinkStats,
    /// Control steps run since boot.
    pub steps: u32,
    /// Largest `Telemetry::loop_ticks` since boot.
    pub loop_ticks_max: u32,
    /// Control periods missed (fixed-rate mode).
    pub overruns: u32,
    /// Fault flags now ([`fault`]).
    pub faults: u16,
}

/// Which board sent a [`Reply::Hello`].
#[cfg_attr(target_os = "none", derive(defmt::Format))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Board {
    /// STM32F405 hardware.
    Stm32f4,
    /// QEMU `netduinoplus2`.
    QemuNetduinoPlus2,
    /// Host-side test double.
    Host,
}

/// ROV -> topside messages.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Reply {
    /// Sent once at boot: the host waits for it before sending (the emulated USART drops
    /// bytes that arrive before it is enabled).
    Hello {
        /// [`PROTOCOL_VERSION`] (also in the envelope).
        protocol: u8,
        /// Which board.
        board: Board,
        /// True when the control step runs on each `NavState` (lock-step).
        lockstep: bool,
        /// Control period (fixed-rate) in microseconds; 0 in lock-step.
        control_period_us: u32,
        /// PWM frequency, hertz.
        pwm_hz: u16,
    },
    /// Telemetry.
    Telemetry(Telemetry),
    /// A command was accepted.
    Ack {
        /// Sequence number of the command.
        seq: u16,
    },
    /// A command was refused; nothing changed.
    Nack {
        /// Sequence number of the command.
        seq: u16,
        /// Why.
        reason: NackReason,
    },
    /// The answer to a `Heartbeat` (version 3).
    Status(Status),
}

/// What every frame carries.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Envelope<M> {
    /// [`PROTOCOL_VERSION`].
    pub version: u8,
    /// Sender's sequence number (wraps).
    pub seq: u16,
    /// The message.
    pub msg: M,
}

/// The first two fields of an [`Envelope`], readable whatever the message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Header {
    /// Version.
    pub version: u8,
    /// Sequence number.
    pub seq: u16,
}

/// Why a frame could not be encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum EncodeError {
    /// The payload is longer than [`MAX_PAYLOAD_LEN`].
    TooLong,
}

impl core::fmt::Display for EncodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            EncodeError::TooLong => write!(f, "payload longer than {MAX_PAYLOAD_LEN} bytes"),
        }
    }
}

impl core::error::Error for EncodeError {}

/// Encode `msg` with sequence number `seq` into `out`; returns the frame (both delimiters
/// included).
pub fn encode<'a, M: Serialize>(
    seq: u16,
    msg: &M,
    out: &'a mut [u8; MAX_FRAME_LEN],
) -> Result<&'a [u8], EncodeError> {
    encode_with_version(PROTOCOL_VERSION, seq, msg, out)
}

/// [`encode`] with another protocol version (for tests of version handling).
///
/// Works in `out` alone, without a scratch buffer: postcard writes the payload at
/// [`PAYLOAD_OFFSET`], the CRC goes right after it, and COBS encodes the body in place into
/// `out[1..]` (`cobs_encode_in_place`'s comment says why that is safe).
pub fn encode_with_version<'a, M: Serialize>(
    version: u8,
    seq: u16,
    msg: &M,
    out: &'a mut [u8; MAX_FRAME_LEN],
) -> Result<&'a [u8], EncodeError> {
    let env = Envelope { version, seq, msg };
    let (_, tail) = out.split_at_mut(PAYLOAD_OFFSET);
    let (payload, _) = tail.split_at_mut(MAX_PAYLOAD_LEN);
    let n = postcard::to_slice(&env, payload)
        .map_err(|_| EncodeError::TooLong)?
        .len();
    Ok(seal(out, n))
}

/// [`encode`] for `Reply::Telemetry(*t)`, the reply of every control step: the same bytes,
/// written by [`crate::wire`]'s hand-written postcard encoder instead of serde (about
/// 1,100 instructions less on the Cortex-M4; tested equal to [`encode`]).
pub fn encode_telemetry<'a>(
    seq: u16,
    t: &Telemetry,
    out: &'a mut [u8; MAX_FRAME_LEN],
) -> Result<&'a [u8], EncodeError> {
    let (_, tail) = out.split_at_mut(PAYLOAD_OFFSET);
    let (payload, _) = tail.split_at_mut(MAX_PAYLOAD_LEN);
    let mut w = crate::wire::Writer::new(payload);
    w.telemetry_envelope(PROTOCOL_VERSION, seq, t);
    let n = w.finish().ok_or(EncodeError::TooLong)?;
    Ok(seal(out, n))
}

/// True when one of the four bytes of `w` is zero (the classic bit trick: a byte's borrow
/// reaches its top bit only if the byte was zero).
#[inline(always)]
fn has_zero_byte(w: u32) -> bool {
    w.wrapping_sub(0x0101_0101) & !w & 0x8080_8080 != 0
}

/// Index of the first zero byte of `bytes`, looked for a word at a time: the lowest byte
/// [`has_zero_byte`]'s mask marks is always a zero byte (a false mark needs a borrow from a
/// zero byte below it).
#[inline(always)]
fn find_zero(bytes: &[u8]) -> Option<usize> {
    let (words, tail) = bytes.as_chunks::<4>();
    for (i, w) in words.iter().enumerate() {
        let w = u32::from_le_bytes(*w);
        let marks = w.wrapping_sub(0x0101_0101) & !w & 0x8080_8080;
        if marks != 0 {
            return Some(4 * i + (marks.trailing_zeros() / 8) as usize);
        }
    }
    let at = 4 * words.len();
    tail.iter().position(|&b| b == 0).map(|k| at + k)
}

/// `0x80` in each byte of `w` that is zero, `0` in the others. Exact, unlike
/// [`has_zero_byte`]'s mask: `(b & 0x7F) + 0x7F` carries into bit 7 (and never out of the
/// byte) unless the low seven bits are zero, and `| b` adds the top bit.
#[inline(always)]
fn zero_bytes(w: u32) -> u32 {
    !(((w & 0x7F7F_7F7F) + 0x7F7F_7F7F) | w | 0x7F7F_7F7F)
}

/// Finish a frame whose `n`-byte postcard payload (`n <= MAX_PAYLOAD_LEN`) is at
/// `out[PAYLOAD_OFFSET..]`: append the CRC, COBS-encode payload and CRC in place into
/// `out[1..]` ([`cobs_encode_in_place`]) and put a delimiter at both ends. Returns the frame.
fn seal(out: &mut [u8; MAX_FRAME_LEN], n: usize) -> &[u8] {
    let body_end = PAYLOAD_OFFSET + n.min(MAX_PAYLOAD_LEN);
    let crc = crc32::checksum(out.get(PAYLOAD_OFFSET..body_end).unwrap_or_default());
    if let Some(d) = out.get_mut(body_end..body_end + CRC_LEN) {
        d.copy_from_slice(&crc.to_le_bytes());
    }
    let len = cobs_encode_in_place(out, body_end + CRC_LEN - PAYLOAD_OFFSET);
    if let Some(d) = out.first_mut() {
        *d = 0;
    }
    if let Some(d) = out.get_mut(len + 1) {
        *d = 0;
    }
    out.get(..len + 2).unwrap_or(&[])
}

/// Where [`encode_with_version`] puts the payload in the frame buffer: one byte for the
/// leading delimiter and room for every COBS code byte a body of up to
/// `MAX_PAYLOAD_LEN + CRC_LEN` bytes can need.
pub const PAYLOAD_OFFSET: usize =
    1 + cobs_max_len(MAX_PAYLOAD_LEN + CRC_LEN) - (MAX_PAYLOAD_LEN + CRC_LEN);
const _: () = assert!(PAYLOAD_OFFSET + MAX_PAYLOAD_LEN + CRC_LEN <= MAX_FRAME_LEN);
const _: () = assert!(PAYLOAD_OFFSET == 2 && MAX_PAYLOAD_LEN + CRC_LEN < 254);

/// COBS-encode the `n` bytes at `buf[PAYLOAD_OFFSET..]` into `buf[1..]` (no delimiter);
/// returns the encoded length, `n + 1` (0 if the body is not in `buf`: never for a frame).
///
/// A body is at most `MAX_PAYLOAD_LEN + CRC_LEN` (< 254) bytes, so it has no 254-byte run of
/// non-zero bytes and COBS needs exactly one code byte more than the body: the one in front
/// (at `buf[1]`) and one in place of each zero byte, whose value is the distance to the next
/// zero byte (or to the end). Every non-zero byte stays where postcard wrote it
/// (`PAYLOAD_OFFSET == 2`), so encoding is one scan for zero bytes and one store per zero.
///
/// The scan runs backwards, so the distance to the next zero is known at each zero and every
/// code byte replaces the zero being looked at: a word at a time, each word's zero bytes
/// found with [`zero_bytes`] (one test for a word without any) and its codes or'ed into it
/// and stored back once. No index is computed from the data: nothing can go out of bounds.
fn cobs_encode_in_place(buf: &mut [u8], n: usize) -> usize {
    let Some((first, body)) = buf
        .get_mut(PAYLOAD_OFFSET - 1..PAYLOAD_OFFSET + n)
        .and_then(|b| b.split_first_mut())
    else {
        return 0;
    };
    // Body index of the zero after the scan point (or the body's end); < 254, so every
    // distance below fits a code byte.
    let mut next = body.len();
    let (words, tail) = body.as_chunks_mut::<4>();
    let tail_at = 4 * words.len();
    for (k, b) in tail.iter_mut().enumerate().rev() {
        if *b == 0 {
            let j = tail_at + k;
            *b = (next - j) as u8;
            next = j;
        }
    }
    for (i, word) in words.iter_mut().enumerate().rev() {
        let w_at = 4 * i;
        let w = u32::from_le_bytes(*word);
        let mut zeros = zero_bytes(w);
        if zeros == 0 {
            continue;
        }
        let mut codes = w;
        if zeros == 0x8080_8080 {
            // Four zero bytes (a 0.0, or zero counters): common in telemetry. The first
            // three point to their neighbours, the last to `next`.
            codes = 0x0001_0101 | ((next - w_at - 3) as u32) << 24;
            next = w_at;
        } else {
            while zeros != 0 {
                // The highest zero byte left: bit 7 of byte `shift / 8`.
                let shift = 24 - (zeros.leading_zeros() & 0x18);
                let j = w_at + (shift / 8) as usize;
                codes |= ((next - j) as u32) << shift;
                next = j;
                zeros &= !(0x80 << shift);
            }
        }
        *word = codes.to_le_bytes();
    }
    // The code byte in front points to the first zero (or to the end).
    *first = (next + 1) as u8;
    n + 1
}

/// COBS-encode `src` into `dst` (no delimiter); returns the length written. `dst` must hold
/// `cobs_max_len(src.len())` bytes; bytes that do not fit are dropped (never the case for
/// the frames built here). The reference the in-place encoder is tested against.
#[cfg(test)]
fn cobs_encode(src: &[u8], dst: &mut [u8]) -> usize {
    let mut code_idx = 0usize;
    let mut out = 1usize;
    let mut code: u8 = 1;
    for &b in src {
        if b == 0 {
            if let Some(c) = dst.get_mut(code_idx) {
                *c = code;
            }
            code_idx = out;
            out += 1;
            code = 1;
        } else {
            if let Some(d) = dst.get_mut(out) {
                *d = b;
            }
            out += 1;
            code += 1;
            if code == 0xFF {
                if let Some(c) = dst.get_mut(code_idx) {
                    *c = code;
                }
                code_idx = out;
                out += 1;
                code = 1;
            }
        }
    }
    if let Some(c) = dst.get_mut(code_idx) {
        *c = code;
    }
    out.min(dst.len())
}

/// Decode COBS in place: returns the range of `buf` that holds the decoded bytes, or `None`
/// if the code chain is not valid (a zero code, a `0xFF` code, or a code that runs past the
/// end) or `buf` is longer than [`MAX_ENCODED_LEN`]. `buf` holds no zero byte (the
/// [`FrameDecoder`] never stores one).
///
/// Only frames shorter than 254 bytes reach it ([`MAX_ENCODED_LEN`]), so no code byte can
/// be `0xFF` (254 data bytes, no zero) in a valid frame: each code byte after the first
/// stands for one zero byte of the data. Decoding is therefore: follow the chain of code
/// bytes, write a zero over each one after the first, and the data is `buf[1..]`. The cost
/// grows with the number of zero bytes, not with the length.
///
/// A `0xFF` code needs no test of its own: it points 255 bytes on, past the end of any
/// `buf` of at most [`MAX_ENCODED_LEN`] bytes, so the chain cannot end exactly at the end.
/// A zero code (only in a `buf` that breaks the rule above) is refused, or the chain would
/// not move.
fn cobs_decode_in_place(buf: &mut [u8]) -> Option<core::ops::Range<usize>> {
    let n = buf.len();
    if n > MAX_ENCODED_LEN {
        return None;
    }
    let first = *buf.first()?;
    // The first code byte stays (it is not part of the data); each one after it becomes a
    // zero. `next < n` is the loop's test, so the index needs no other bounds check.
    let mut next = usize::from(first);
    if first == 0 {
        return None;
    }
    while next < n {
        let code = core::mem::replace(buf.get_mut(next)?, 0);
        if code == 0 {
            return None;
        }
        next += usize::from(code);
    }
    // The last code must end exactly at the end of the frame.
    (next == n).then_some(1..n)
}

const _: () = assert!(MAX_ENCODED_LEN < 255);

/// Why a frame was dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum DropReason {
    /// More than [`MAX_ENCODED_LEN`] bytes before a delimiter.
    Overflow,
    /// Not valid COBS.
    Cobs,
    /// Shorter than a header and a CRC.
    TooShort,
    /// CRC mismatch.
    Crc,
    /// Protocol version differs.
    Version,
    /// CRC good, but the payload is not a valid message.
    Malformed,
}

/// Dropped frames, by reason.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct DropCounters {
    /// [`DropReason::Overflow`].
    pub overflow: u32,
    /// [`DropReason::Cobs`].
    pub cobs: u32,
    /// [`DropReason::TooShort`].
    pub too_short: u32,
    /// [`DropReason::Crc`].
    pub crc: u32,
    /// [`DropReason::Version`].
    pub version: u32,
    /// [`DropReason::Malformed`].
    pub malformed: u32,
}

impl DropCounters {
    /// Count one drop.
    pub fn count(&mut self, r: DropReason) {
        let c = match r {
            DropReason::Overflow => &mut self.overflow,
            DropReason::Cobs => &mut self.cobs,
            DropReason::TooShort => &mut self.too_short,
            DropReason::Crc => &mut self.crc,
            DropReason::Version => &mut self.version,
            DropReason::Malformed => &mut self.malformed,
        };
        *c = c.wrapping_add(1);
    }

    /// All drops.
    pub fn total(&self) -> u32 {
        self.overflow
            .wrapping_add(self.cobs)
            .wrapping_add(self.too_short)
            .wrapping_add(self.crc)
            .wrapping_add(self.version)
            .wrapping_add(self.malformed)
    }
}

/// What the decoder made of a delimiter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Decoded<M> {
    /// A good frame.
    Frame {
        /// Sender's sequence number.
        seq: u16,
        /// The message.
        msg: M,
    },
    /// A dropped frame; `seq` is known when the CRC was good (version or malformed), so
    /// the receiver can `Nack` it.
    Dropped {
        /// Why.
        reason: DropReason,
        /// Sequence number when readable.
        seq: Option<u16>,
    },
}

/// Move `buf[start..end]` to the front of `buf` (`0 < start < end`) in pieces of at most
/// `start` bytes, each a copy between parts that do not overlap: `copy_within` would link
/// `memmove` (1.5 KiB of flash) for this one rare move.
#[inline(never)]
fn move_to_front(buf: &mut [u8], start: usize, end: usize) {
    let mut at = 0;
    while start + at < end {
        let m = (end - start - at).min(start);
        let (head, tail) = buf.split_at_mut((start + at).min(buf.len()));
        let (Some(d), Some(s)) = (head.get_mut(at..at + m), tail.get(..m)) else {
            return;
        };
        if m == 0 {
            return;
        }
        for (x, y) in d.iter_mut().zip(s) {
            *x = *y;
        }
        at += m;
    }
}

/// Size of the [`FrameDecoder`]'s buffer: a frame of [`MAX_ENCODED_LEN`] bytes and one byte
/// more, so that [`FrameDecoder::fill`] always has room for the byte that tells whether a
/// frame of the largest length ends there or runs over.
const RX_BUF_LEN: usize = MAX_ENCODED_LEN + 1;

/// Streaming frame decoder: feed it bytes, it yields messages of type `M` at each delimiter.
///
/// Resynchronizes on the next `0x00` after garbage, an overlong frame or a bad CRC; empty
/// frames (two delimiters in a row) are ignored silently so a sender may start each frame
/// with a delimiter to flush garbage. Never allocates, never panics.
#[derive(Debug, Clone)]
pub struct FrameDecoder<M> {
    /// The frame being gathered is `buf[start..len]` (no delimiter in it); `buf[len..filled]`
    /// were read by [`fill`](Self::fill) and not yet looked at by [`poll`](Self::poll).
    /// `start <= len <= filled <= RX_BUF_LEN`; `push` and `push_slice` keep `start == 0` and
    /// `filled == len`.
    buf: [u8; RX_BUF_LEN],
    start: usize,
    len: usize,
    filled: usize,
    overflowed: bool,
    /// Frames accepted.
    pub frames: u32,
    /// Frames dropped, by reason.
    pub dropped: DropCounters,
    _m: core::marker::PhantomData<M>,
}

impl<M> Default for FrameDecoder<M> {
    fn default() -> Self {
        Self::new()
    }
}

impl<M> FrameDecoder<M> {
    /// An empty decoder.
    pub const fn new() -> Self {
        Self {
            buf: [0; RX_BUF_LEN],
            start: 0,
            len: 0,
            filled: 0,
            overflowed: false,
            frames: 0,
            dropped: DropCounters {
                overflow: 0,
                cobs: 0,
                too_short: 0,
                crc: 0,
                version: 0,
                malformed: 0,
            },
            _m: core::marker::PhantomData,
        }
    }
}

/// A message type the [`FrameDecoder`] decodes: with postcard, or with a hand-written
/// reader for a payload that reader recognizes.
pub trait Message: DeserializeOwned {
    /// The sequence number and the message of a payload (an [`Envelope`] whose first byte,
    /// the version, was checked) when a hand-written reader recognizes it; it must decode exactly as
    /// postcard would. `None` lets postcard decode the payload.
    #[inline(always)]
    fn fast_decode(_payload: &[u8]) -> Option<(u16, Self)> {
        None
    }
}

/// `Command::Nav`, the command of every control step, is read by [`crate::wire`]
/// (about 250 instructions less on the Cortex-M4; tested against postcard).
impl Message for Command {
    #[inline(always)]
    fn fast_decode(payload: &[u8]) -> Option<(u16, Self)> {
        crate::wire::nav_envelope(payload)
    }
}

/// The topside decodes every reply with postcard (so each telemetry frame the firmware
/// writes by hand is checked against postcard's decoder).
impl Message for Reply {}

impl<M: Message> FrameDecoder<M> {
    /// Feed one byte. Returns `Some` at a delimiter that ended a non-empty frame.
    #[cfg_attr(feature = "no-panic", no_panic::no_panic)]
    pub fn push(&mut self, byte: u8) -> Option<Decoded<M>> {
        if self.start != 0 {
            self.compact_cold();
        }
        if byte != 0 {
            match self.buf.get_mut(self.len) {
                Some(slot) if !self.overflowed && self.len < MAX_ENCODED_LEN => {
                    *slot = byte;
                    self.len += 1;
                    self.filled = self.len;
                }
                _ => self.overflowed = true,
            }
            return None;
        }
        self.end_of_frame()
    }

    /// Feed bytes up to and including the first delimiter in `bytes` and advance `bytes`
    /// past them; returns what [`push`](Self::push) would have returned for the last of
    /// them. Call it again while `bytes` is not empty. Same results as pushing the bytes
    /// one by one, at a fraction of the cost (one scan for the delimiter and one copy).
    #[cfg_attr(feature = "no-panic", no_panic::no_panic)]
    pub fn push_slice(&mut self, bytes: &mut &[u8]) -> Option<Decoded<M>> {
        if self.start != 0 {
            self.compact_cold();
        }
        let all: &[u8] = bytes;
        let mut copied = 0usize;
        let mut delimiter = None;
        if !self.overflowed {
            // Copy up to the first zero in one pass (scan and copy fused): four bytes at a
            // time while they hold no zero, then byte by byte.
            let room = self
                .buf
                .get_mut(self.len..MAX_ENCODED_LEN)
                .unwrap_or_default();
            for (d, s) in room.chunks_exact_mut(4).zip(all.chunks_exact(4)) {
                let Ok(w) = <[u8; 4]>::try_from(s) else {
                    break;
                };
                if has_zero_byte(u32::from_le_bytes(w)) {
                    break;
                }
                d.copy_from_slice(&w);
                copied += 4;
            }
            let room = room.get_mut(copied..).unwrap_or_default();
            for (slot, &b) in room.iter_mut().zip(all.get(copied..).unwrap_or_default()) {
                if b == 0 {
                    delimiter = Some(copied);
                    break;
                }
                *slot = b;
                copied += 1;
            }
            self.len += copied;
            self.filled = self.len;
            if delimiter.is_none() {
                match all.get(copied) {
                    // The buffer is full and the frame ends right here.
                    Some(0) => delimiter = Some(copied),
                    // The buffer is full and the frame goes on.
                    Some(_) => self.overflowed = true,
                    None => {}
                }
            }
        }
        if delimiter.is_none() && self.overflowed {
            delimiter = all
                .get(copied..)
                .and_then(|rest| rest.iter().position(|&b| b == 0))
                .map(|k| copied + k);
        }
        match delimiter {
            Some(i) => {
                *bytes = all.get(i + 1..).unwrap_or_default();
                self.end_of_frame()
            }
            None => {
                *bytes = &[];
                None
            }
        }
    }

    /// Read bytes straight into the decoder's buffer: `read` gets the free part of it (at
    /// most `max` bytes, never empty when `max > 0`) and returns how many bytes it wrote at
    /// its start (a larger count is taken as the length of the part it got). Returns that
    /// count, or `read`'s error (nothing taken). Then call [`poll`](Self::poll) while
    /// [`has_unscanned`](Self::has_unscanned): the same frames, drops and counts as
    /// [`push`](Self::push) with each byte, without a copy of the bytes (only the start of
    /// a frame a read left unfinished moves to the front of the buffer, at the next `fill`).
    pub fn fill<E>(
        &mut self,
        max: usize,
        read: impl FnOnce(&mut [u8]) -> Result<usize, E>,
    ) -> Result<usize, E> {
        let spare = self.spare(max);
        let room = spare.len();
        let n = read(spare)?.min(room);
        self.filled += n;
        Ok(n)
    }

    /// The free part of the buffer for [`fill`](Self::fill), at most `max` bytes (the frame
    /// being gathered moved to the front first).
    #[cfg_attr(feature = "no-panic", no_panic::no_panic)]
    #[inline(always)]
    fn spare(&mut self, max: usize) -> &mut [u8] {
        self.compact();
        let spare = self.buf.get_mut(self.filled..).unwrap_or_default();
        let room = spare.len().min(max);
        spare.get_mut(..room).unwrap_or_default()
    }

    /// True while bytes taken by [`fill`](Self::fill) wait for [`poll`](Self::poll).
    #[inline]
    pub fn has_unscanned(&self) -> bool {
        self.filled > self.len
    }

    /// Look at the bytes [`fill`](Self::fill) took, up to the first delimiter that ends a
    /// non-empty (or over-long) frame; returns what [`push`](Self::push) returned for that
    /// delimiter, or `None` when the bytes ran out first (call again while
    /// [`has_unscanned`](Self::has_unscanned)). The scan reads a word at a time.
    #[cfg_attr(feature = "no-panic", no_panic::no_panic)]
    pub fn poll(&mut self) -> Option<Decoded<M>> {
        loop {
            let new = self.buf.get(self.len..self.filled).unwrap_or_default();
            let Some(k) = find_zero(new) else {
                // No delimiter: the bytes join the frame being gathered.
                self.len = self.filled;
                if self.overflowed || self.len.wrapping_sub(self.start) > MAX_ENCODED_LEN {
                    // Over-long: its bytes are of no use, only the flag is kept (the frame
                    // is dropped at its delimiter, like `push` does).
                    self.overflowed = true;
                    self.start = 0;
                    self.len = 0;
                    self.filled = 0;
                }
                return None;
            };
            let start = self.start;
            let end = self.len + k;
            self.start = end + 1;
            self.len = end + 1;
            if end != start || self.overflowed {
                return self.decode(start, end);
            }
            // An empty frame (two delimiters in a row): `push` returns `None` for it.
            if self.len >= self.filled {
                return None;
            }
        }
    }

    /// [`compact`](Self::compact) out of line, for `push` and `push_slice` (only after
    /// [`fill`](Self::fill) and [`poll`](Self::poll) is there anything to move).
    #[cold]
    #[inline(never)]
    fn compact_cold(&mut self) {
        self.compact();
    }

    /// Move the frame being gathered (and any unscanned bytes) to the front of the buffer.
    #[inline(always)]
    fn compact(&mut self) {
        let (start, len, filled) = (self.start, self.len, self.filled);
        self.start = 0;
        if start <= len && len <= filled && filled <= RX_BUF_LEN {
            if start != 0 && start < filled {
                move_to_front(&mut self.buf, start, filled);
            }
            self.len = len - start;
            self.filled = filled - start;
        } else {
            self.len = 0;
            self.filled = 0;
        }
    }

    /// A delimiter arrived: check and decode the bytes gathered since the last one.
    fn end_of_frame(&mut self) -> Option<Decoded<M>> {
        let start = core::mem::replace(&mut self.start, 0);
        let end = core::mem::replace(&mut self.len, 0);
        self.filled = 0;
        self.decode(start, end)
    }

    /// Check and decode the frame `buf[start..end]` (its delimiter arrived).
    fn decode(&mut self, start: usize, end: usize) -> Option<Decoded<M>> {
        if core::mem::replace(&mut self.overflowed, false) {
            return Some(self.drop_frame(DropReason::Overflow, None));
        }
        if end == start {
            return None;
        }
        let Some(frame) = self.buf.get_mut(start..end) else {
            return Some(self.drop_frame(DropReason::Overflow, None));
        };
        let Some(data) = cobs_decode_in_place(frame) else {
            return Some(self.drop_frame(DropReason::Cobs, None));
        };
        let Some(data) = frame.get(data) else {
            return Some(self.drop_frame(DropReason::Cobs, None));
        };
        // Header (>= 2 bytes) + CRC.
        if data.len() < 2 + CRC_LEN {
            return Some(self.drop_frame(DropReason::TooShort, None));
        }
        let Some((payload, crc_bytes)) = data.split_last_chunk::<CRC_LEN>() else {
            return Some(self.drop_frame(DropReason::TooShort, None));
        };
        let crc = *crc_bytes;
        if crc32::checksum(payload) != u32::from_le_bytes(crc) {
            return Some(self.drop_frame(DropReason::Crc, None));
        }
        // The version is the payload's first byte (a raw `u8`): a frame of this version that
        // the hand-written reader recognizes needs no other parse.
        if payload.first() == Some(&PROTOCOL_VERSION) {
            if let Some((seq, msg)) = M::fast_decode(payload) {
                self.frames = self.frames.wrapping_add(1);
                return Some(Decoded::Frame { seq, msg });
            }
        }
        let header = postcard::take_from_bytes::<Header>(payload)
            .ok()
            .map(|(h, _)| h);
        let Some(header) = header else {
            return Some(self.drop_frame(DropReason::Malformed, None));
        };
        if header.version != PROTOCOL_VERSION {
            return Some(self.drop_frame(DropReason::Version, Some(header.seq)));
        }
        match postcard::from_bytes::<Envelope<M>>(payload) {
            Ok(env) => {
                self.frames = self.frames.wrapping_add(1);
                Some(Decoded::Frame {
                    seq: env.seq,
                    msg: env.msg,
                })
            }
            Err(_) => Some(self.drop_frame(DropReason::Malformed, Some(header.seq))),
        }
    }

    fn drop_frame(&mut self, reason: DropReason, seq: Option<u16>) -> Decoded<M> {
        self.dropped.count(reason);
        Decoded::Dropped { reason, seq }
    }
}

/// Decode one complete frame (with or without its trailing delimiter) in one call.
pub fn decode_frame<M: Message>(frame: &[u8]) -> Option<Decoded<M>> {
    let mut d = FrameDecoder::<M>::new();
    let mut last = None;
    for &b in frame.iter().chain(core::iter::once(&0u8)) {
        if let Some(x) = d.push(b) {
            last = Some(x);
            break;
        }
    }
    last
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cobs_round_trip_edge_cases() {
        // Every length a frame can have (the decoder refuses longer ones as overflow).
        for len in (0usize..=MAX_ENCODED_LEN - 1).chain([253, 254, 255, 300]) {
            for fill in [0u8, 1, 0xFF] {
                let src: [u8; 300] =
                    core::array::from_fn(|i| if i % 7 == 0 { fill } else { i as u8 | 1 });
                let src = &src[..len];
                let mut dst = [0u8; 400];
                let n = cobs_encode(src, &mut dst);
                assert!(n <= cobs_max_len(len));
                assert!(!dst[..n].contains(&0));
                let mut buf = dst[..n].to_vec();
                match cobs_decode_in_place(&mut buf) {
                    Some(r) => assert_eq!(&buf[r], src, "len {len}"),
                    // Only a frame over MAX_ENCODED_LEN can hold a 0xFF code: refused.
                    None => assert!(n > MAX_ENCODED_LEN, "len {len}"),
                }
            }
        }
        // Broken chains.
        for bad in [&[0u8][..], &[3, 1], &[2, 1, 5], &[0xFF, 1, 1], &[1, 0]] {
            assert_eq!(cobs_decode_in_place(&mut bad.to_vec()), None, "{bad:?}");
        }
    }

    #[test]
    fn in_place_cobs_equals_the_reference_encoder() {
        let mut seed = 0x1234_5678u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 24) as u8
        };
        for n in 0..=MAX_PAYLOAD_LEN + CRC_LEN {
            for zeros in [0u8, 1, 8, 255] {
                let body: Vec<u8> = (0..n)
                    .map(|_| {
                        let b = next();
                        if b < zeros {
                            0
                        } else {
                            b
                        }
                    })
                    .collect();
                let mut want = [0u8; 400];
                let m = cobs_encode(&body, &mut want);
                let mut buf = [0xAAu8; MAX_FRAME_LEN];
                buf[PAYLOAD_OFFSET..PAYLOAD_OFFSET + n].copy_from_slice(&body);
                let got = cobs_encode_in_place(&mut buf, n);
                assert_eq!(got, m, "n {n}");
                assert_eq!(&buf[1..1 + got], &want[..m], "n {n}");
            }
        }
    }

    #[test]
    fn seal_equals_crc_then_reference_cobs() {
        // `seal` scans words and shortcuts all-zero words: compare it with the byte-wise
        // reference on payloads of every length and zero density (runs of zeros included).
        let mut seed = 0x0BAD_5EEDu32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 24) as u8
        };
        for n in 0..=MAX_PAYLOAD_LEN {
            for zeros in [0u8, 8, 128, 240, 255] {
                let body: Vec<u8> = (0..n)
                    .map(|_| if next() < zeros { 0 } else { next() | 1 })
                    .collect();
                let mut with_crc = body.clone();
                with_crc.extend_from_slice(&crc32::checksum(&body).to_le_bytes());
                let mut want = [0u8; 400];
                let m = cobs_encode(&with_crc, &mut want);
                let mut out = [0xAAu8; MAX_FRAME_LEN];
                out[PAYLOAD_OFFSET..PAYLOAD_OFFSET + n].copy_from_slice(&body);
                let frame = seal(&mut out, n);
                assert_eq!(frame.len(), m + 2, "n {n}");
                assert_eq!((frame[0], frame[m + 1]), (0, 0), "n {n}");
                assert_eq!(&frame[1..=m], &want[..m], "n {n} zeros {zeros}");
            }
        }
    }

    #[test]
    fn largest_payload_frames_round_trip() {
        // A payload of exactly MAX_PAYLOAD_LEN bytes puts the CRC past the payload area.
        // Arrays are postcard tuples (no length prefix): 7 x 32 + 22 = 246 bytes.
        #[derive(Serialize, Deserialize, Debug, PartialEq)]
        struct Blob([[u8; 32]; 7], [u8; 22]);
        impl Message for Blob {}
        for fill in [0u8, 7, 0xFF] {
            let blob = Blob([[fill; 32]; 7], [fill; 22]);
            let mut out = [0u8; MAX_FRAME_LEN];
            let f = encode(0x7F, &blob, &mut out).unwrap().to_vec();
            // version 1 B + seq 1 B + 246 B = MAX_PAYLOAD_LEN.
            let mut p = [0u8; 300];
            let env = Envelope {
                version: PROTOCOL_VERSION,
                seq: 0x7F_u16,
                msg: &blob,
            };
            assert_eq!(
                postcard::to_slice(&env, &mut p).unwrap().len(),
                MAX_PAYLOAD_LEN
            );
            assert!(f.len() <= MAX_FRAME_LEN);
            assert!(!f[1..f.len() - 1].contains(&0));
            match decode_frame::<Blob>(&f) {
                Some(Decoded::Frame { seq: 0x7F, msg }) => assert_eq!(msg, blob),
                other => panic!("{other:?}"),
            }
        }
        // One byte more does not fit and is refused.
        let big = [1u8; MAX_PAYLOAD_LEN];
        let mut out = [0u8; MAX_FRAME_LEN];
        assert!(encode(0, &big.as_slice(), &mut out).is_err());
    }

    #[test]
    fn push_slice_equals_push() {
        let mut frames = Vec::new();
        for (i, cmd) in [
            Command::Arm,
            Command::Disarm,
            Command::Heartbeat { t_us: 1 << 40 },
        ]
        .iter()
        .enumerate()
        {
            let mut out = [0u8; MAX_FRAME_LEN];
            frames.extend_from_slice(encode(i as u16, cmd, &mut out).unwrap());
            frames.extend_from_slice(&[5, 6, 0, 0]); // garbage, an empty frame
        }
        frames.extend_from_slice(&[9; 300]); // overflow
        frames.push(0);
        let mut one = FrameDecoder::<Command>::new();
        let want: Vec<_> = frames.iter().filter_map(|&b| one.push(b)).collect();
        for chunk in [1usize, 3, 64, 1000] {
            let mut d = FrameDecoder::<Command>::new();
            let mut got = Vec::new();
            for c in frames.chunks(chunk) {
                let mut rest = c;
                while !rest.is_empty() {
                    let before = rest.len();
                    let x = d.push_slice(&mut rest);
                    assert!(rest.len() < before);
                    got.extend(x);
                }
            }
            assert_eq!(got, want, "chunk {chunk}");
            assert_eq!(d.dropped, one.dropped);
            assert_eq!(d.frames, one.frames);
        }
        assert_eq!(one.frames, 3);
        assert!(one.dropped.overflow == 1 && one.dropped.total() >= 4);
    }

    /// A byte stream for the decoder tests: valid frames, garbage (zeros included), runs of
    /// non-zero bytes around the longest frame (one byte shorter, exact, one and more
    /// bytes over), valid frames of the largest length, and runs of delimiters.
    fn stream_strategy() -> impl proptest::strategy::Strategy<Value = Vec<u8>> {
        use proptest::prelude::*;
        #[derive(Serialize, Deserialize)]
        struct Blob([[u8; 32]; 7], [u8; 22]);
        let seg = prop_oneof![
            (any::<u16>(), any::<u64>(), 0u8..4).prop_map(|(seq, t, k)| {
                let cmd = match k {
                    0 => Command::Arm,
                    1 => Command::Heartbeat { t_us: t },
                    2 => Command::Nav(NavSample {
                        t_us: t,
                        state: NavState {
                            x_m: t as f32,
                            ..NavState::default()
                        },
                    }),
                    _ => Command::SetMode(Mode::Manual),
                };
                let mut out = [0u8; MAX_FRAME_LEN];
                encode(seq, &cmd, &mut out).unwrap().to_vec()
            }),
            proptest::collection::vec(prop_oneof![Just(0u8), any::<u8>()], 0..40),
            (
                MAX_ENCODED_LEN - 2..=MAX_ENCODED_LEN + 2,
                1u8..=255,
                any::<bool>()
            )
                .prop_map(|(n, fill, end)| {
                    let mut v = vec![fill; n];
                    if end {
                        v.push(0);
                    }
                    v
                }),
            (0usize..600, 1u8..=255).prop_map(|(n, fill)| vec![fill; n]),
            (any::<u16>(), 1u8..=255).prop_map(|(seq, fill)| {
                let blob = Blob([[fill; 32]; 7], [fill; 22]);
                let mut out = [0u8; MAX_FRAME_LEN];
                encode(seq & 0x7F, &blob, &mut out).unwrap().to_vec()
            }),
            (1usize..4).prop_map(|n| vec![0u8; n]),
        ];
        proptest::collection::vec(seg, 0..16).prop_map(|v| v.concat())
    }

    /// What `push` returns for each byte of `bytes` (the `Some`s), and the decoder after.
    fn by_push(bytes: &[u8]) -> (Vec<Decoded<Command>>, FrameDecoder<Command>) {
        let mut d = FrameDecoder::<Command>::new();
        let got = bytes.iter().filter_map(|&b| d.push(b)).collect();
        (got, d)
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(2000))]

        /// `fill` + `poll` (the firmware loop's path: reads straight into the decoder's
        /// buffer) decode exactly what `push` decodes byte by byte, for any stream cut into
        /// reads of any size (a read may return fewer bytes than it was given room for), with
        /// `push` and `push_slice` used now and then between reads on the same decoder.
        #[test]
        fn fill_and_poll_equal_push(
            bytes in stream_strategy(),
            sizes in proptest::collection::vec((1usize..300, 0usize..300, 0u8..8), 1..20),
        ) {
            let (want, one) = by_push(&bytes);
            let mut d = FrameDecoder::<Command>::new();
            let mut got = Vec::new();
            let mut rest = bytes.as_slice();
            let mut k = 0;
            while !rest.is_empty() {
                let (max, short, how) = sizes[k % sizes.len()];
                k += 1;
                match how {
                    // A byte or a slice through the other entry points.
                    0 => {
                        got.extend(d.push(rest[0]));
                        rest = &rest[1..];
                    }
                    1 => {
                        let mut s = &rest[..max.min(rest.len())];
                        rest = &rest[s.len()..];
                        while !s.is_empty() {
                            got.extend(d.push_slice(&mut s));
                        }
                    }
                    _ => {
                        let n = d
                            .fill(max, |buf| {
                                proptest::prop_assert!(!buf.is_empty() && buf.len() <= max);
                                // Sometimes fewer bytes than there is room for.
                                let n = buf.len().min(rest.len()).min(short.max(1));
                                buf[..n].copy_from_slice(&rest[..n]);
                                Ok(n)
                            })?;
                        rest = &rest[n..];
                        while d.has_unscanned() {
                            got.extend(d.poll());
                        }
                    }
                }
            }
            proptest::prop_assert_eq!(&got, &want);
            proptest::prop_assert_eq!(d.frames, one.frames);
            proptest::prop_assert_eq!(d.dropped, one.dropped);
            // And the state after: the next frame decodes the same way on both.
            let mut out = [0u8; MAX_FRAME_LEN];
            let f = encode(9, &Command::Disarm, &mut out).unwrap();
            let (mut a, mut b) = (d, one);
            let x: Vec<_> = f.iter().filter_map(|&c| a.push(c)).collect();
            let y: Vec<_> = f.iter().filter_map(|&c| b.push(c)).collect();
            proptest::prop_assert_eq!(x, y);
        }
    }

    #[test]
    fn fill_handles_errors_and_bad_counts() {
        let mut d = FrameDecoder::<Command>::new();
        // An error takes nothing.
        assert_eq!(d.fill(10, |_| Err::<usize, ()>(())), Err(()));
        assert!(!d.has_unscanned());
        // A count larger than the room is taken as the room.
        assert_eq!(d.fill(4, |buf| Ok::<_, ()>(buf.len() + 100)), Ok(4));
        assert!(d.has_unscanned());
        while d.has_unscanned() {
            let _ = d.poll();
        }
        // `max == 0`: an empty buffer, nothing taken.
        assert_eq!(d.fill(0, |buf| Ok::<_, ()>(buf.len())), Ok(0));
        // Never an empty buffer when `max > 0`, whatever came before: a frame of the
        // largest length, then one byte over it.
        for _ in 0..3 {
            let n = d.fill(MAX_ENCODED_LEN, |buf| {
                assert!(!buf.is_empty());
                buf.fill(7);
                Ok::<_, ()>(buf.len())
            });
            assert!(n.unwrap() > 0);
            while d.has_unscanned() {
                assert_eq!(d.poll(), None);
            }
        }
        let _ = d.fill(1, |buf| {
            buf[0] = 0;
            Ok::<_, ()>(1)
        });
        assert_eq!(
            d.poll(),
            Some(Decoded::Dropped {
                reason: DropReason::Overflow,
                seq: None
            })
        );
        assert_eq!(d.dropped.overflow, 1);
    }

    /// With the `no-panic` feature (release builds: `cargo test -p firmware --release
    /// --features no-panic --lib`), linking this proves that the loop's receive path cannot
    /// panic: `poll` for `Command` and the decoder's part of `fill` (`spare`; `read` is the
    /// caller's).
    #[cfg(feature = "no-panic")]
    #[test]
    fn fill_and_poll_link_without_panics() {
        let mut d = FrameDecoder::<Command>::new();
        let bytes = std::hint::black_box([0u8, 3, 1, 2, 0, 9, 9, 9, 0]);
        let mut rest = &bytes[..];
        while !rest.is_empty() {
            // A panic-free `read` (the check covers what is inlined into `fill`).
            let n = d.fill(std::hint::black_box(4), |buf| {
                let mut n = 0;
                for (b, x) in buf.iter_mut().zip(rest) {
                    *b = *x;
                    n += 1;
                }
                Ok::<_, ()>(n)
            });
            rest = &rest[n.unwrap()..];
            while d.has_unscanned() {
                assert!(!matches!(d.poll(), Some(Decoded::Frame { .. })));
            }
        }
    }

    #[test]
    fn round_trip_and_sizes() {
        let mut out = [0u8; MAX_FRAME_LEN];
        let f = encode(7, &Command::Arm, &mut out).unwrap().to_vec();
        assert_eq!(*f.last().unwrap(), 0);
        assert_eq!(f[0], 0);
        match decode_frame::<Command>(&f) {
            Some(Decoded::Frame { seq: 7, msg }) => assert_eq!(msg, Command::Arm),
            other => panic!("{other:?}"),
        }
        const _: () = assert!(MAX_FRAME_LEN <= 256);
    }
}
