//! The node link: the wire between the topside MCU, which runs the control loop
//! at the surface (the paper's layout: the Observer's 150 m cable "enables communication
//! between the vehicle sensors and the surface equipment"), and the vehicle's thin node,
//! which reads the IMU and the pressure sensor and drives the three ESCs.
//!
//! Frames are the tether's: postcard + CRC-32 + COBS between zero delimiters, written by the
//! tether's own [`crate::protocol::encode_with_version`] (one call, in [`seal`]) with the
//! node link's version [`NODE_LINK_VERSION`]. The message set is its own and small:
//!
//! - [`Downlink`] (topside -> node, every link period): the topside's session, the frame's
//!   sequence, the three pulse widths (us), a time to live and the arm command;
//! - [`Uplink`] (node -> topside, every link period): the session the node serves, the
//!   low bits of the sequence of the latest downlink it applied, the IMU
//!   increments integrated over the period (delta angle, delta velocity, their dt), the latest
//!   pressure, the node's status and counters, and the DVL's velocity admitted since the last
//!   uplink ([`UplinkDvl`]: parsed and gated on the node).
//!
//! Sequences: a downlink carries the topside's sequence as a `u64` that counts up from 1 and
//! never wraps (at 200 frames a second it would take 2.9e9 years), and the node applies only a
//! frame whose sequence is above the last one it applied ([`seq_after`]), also across its
//! silence latch for the session it served: a downlink replayed at any distance, one frame or
//! a billion later, is refused. Its envelope's `u16` sequence carries the low 16 bits, for the
//! tether's tools; no check reads it. An uplink keeps the envelope's `u16` sequence, checked
//! by the topside with [`seq_newer`] (a half range ahead): the uplink's size is at its bound
//! for a 57 Hz link at 115,200 Bd, and a replayed uplink commands no thrust (`docs/safety.md`,
//! the node link's rows).
//!
//! Sizes: every message is tested to encode within [`MAX_DOWNLINK_FRAME_LEN`] /
//! [`MAX_UPLINK_FRAME_LEN`] bytes (largest field values), and the wire time of both at
//! [`LINK_BAUD`] at most half of the [`LINK_PERIOD_US`] (`docs/deployment.md`).

mod decoder;
mod dvl;
mod wire;

pub use decoder::{LinkDecoder, LinkFrame};
pub use dvl::{UplinkDvl, MAX_UPLINK_DVL_AGE_MS, MAX_UPLINK_DVL_STD_M_S};
pub use wire::{
    MAX_DOWNLINK_FRAME_LEN, MAX_LINK_FRAME_LEN, MAX_UPLINK_FRAME_LEN, NODE_LINK_VERSION,
};

use crate::protocol::{EncodeError, MAX_FRAME_LEN};
use serde::{Deserialize, Serialize};

/// The link's default rate on the wire, 8N1 (10 bits a byte).
pub const LINK_BAUD: u32 = 115_200;
/// Bits on the wire per byte (start, 8 data, stop).
pub const BITS_PER_BYTE: u32 = 10;
/// One downlink and one uplink frame per period: 50 Hz, the control rate.
pub const LINK_PERIOD_US: u32 = 20_000;

/// The ESC's neutral pulse width (no thrust), microseconds.
pub const ESC_NEUTRAL_US: u16 = 1500;
/// The ESC's shortest pulse (full reverse), microseconds.
pub const ESC_MIN_US: u16 = 1100;
/// The ESC's longest pulse (full forward), microseconds.
pub const ESC_MAX_US: u16 = 1900;
/// The longest time to live a downlink may ask for, milliseconds.
pub const MAX_TTL_MS: u8 = 100;

/// Wire time of `bytes` at `baud` (8N1), microseconds, rounded up.
pub const fn wire_time_us(bytes: usize, baud: u32) -> u32 {
    let bits = bytes as u64 * BITS_PER_BYTE as u64 * 1_000_000;
    let baud = if baud == 0 { 1 } else { baud as u64 };
    bits.div_ceil(baud) as u32
}

/// The link periods a layout picks from by default, shortest first (200, 100, 50 Hz).
pub const DEFAULT_LINK_PERIODS_US: [u32; 3] = [5_000, 10_000, LINK_PERIOD_US];

