//! A byte ring buffer for the serial receive interrupt (single producer, single consumer;
//! the board wraps it in a critical section).

/// Ring buffer of `N` bytes; when full, new bytes are dropped and counted.
#[derive(Debug, Clone)]
pub struct Ring<const N: usize> {
    buf: [u8; N],
    head: usize,
    len: usize,
    /// Bytes dropped because the ring was full.
    pub overruns: u32,
}

impl<const N: usize> Default for Ring<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Ring<N> {
    /// Empty.
    pub const fn new() -> Self {
        Self {
            buf: [0; N],
            head: 0,
            len: 0,
            overruns: 0,
        }
    }

    /// Bytes waiting.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Nothing waiting?
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Append a byte (dropped and counted when full).
    pub fn push(&mut self, b: u8) {
        if self.len >= N {
            self.overruns = self.overruns.wrapping_add(1);
            return;
        }
        let i = (self.head + self.len) % N;
        if let Some(slot) = self.buf.get_mut(i) {
            *slot = b;
            self.len += 1;
        }
    }

    /// Take up to `out.len()` bytes; returns how many.
    pub fn pop_into(&mut self, out: &mut [u8]) -> usize {
        let mut n = 0;
        for o in out.iter_mut() {
            if self.len == 0 {
                break;
            }
            if let Some(b) = self.buf.get(self.head) {
                *o = *b;
            }
            self.head = (self.head + 1) % N;
            self.len -= 1;
            n += 1;
        }
        n
    }
}

#[cfg(test)]
mod tests {
    use super::Ring;

    #[test]
    fn fifo_wraps_and_counts_overruns() {
        let mut r = Ring::<4>::new();
        for b in 1..=6 {
            r.push(b);
        }
        assert_eq!(r.overruns, 2);
        let mut o = [0u8; 3];
        assert_eq!(r.pop_into(&mut o), 3);
        assert_eq!(o, [1, 2, 3]);
        r.push(7);
        r.push(8);
        let mut o = [0u8; 8];
        assert_eq!(r.pop_into(&mut o), 3);
        assert_eq!(&o[..3], &[4, 7, 8]);
        assert!(r.is_empty());
    }
}
