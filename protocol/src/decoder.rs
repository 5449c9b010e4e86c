//! The streaming decoder: bytes in, messages out at each delimiter, every dropped frame
//! counted by reason. Resynchronizes on the next `0x00` after garbage, an over-long frame or
//! a bad CRC; an empty frame (two delimiters in a row) is ignored, so a sender may start each
//! frame with a delimiter to flush garbage. No allocation, no panics.

use crate::framing::{
    Envelope, Header, CRC, CRC_LEN, MAX_ENCODED_LEN, MAX_PAYLOAD_LEN, PROTOCOL_VERSION,
};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

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
        let all = [
            self.overflow,
            self.cobs,
            self.too_short,
            self.crc,
            self.version,
        ];
        all.iter().fold(self.malformed, |a, &b| a.wrapping_add(b))
    }
}

/// What the decoder made of a delimiter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Decoded<M> {
    /// A good frame.
    Frame {
        /// Sender's sequence number.
        seq: u16,
        /// The sender's session (version 6).
        session: u32,
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

/// Streaming frame decoder: feed it bytes, it yields messages of type `M` at each delimiter.
///
/// COBS is undone as the bytes arrive, by the `cobs` crate's state machine
/// ([`cobs::DecoderState`]), into a buffer the size of the largest payload and its CRC; at the
/// delimiter the CRC is checked and postcard decodes the payload.
#[derive(Debug)]
pub struct FrameDecoder<M> {
    cobs: cobs::DecoderState,
    /// The decoded bytes of the frame being gathered.
    buf: [u8; MAX_PAYLOAD_LEN + CRC_LEN],
    len: usize,
    /// Encoded bytes since the last delimiter.
    raw: usize,
    /// The frame is already lost: over-long (`Some(Overflow)`) or not valid COBS.
    lost: Option<DropReason>,
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
    pub fn new() -> Self {
        Self {
            cobs: cobs::DecoderState::Idle,
            buf: [0; MAX_PAYLOAD_LEN + CRC_LEN],
            len: 0,
            raw: 0,
            lost: None,
            frames: 0,
            dropped: DropCounters::default(),
            _m: core::marker::PhantomData,
        }
    }
}

impl<M: DeserializeOwned> FrameDecoder<M> {
    /// Feed one byte. Returns `Some` at a delimiter that ended a non-empty frame.
    #[cfg_attr(feature = "no-panic", no_panic::no_panic)]
    pub fn push(&mut self, byte: u8) -> Option<Decoded<M>> {
        if byte != 0 {
            self.raw = self.raw.saturating_add(1);
            if self.lost.is_some() {
                return None;
            }
            if self.raw > MAX_ENCODED_LEN {
                self.lost = Some(DropReason::Overflow);
                return None;
            }
            match self.cobs.feed(byte) {
                Ok(cobs::DecodeResult::DataContinue(b)) => match self.buf.get_mut(self.len) {
                    Some(slot) => {
                        *slot = b;
                        self.len += 1;
                    }
                    None => self.lost = Some(DropReason::Overflow),
                },
                Ok(_) => {}
                Err(_) => self.lost = Some(DropReason::Cobs),
            }
            return None;
        }
        // A delimiter: the frame gathered since the last one ends here.
        let (raw, len) = (self.raw, self.len);
        let lost = self.lost.take();
        let end = core::mem::replace(&mut self.cobs, cobs::DecoderState::Idle).feed(0);
        self.raw = 0;
        self.len = 0;
        if let Some(reason) = lost {
            return Some(self.drop_frame(reason, None));
        }
        if raw == 0 {
            return None;
        }
        if !matches!(end, Ok(cobs::DecodeResult::DataComplete)) {
            return Some(self.drop_frame(DropReason::Cobs, None));
        }
        Some(self.decode(len))
    }

    /// Feed bytes up to and including the first delimiter that ends a frame, advance `bytes`
    /// past them, and return what [`push`](Self::push) returned for it (`None` when `bytes`
    /// ran out first). Call it again while `bytes` is not empty.
    #[cfg_attr(feature = "no-panic", no_panic::no_panic)]
    pub fn push_slice(&mut self, bytes: &mut &[u8]) -> Option<Decoded<M>> {
        while let Some((&b, rest)) = bytes.split_first() {
            *bytes = rest;
            if let Some(d) = self.push(b) {
                return Some(d);
            }
        }
        None
    }

    /// Check and decode the `len` decoded bytes of a frame whose delimiter arrived.
    fn decode(&mut self, len: usize) -> Decoded<M> {
        let data = self.buf.get(..len).unwrap_or_default();
        let Some((payload, crc)) = data.split_last_chunk::<CRC_LEN>() else {
            return self.drop_frame(DropReason::TooShort, None);
        };
        if payload.len() < 2 {
            return self.drop_frame(DropReason::TooShort, None);
        }
        if CRC.checksum(payload) != u32::from_le_bytes(*crc) {
            return self.drop_frame(DropReason::Crc, None);
        }
        let Ok((header, _)) = postcard::take_from_bytes::<Header>(payload) else {
            return self.drop_frame(DropReason::Malformed, None);
        };
        if header.version != PROTOCOL_VERSION {
            return self.drop_frame(DropReason::Version, Some(header.seq));
        }
        match postcard::from_bytes::<Envelope<M>>(payload) {
            Ok(env) => {
                self.frames = self.frames.wrapping_add(1);
                Decoded::Frame {
                    seq: env.seq,
                    session: env.session,
                    msg: env.msg,
                }
            }
            Err(_) => self.drop_frame(DropReason::Malformed, Some(header.seq)),
        }
    }

    fn drop_frame(&mut self, reason: DropReason, seq: Option<u16>) -> Decoded<M> {
        self.dropped.count(reason);
        Decoded::Dropped { reason, seq }
    }
}

/// Decode one complete frame (with or without its delimiters) in one call.
pub fn decode_frame<M: DeserializeOwned>(frame: &[u8]) -> Option<Decoded<M>> {
    let mut d = FrameDecoder::<M>::new();
    let mut bytes = frame;
    d.push_slice(&mut bytes).or_else(|| d.push(0))
}
