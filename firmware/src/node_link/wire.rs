//! The node link's wire facts: its version and the largest frame each way (the receive
//! buffers' size), shared by the link's messages and its decoder.

/// Version of the node link's messages; a frame of another version is never applied.
/// Version 4: the uplink carries the DVL's admitted velocity (`UplinkDvl`) and the node's
/// count of refused DVL reports. Version 3: both messages carry their sender's `u64` sequence (replays refused at any
/// distance). Version 2: the downlink carries the topside's send time and the uplink
/// echoes it with the node's holding time and the age of its newest IMU sample, so the
/// topside knows the round trip and the sample's time on its own clock at any latency.
pub const NODE_LINK_VERSION: u8 = 4;

/// Largest downlink frame on the wire, both delimiters included (every field at its
/// largest postcard encoding; tested).
pub const MAX_DOWNLINK_FRAME_LEN: usize = frame_len(MAX_DOWNLINK_PAYLOAD_LEN);
/// Largest uplink frame on the wire, both delimiters included (tested).
pub const MAX_UPLINK_FRAME_LEN: usize = frame_len(MAX_UPLINK_PAYLOAD_LEN);
/// Largest frame either way: the receive buffers' size.
pub const MAX_LINK_FRAME_LEN: usize = if MAX_UPLINK_FRAME_LEN > MAX_DOWNLINK_FRAME_LEN {
    MAX_UPLINK_FRAME_LEN
} else {
    MAX_DOWNLINK_FRAME_LEN
};

/// Envelope: version (1 byte), session (the tether's: a `u32` varint, at most 5;
/// the node link sends 0, one byte, and carries its own session in its messages), sequence
/// (`u16` varint, at most 3). The bounds count the envelope's session at its largest.
const ENVELOPE_MAX: usize = 1 + 3 + 5;
/// Largest postcard varint of a `u64` sequence.
const SEQ_MAX: usize = 10;
/// Downlink postcard payload at most: envelope, session (`u32`, 5), sequence (`u64`, 10),
/// three pulses (`u16`, 3 each), time to live (`u8`, 1), arm (1), send time (`u32`, 5).
const MAX_DOWNLINK_PAYLOAD_LEN: usize = ENVELOPE_MAX + 5 + SEQ_MAX + 3 * 3 + 1 + 1 + 5;
/// Uplink postcard payload at most: envelope, session (5), echoed sequence (`u16`, 3),
/// echoed time (`u32`, 5), IMU age (`u32`, 5), dt (`u32`, 5), samples (`u16`, 3), delta angle
/// and velocity (6 `f32`, 24), pressure (4), pressure count (1), status (1), eight `u16`
/// counters (24) and the DVL's refused count (`u8`, 1), the DVL's velocity (
/// [`UPLINK_DVL_MAX`]).
const MAX_UPLINK_PAYLOAD_LEN: usize =
    ENVELOPE_MAX + 5 + 3 + 5 + 5 + 5 + 3 + 24 + 4 + 1 + 1 + 8 * 3 + 1 + UPLINK_DVL_MAX;
/// `Option<UplinkDvl>` at most: the option's tag (1), the age (`u16`, 3), two `i16`
/// velocities (zigzag varints, 3 each), the figure of merit (`u8`, 1).
const UPLINK_DVL_MAX: usize = 1 + 3 + 2 * 3 + 1;
/// The uplink's budget (`docs/drivers.md`, "The DVL on the node"): 109 B at most, 47.3 % of
/// the 115,200 Bd link at 50 Hz.
const _: () = assert!(MAX_UPLINK_FRAME_LEN <= 109);

/// Frame length for a payload: CRC-32 appended, COBS, two delimiters.
const fn frame_len(payload: usize) -> usize {
    cobs::max_encoding_length(payload + crate::protocol::CRC_LEN) + 2
}
