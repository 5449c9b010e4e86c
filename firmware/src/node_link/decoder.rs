//! The node link's receiver: bytes in, a message or a drop reason at each delimiter.
//!
//! The tether's `FrameDecoder` checks the tether's version and holds a 252-byte payload;
//! the node link has its own version and frames of at most [`MAX_LINK_FRAME_LEN`] bytes, so
//! this receiver keeps the encoded bytes of one frame (a small buffer, for the node's 8 KiB
//! of RAM) and at the delimiter undoes COBS in place (`cobs` crate), checks the tether's
//! CRC-32 ([`CRC`]) and decodes the tether's [`Envelope`] with postcard. Resynchronizes on
//! the next zero after garbage or an over-long frame; an empty frame is ignored.

use super::{MAX_LINK_FRAME_LEN, NODE_LINK_VERSION};
use crate::protocol::{DropCounters, DropReason, Envelope, Header, CRC, CRC_LEN};
use serde::de::DeserializeOwned;

/// Encoded bytes of one frame at most (the delimiters are not kept).
const BUF_LEN: usize = MAX_LINK_FRAME_LEN - 2;

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

/// The node link's streaming receiver.
#[derive(Debug)]
pub struct LinkDecoder<M> {
    buf: [u8; BUF_LEN],
    len: usize,
    /// More bytes than a frame can hold arrived since the last delimiter.
    overflow: bool,
    /// Frames accepted.
    pub frames: u32,
    /// Frames dropped, by reason.
    pub dropped: DropCounters,
    _m: core::marker::PhantomData<M>,
}

impl<M> Default for LinkDecoder<M> {
    fn default() -> Self {
        Self::new()
    }
}

impl<M> LinkDecoder<M> {
    /// An empty receiver.
    pub const fn new() -> Self {
        Self {
            buf: [0; BUF_LEN],
            len: 0,
            overflow: false,
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

impl<M: DeserializeOwned> LinkDecoder<M> {
    /// Feed one byte; `Some` at a delimiter that ended a non-empty frame.
    #[cfg_attr(feature = "no-panic", no_panic::no_panic)]
    pub fn push(&mut self, byte: u8) -> Option<LinkFrame<M>> {
        if byte != 0 {
            match self.buf.get_mut(self.len) {
                Some(slot) => {
                    *slot = byte;
                    self.len += 1;
                }
                None => self.overflow = true,
            }
            return None;
        }
        let len = core::mem::replace(&mut self.len, 0);
        if core::mem::replace(&mut self.overflow, false) {
            return Some(self.drop_frame(DropReason::Overflow));
        }
        if len == 0 {
            return None;
        }
        Some(self.decode(len))
    }

    fn decode(&mut self, len: usize) -> LinkFrame<M> {
        let encoded = self.buf.get_mut(..len).unwrap_or_default();
        let Ok(n) = cobs::decode_in_place(encoded) else {
            return self.drop_frame(DropReason::Cobs);
        };
        let data = self.buf.get(..n).unwrap_or_default();
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
            Ok((h, _)) if h.version == NODE_LINK_VERSION => {}
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
