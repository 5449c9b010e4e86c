//! Framing: a message in an [`Envelope`], serialized by postcard, the CRC-32 appended,
//! COBS-encoded (the `cobs` crate) between two zero delimiters:
//!
//! ```text
//! 0x00 ++ COBS( postcard(Envelope { version: u8, seq: u16, session: u32, msg }) ++ CRC-32/ISO-HDLC(le) ) ++ 0x00
//! ```
//!
//! The CRC (the `crc` crate's CRC-32/ISO-HDLC, the zlib/Ethernet one) covers the whole
//! postcard payload, version and sequence number too. COBS leaves no zero byte inside a
//! frame, so a receiver that loses bytes or joins mid-stream resynchronizes on the next zero;
//! the leading zero keeps a frame that follows garbage from being glued to it.

use serde::{Deserialize, Serialize};

/// Protocol version. Bump it on any change of the bytes; a frame with another version is
/// dropped (counted as [`DropReason::Version`](crate::DropReason::Version)) and answered with
/// `Nack { reason: UnsupportedVersion }` when its sequence number can be read.
pub const PROTOCOL_VERSION: u8 = 9;

/// Largest postcard payload (envelope) in bytes, CRC not included.
pub const MAX_PAYLOAD_LEN: usize = 248;
/// Length of the CRC trailer.
pub const CRC_LEN: usize = 4;
/// Largest COBS-encoded frame, without the delimiters.
pub const MAX_ENCODED_LEN: usize = cobs::max_encoding_length(MAX_PAYLOAD_LEN + CRC_LEN);
/// Largest frame on the wire, both delimiters included.
pub const MAX_FRAME_LEN: usize = MAX_ENCODED_LEN + 2;

/// The frame check: CRC-32/ISO-HDLC.
pub const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// What every frame carries.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Envelope<M> {
    /// [`PROTOCOL_VERSION`].
    pub version: u8,
    /// Sender's sequence number (wraps).
    pub seq: u16,
    /// The surface session the frame belongs to (version 6): the number the vehicle gave in
    /// its `Reply::Session` (1..=16383), 0 outside a session (the `OpenSession` itself).
    /// Replies carry 0.
    pub session: u32,
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

/// Encode `msg` with sequence number `seq` in session `session` into `out`; returns the
/// frame (both delimiters included).
pub fn encode<'a, M: Serialize>(
    session: u32,
    seq: u16,
    msg: &M,
    out: &'a mut [u8; MAX_FRAME_LEN],
) -> Result<&'a [u8], EncodeError> {
    encode_with_version(PROTOCOL_VERSION, session, seq, msg, out)
}

/// [`encode`] with another protocol version (for tests of version handling).
pub fn encode_with_version<'a, M: Serialize>(
    version: u8,
    session: u32,
    seq: u16,
    msg: &M,
    out: &'a mut [u8; MAX_FRAME_LEN],
) -> Result<&'a [u8], EncodeError> {
    let mut body = [0u8; MAX_PAYLOAD_LEN + CRC_LEN];
    let (payload, _) = body.split_at_mut(MAX_PAYLOAD_LEN);
    let env = Envelope {
        version,
        seq,
        session,
        msg,
    };
    let n = postcard::to_slice(&env, payload)
        .map_err(|_| EncodeError::TooLong)?
        .len();
    let crc = CRC.checksum(body.get(..n).unwrap_or_default());
    let trailer = body.get_mut(n..n + CRC_LEN).ok_or(EncodeError::TooLong)?;
    trailer.copy_from_slice(&crc.to_le_bytes());
    let (first, rest) = out.split_first_mut().ok_or(EncodeError::TooLong)?;
    *first = 0;
    let source = body.get(..n + CRC_LEN).unwrap_or_default();
    let len = cobs::try_encode(source, rest).map_err(|_| EncodeError::TooLong)?;
    *rest.get_mut(len).ok_or(EncodeError::TooLong)? = 0;
    out.get(..len + 2).ok_or(EncodeError::TooLong)
}
