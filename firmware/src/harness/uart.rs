//! The harness UART of an emulated board: the host's steps arrive through the USART's
//! receive interrupt into a ring (`embedded-io`), and while none is waiting the board sleeps
//! until an interrupt (the board's own `sleep` closure: a core halted in WFI costs QEMU's
//! host nothing, where polling the data register keeps a host core busy); the reports are
//! sent polled.

use super::{arrived, seal, HarnessDecoder};
use crate::node_link::LinkFrame;
use crate::protocol::MAX_FRAME_LEN;
use embedded_hal_nb::serial::Write;
use embedded_io::{Read, ReadReady};
use serde::de::DeserializeOwned;
use serde::Serialize;

/// How long a board waits for bytes a step says were delivered, in polls (tens of
/// instructions each: under a second of host time under QEMU). The host writes them before
/// the step, so they are normally there already.
pub const WAIT_POLLS: u32 = 2_000_000;

/// A harness UART: an interrupt-driven receive ring and a polled transmitter.
pub struct HarnessUart<R, W> {
    rx: R,
    tx: W,
    seq: u16,
}

impl<R: Read + ReadReady, W: Write<u8>> HarnessUart<R, W> {
    /// On a started receive ring and a USART's transmitter.
    pub fn new(rx: R, tx: W) -> Self {
        Self { rx, tx, seq: 0 }
    }

    /// Wait for the next valid frame of `M`; anything else is skipped (and counted by the
    /// decoder). While the ring is empty, `sleep(rx)` is called: it must return at once if
    /// `rx` has a byte, else when an interrupt has come.
    pub fn recv<M: DeserializeOwned>(
        &mut self,
        decoder: &mut HarnessDecoder<M>,
        mut sleep: impl FnMut(&mut R),
    ) -> M {
        loop {
            let mut b = [0u8; 1];
            // One byte at a time: the bytes after a frame's end are the next step's.
            if self.rx.read_ready().ok() != Some(true) || self.rx.read(&mut b).ok() != Some(1) {
                sleep(&mut self.rx);
                continue;
            }
            if let Some(LinkFrame::Frame { msg, .. }) = decoder.push(b[0]) {
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
