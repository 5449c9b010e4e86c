//! Assembles lines from a byte stream (a UART, a UDP datagram) for the ASCII instrument
//! formats: bytes up to CR or LF make a line; empty lines are skipped; a line longer than the
//! buffer is dropped whole (counted) and reading resumes at the next line end. The buffer is
//! fixed (`N` bytes), nothing is allocated.

/// A line accumulator with room for lines of up to `N` bytes (without their end).
#[derive(Debug, Clone)]
pub struct LineBuffer<const N: usize> {
    buf: [u8; N],
    len: usize,
    overflowed: bool,
    /// Lines dropped because they were longer than `N` bytes.
    pub overflows: u32,
}

impl<const N: usize> Default for LineBuffer<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> LineBuffer<N> {
    /// An empty accumulator.
    pub const fn new() -> Self {
        Self {
            buf: [0; N],
            len: 0,
            overflowed: false,
            overflows: 0,
        }
    }

    /// Takes one byte; returns the finished line (without its CR / LF) when `byte` ends one.
    pub fn push(&mut self, byte: u8) -> Option<&[u8]> {
        if byte == b'\r' || byte == b'\n' {
            let len = core::mem::take(&mut self.len);
            if core::mem::take(&mut self.overflowed) || len == 0 {
                return None;
            }
            return self.buf.get(..len);
        }
        if self.overflowed {
            return None;
        }
        match self.buf.get_mut(self.len) {
            Some(slot) => {
                *slot = byte;
                self.len += 1;
            }
            None => {
                self.overflowed = true;
                self.overflows = self.overflows.saturating_add(1);
            }
        }
        None
    }

    /// Drops a partly received line (after a UART error, say).
    pub fn clear(&mut self) {
        self.len = 0;
        self.overflowed = false;
    }
}