/// Share of a link period the larger frame (the uplink, at its bound) keeps one direction
/// busy at `baud`, in per mille, rounded up.
pub const fn busy_per_mille(link_period_us: u32, baud: u32) -> u32 {
    let up_us = wire_time_us(MAX_UPLINK_FRAME_LEN, baud) as u64;
    let period = if link_period_us == 0 {
        1
    } else {
        link_period_us as u64
    };
    let pm = (up_us * 1_000).div_ceil(period);
    if pm > u32::MAX as u64 {
        u32::MAX
    } else {
        pm as u32
    }
}

/// The default link period at `baud`: the shortest of [`DEFAULT_LINK_PERIODS_US`] that keeps
/// each direction at most half busy; [`LINK_PERIOD_US`] when none does (115,200 Bd: 20 ms,
/// the images' period; 1 Mbd: 5 ms). A shorter period makes the increments younger (their
/// oldest sample is one period older than their newest).
pub const fn default_link_period_us(baud: u32) -> u32 {
    let [fast, mid, slow] = DEFAULT_LINK_PERIODS_US;
    if busy_per_mille(fast, baud) <= 500 {
        fast
    } else if busy_per_mille(mid, baud) <= 500 {
        mid
    } else {
        slow
    }
}

/// Why a link period was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum LinkPeriodError {
    /// Shorter than the IMU period: an uplink would carry no new sample.
    BelowImuPeriod,
    /// The uplink would keep its direction more than half busy at this rate.
    OverHalfBusy,
    /// Longer than [`LINK_PERIOD_US`]: below the 50 Hz the control needs.
    Below50Hz,
}

impl core::fmt::Display for LinkPeriodError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            LinkPeriodError::BelowImuPeriod => "shorter than the node's IMU period",
            LinkPeriodError::OverHalfBusy => {
                "the uplink would keep the link more than 50 % busy at this rate"
            }
            LinkPeriodError::Below50Hz => "longer than 20 ms (below 50 Hz)",
        })
    }
}

impl core::error::Error for LinkPeriodError {}

/// Check a link period against the node's IMU period and the link's rate.
pub fn check_link_period(
    link_period_us: u32,
    imu_period_us: u32,
    baud: u32,
) -> Result<(), LinkPeriodError> {
    if link_period_us < imu_period_us.max(1) {
        Err(LinkPeriodError::BelowImuPeriod)
    } else if link_period_us > LINK_PERIOD_US {
        Err(LinkPeriodError::Below50Hz)
    } else if busy_per_mille(link_period_us, baud) > 500 {
        Err(LinkPeriodError::OverHalfBusy)
    } else {
        Ok(())
    }
}

/// What the topside asks of the node's thrusters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum ArmCommand {
    /// Outputs at neutral whatever the pulses say.
    Disarmed,
    /// Apply the pulses. After a boot or a latched disarm the node arms only on a
    /// `Disarmed` -> `Armed` transition seen in two valid frames.
    Armed,
}

/// Topside -> node, once a link period.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Downlink {
    /// The topside's session, chosen at its boot, never 0. The node serves one session at
    /// a time; a frame of another is refused (crossed wires, or a second topside).
    pub session: u32,
    /// The frame's sequence in the session: 1 for the first, one more for each next, never
    /// wrapping. The node applies only a frame above the last one it applied.
    pub seq: u64,
    /// Pulse widths of `F1x`, `F2x`, `F3z`, microseconds, [`ESC_MIN_US`]..=[`ESC_MAX_US`].
    pub pulse_us: [u16; 3],
    /// How long the pulses hold, from the frame's arrival, milliseconds: 1..=[`MAX_TTL_MS`].
    pub ttl_ms: u8,
    /// Arm command.
    pub arm: ArmCommand,
    /// The topside's clock when it sent the frame, microseconds (its low 32 bits, wrapping):
    /// echoed in [`Uplink::echo_t_us`], it gives the round trip without a table of send
    /// times, however long the tether's latency.
    pub t_us: u32,
}

/// Status bits of the node ([`Uplink::status`]).
pub mod status {
    /// The outputs follow the topside's pulses (armed).
    pub const ARMED: u8 = 1 << 0;
    /// Disarmed and waiting for an explicit arm transition (at boot, and after 1 s without
    /// a valid frame).
    pub const LATCHED: u8 = 1 << 1;
    /// The latest command outlived its time to live: outputs at neutral.
    pub const TTL_NEUTRAL: u8 = 1 << 2;
    /// The IMU gave no sample in the period (the increments are empty).
    pub const IMU_LOST: u8 = 1 << 3;
    /// The pressure sensor gave no reading for 0.5 s.
    pub const PRESSURE_LOST: u8 = 1 << 4;
    /// A PWM output reported an error.
    pub const PWM_ERROR: u8 = 1 << 5;
}

