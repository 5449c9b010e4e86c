//! The node link's receiver: bytes in, a message or a drop reason at each delimiter.
//!
//! The tether's `FrameDecoder` checks the tether's version and holds a 252-byte payload;
//! the node link has its own version and frames of at most [`MAX_LINK_FRAME_LEN`] bytes, so
//! this receiver undoes COBS as the bytes arrive (the `cobs` crate's state machine, as the
//! tether's decoder: `cobs::decode_in_place` keeps index panics the optimizer cannot
//! remove) into a buffer of one frame (small, for the node's 8 KiB of RAM), and at the
//! delimiter checks the tether's CRC-32 ([`CRC`]) and decodes the tether's [`Envelope`] with
//! postcard. Resynchronizes on the next zero after garbage or an over-long frame; an empty
//! frame is ignored.

use super::wire::{MAX_LINK_FRAME_LEN, NODE_LINK_VERSION};
use crate::protocol::{DropCounters, DropReason, Envelope, Header, CRC, CRC_LEN};
use serde::de::DeserializeOwned;

/// Decoded bytes of one frame at most (COBS adds at least one byte; no delimiters).
const BUF_LEN: usize = MAX_LINK_FRAME_LEN - 3;

/// What a delimiter ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LinkFrame<M> {
    /// A frame with a good CRC, this link's version and a valid message.
    Frame {
        /// Sender's sequence number.
        seq: u16,
        /// The message.
        msg: M,
    },
    /// A dropped frame, and why.
    Dropped(DropReason),
}

/// The node link's streaming receiver. `VERSION` is the envelope version it accepts: the
/// node link's, or the emulation harness's (`crate::harness`, the same framing).
#[derive(Debug)]
pub struct LinkDecoder<M, const VERSION: u8 = NODE_LINK_VERSION> {
    cobs: cobs::DecoderState,
    /// The decoded bytes of the frame being gathered.
    buf: [u8; BUF_LEN],
    len: usize,
    /// The frame is already lost: over-long (`Overflow`) or not valid COBS.
    lost: Option<DropReason>,
    /// Frames accepted.
    pub frames: u32,
    /// Frames dropped, by reason.
    pub dropped: DropCounters,
    _m: core::marker::PhantomData<M>,
}

impl<M, const VERSION: u8> Default for LinkDecoder<M, VERSION> {
    fn default() -> Self {
        Self::new()
    }
}

impl<M, const VERSION: u8> LinkDecoder<M, VERSION> {
    /// An empty receiver.
    pub const fn new() -> Self {
        Self {
            cobs: cobs::DecoderState::Idle,
            buf: [0; BUF_LEN],
            len: 0,
            lost: None,
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

impl<M: DeserializeOwned, const VERSION: u8> LinkDecoder<M, VERSION> {
    /// Feed one byte; `Some` at a delimiter that ended a non-empty frame.
    #[cfg_attr(feature = "no-panic", no_panic::no_panic)]
    pub fn push(&mut self, byte: u8) -> Option<LinkFrame<M>> {
        if byte != 0 {
            if self.lost.is_none() {
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
            }
            return None;
        }
        // A delimiter: the frame gathered since the last one ends here.
        let len = core::mem::replace(&mut self.len, 0);
        let lost = self.lost.take();
        let end = core::mem::replace(&mut self.cobs, cobs::DecoderState::Idle).feed(0);
        if let Some(reason) = lost {
            return Some(self.drop_frame(reason));
        }
        match end {
            // Two delimiters in a row: an empty frame, ignored.
            Ok(cobs::DecodeResult::NoData) if len == 0 => None,
            Ok(cobs::DecodeResult::DataComplete) => Some(self.decode(len)),
            _ => Some(self.drop_frame(DropReason::Cobs)),
        }
    }

    fn decode(&mut self, len: usize) -> LinkFrame<M> {
        let data = self.buf.get(..len).unwrap_or_default();
        let Some((payload, crc)) = data.split_last_chunk::<CRC_LEN>() else {
            return self.drop_frame(DropReason::TooShort);
        };
        if payload.len() < 2 {
            return self.drop_frame(DropReason::TooShort);
        }
        if CRC.checksum(payload) != u32::from_le_bytes(*crc) {
            return self.drop_frame(DropReason::Crc);
        }
        match postcard::take_from_bytes::<Header>(payload) {
            Ok((h, _)) if h.version == VERSION => {}
            Ok(_) => return self.drop_frame(DropReason::Version),
            Err(_) => return self.drop_frame(DropReason::Malformed),
        }
        match postcard::from_bytes::<Envelope<M>>(payload) {
            Ok(env) => {
                self.frames = self.frames.wrapping_add(1);
                LinkFrame::Frame {
                    seq: env.seq,
                    msg: env.msg,
                }
            }
            Err(_) => self.drop_frame(DropReason::Malformed),
        }
    }

    fn drop_frame(&mut self, reason: DropReason) -> LinkFrame<M> {
        self.dropped.count(reason);
        LinkFrame::Dropped(reason)
    }
}
