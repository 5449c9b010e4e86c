//! The byte queue between the serial receive interrupt and the main loop: a
//! `heapless::Deque` (fixed capacity, no allocation) plus a count of the bytes it had to drop.
//! The board wraps it in a critical section (single producer, single consumer).

use heapless::Deque;

/// Queue of up to `N` bytes; when full, new bytes are dropped and counted.
#[derive(Debug, Clone)]
pub struct Ring<const N: usize> {
    bytes: Deque<u8, N>,
    /// Bytes dropped because the queue was full.
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
            bytes: Deque::new(),
            overruns: 0,
        }
    }

    /// Bytes waiting.
    pub fn len(&self) -> usize {
        self.bytes.len()
    }

    /// Nothing waiting?
    pub fn is_empty(&self) -> bool {
        self.bytes.is_empty()
    }

    /// Append a byte (dropped and counted when full).
    pub fn push(&mut self, b: u8) {
        if self.bytes.push_back(b).is_err() {
            self.overruns = self.overruns.wrapping_add(1);
        }
    }

    /// Take up to `out.len()` bytes; returns how many.
    pub fn pop_into(&mut self, out: &mut [u8]) -> usize {
        let mut n = 0;
        for o in out.iter_mut() {
            match self.bytes.pop_front() {
                Some(b) => *o = b,
                None => break,
            }
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
        assert_eq!(r.len(), 4);
        let mut o = [0u8; 3];
        assert_eq!(r.pop_into(&mut o), 3);
        assert_eq!(o, [1, 2, 3]);
        r.push(7);
        r.push(8);
        let mut o = [0u8; 8];
        assert_eq!(r.pop_into(&mut o), 3);
        assert_eq!(&o[..3], &[4, 7, 8]);
        assert!(r.is_empty());
        assert_eq!(r.pop_into(&mut o), 0);
    }
}
