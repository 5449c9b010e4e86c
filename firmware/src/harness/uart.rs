//! The harness UART of an emulated board: polled both ways (the board has nothing else to
//! do while it waits for the host's next step; QEMU's USART hands over the next byte only
//! once the data register has been read, so polling loses none).

use super::{arrived, seal, HarnessDecoder};
use crate::node_link::LinkFrame;
use crate::protocol::MAX_FRAME_LEN;
use embedded_hal_nb::serial::{Read, Write};
use serde::de::DeserializeOwned;
use serde::Serialize;

/// How long a board waits for bytes a step says were delivered, in polls (tens of
/// instructions each: under a second of host time under QEMU). The host writes them before
/// the step, so they are normally there already.
pub const WAIT_POLLS: u32 = 2_000_000;

/// A polled harness UART.
pub struct HarnessUart<R, W> {
    rx: R,
    tx: W,
    seq: u16,
}

impl<R: Read<u8>, W: Write<u8>> HarnessUart<R, W> {
    /// On a started USART's halves.
    pub fn new(rx: R, tx: W) -> Self {
        Self { rx, tx, seq: 0 }
    }

    /// Wait for the next valid frame of `M`; anything else is skipped (and counted by the
    /// decoder).
    pub fn recv<M: DeserializeOwned>(&mut self, decoder: &mut HarnessDecoder<M>) -> M {
        loop {
            let Ok(b) = self.rx.read() else { continue };
            if let Some(LinkFrame::Frame { msg, .. }) = decoder.push(b) {
                return msg;
            }
        }
    }

    /// Send `msg` as the next harness frame (waits for the transmitter).
    pub fn send<M: Serialize>(&mut self, msg: &M) {
        let mut out = [0u8; MAX_FRAME_LEN];
        if let Ok(f) = seal(self.seq, msg, &mut out) {
            for &b in f {
                let _ = nb::block!(self.tx.write(b));
            }
        }
        self.seq = self.seq.wrapping_add(1);
    }
}

/// Poll `received` until it covers `want` or [`WAIT_POLLS`] run out; the count it reached.
pub fn wait_for(want: u32, mut received: impl FnMut() -> u32) -> u32 {
    let mut have = received();
    for _ in 0..WAIT_POLLS {
        if arrived(have, want) {
            break;
        }
        have = received();
    }
    have
}
