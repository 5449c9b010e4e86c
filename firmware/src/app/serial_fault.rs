//! A serial port's error raised as a fault.

use crate::protocol::fault;

/// `r`'s value, or `None` with [`fault::SERIAL_ERROR`] raised in `faults`.
pub(super) fn serial_ok<T, E>(faults: &mut u16, r: Result<T, E>) -> Option<T> {
    r.map_err(|_| *faults |= fault::SERIAL_ERROR).ok()
}