/// The node's counters of refused downlink frames, and of its own troubles (wrapping).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct NodeCounters {
    /// Downlink frames applied.
    pub accepted: u16,
    /// Frames dropped by the framing: COBS, CRC, too short, too long, not a `Downlink`.
    pub corrupt: u16,
    /// Frames whose sequence is not above the last applied one (a replay, at any distance).
    pub replayed: u16,
    /// Frames with a pulse outside the ESC's range or a time to live outside 1..=100 ms.
    pub out_of_range: u16,
    /// Frames of another topside's session.
    pub foreign: u16,
    /// Frames of another link version.
    pub version: u16,
    /// Commands that outlived their time to live (each counted once).
    pub ttl_expired: u16,
    /// IMU reads that failed.
    pub imu_errors: u16,
    /// DVL lines and reports the node refused (bad checksum, malformed, no bottom lock, a
    /// poor figure of merit, over-long; wrapping at 256: the topside sums the differences,
    /// at most a few a link period).
    pub dvl_refused: u8,
}

/// Node -> topside, once a link period.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Uplink {
    /// The session the node serves (0: none yet).
    pub session: u32,
    /// Low 16 bits of the sequence of the latest downlink applied (0: none).
    pub echo_seq: u16,
    /// That downlink's [`Downlink::t_us`] plus the time the node held it, from its arrival
    /// to this uplink's sending (wrapping): the topside's clock now minus this is the round
    /// trip, the node's own time left out. 0 before any downlink was applied.
    pub echo_t_us: u32,
    /// Age of the newest IMU sample of the increments when this uplink was sent,
    /// microseconds: with the round trip, the topside places the sample on its own clock.
    pub imu_age_us: u32,
    /// Time the increments cover, microseconds (first to last sample of the period).
    pub dt_us: u32,
    /// IMU intervals integrated (consecutive samples at most four IMU periods apart).
    pub samples: u16,
    /// Integrated angular rate, body axes, rad.
    pub delta_angle_rad: [f32; 3],
    /// Integrated specific force, body axes, m/s.
    pub delta_velocity_m_s: [f32; 3],
    /// Latest absolute pressure, Pa.
    pub pressure_pa: f32,
    /// Count of pressure readings (wraps): a new value when it changes.
    pub pressure_count: u8,
    /// [`status`] bits.
    pub status: u8,
    /// Counters.
    pub counters: NodeCounters,
    /// The newest DVL velocity the node admitted since the previous uplink (`None`: none).
    pub dvl: Option<UplinkDvl>,
}

/// Encode `msg` as a node-link frame with envelope sequence `seq` into `out`; returns the
/// frame. The tether's framing (`protocol::encode_with_version`) with [`NODE_LINK_VERSION`].
/// A downlink's envelope sequence is the low 16 bits of its own ([`low_16`]).
pub fn seal<'a, M: Serialize>(
    seq: u16,
    msg: &M,
    out: &'a mut [u8; MAX_FRAME_LEN],
) -> Result<&'a [u8], EncodeError> {
    // The envelope's session is the tether's; the node link carries its own in its
    // messages, so the envelope's is 0 (one byte).
    crate::protocol::encode_with_version(NODE_LINK_VERSION, 0, seq, msg, out)
}

/// The low 16 bits of a sequence (the envelope's, the uplink's echo).
pub const fn low_16(seq: u64) -> u16 {
    (seq & 0xFFFF) as u16
}

/// `true` when a frame of sequence `seq` may be taken after the one of `last` (`None`:
/// none taken yet): strictly above it, with no wrapping, so a replay is refused however
/// long after its first sending it comes.
pub fn seq_after(seq: u64, last: Option<u64>) -> bool {
    last.is_none_or(|last| seq > last)
}

/// `true` when the uplink sequence `seq` is newer than `last` (wrapping; a half range ahead
/// at most).
pub fn seq_newer(seq: u16, last: u16) -> bool {
    let d = seq.wrapping_sub(last);
    d != 0 && d < 0x8000
}

/// A frame of any version, for the tests of version handling.
#[cfg(test)]
pub(crate) fn encode_frame_for_tests<M: Serialize>(version: u8, seq: u16, msg: &M) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME_LEN];
    crate::protocol::encode_with_version(version, 0, seq, msg, &mut out)
        .map(<[u8]>::to_vec)
        .unwrap_or_default()
}

#[cfg(test)]
mod tests;
