//! CRC-32/ISO-HDLC (the Ethernet / zlib CRC) over a frame's postcard payload.

use crc::{Crc, CRC_32_ISO_HDLC};

/// The one CRC engine (a 1 KiB table in flash).
const CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

/// CRC-32 of `bytes`.
#[inline]
pub fn checksum(bytes: &[u8]) -> u32 {
    CRC32.checksum(bytes)
}

#[cfg(test)]
mod tests {
    #[test]
    fn check_value() {
        // The catalogue's check value for "123456789".
        assert_eq!(super::checksum(b"123456789"), 0xCBF4_3926);
    }
}
