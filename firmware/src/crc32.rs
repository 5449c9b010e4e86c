//! CRC-32/ISO-HDLC (the Ethernet / zlib CRC) over a frame's postcard payload.
//!
//! Reflected polynomial `0xEDB8_8320`, init and xorout `0xFFFF_FFFF`, one 1 KiB table built at
//! compile time. Byte-wise so that the frame encoder can fold it into its COBS pass
//! ([`update`]) instead of reading the payload twice.

/// The table: the CRC of each byte value.
const TABLE: [u32; 256] = table();

// Evaluated by the compiler only (`TABLE` is a `const`): an index out of range would fail the
// build, it cannot panic in the firmware.
#[allow(clippy::indexing_slicing)]
const fn table() -> [u32; 256] {
    let mut t = [0u32; 256];
    let mut i = 0;
    while i < 256 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
            k += 1;
        }
        t[i] = c;
        i += 1;
    }
    t
}

/// The register before the first byte.
pub const INIT: u32 = 0xFFFF_FFFF;

/// Fold one byte into the register.
#[inline(always)]
pub fn update(crc: u32, byte: u8) -> u32 {
    // The index is masked to 0..=255: the lookup cannot miss.
    let i = ((crc ^ u32::from(byte)) & 0xFF) as usize;
    TABLE.get(i).copied().unwrap_or(0) ^ (crc >> 8)
}

/// The CRC from the register after the last byte.
#[inline(always)]
pub fn finish(crc: u32) -> u32 {
    crc ^ 0xFFFF_FFFF
}

/// Fold four bytes, read as a little-endian word, into the register: the same as
/// [`update`] with each byte in turn (the register is reflected, so the word's bytes line up
/// with the register's, least significant first), one load instead of four.
#[inline(always)]
fn update_word(crc: u32, word: u32) -> u32 {
    // Written out: the firmware crate is built for size, which would keep a loop here.
    let c = crc ^ word;
    let c = shift(c);
    let c = shift(c);
    let c = shift(c);
    shift(c)
}

/// One byte's worth of the register shifted out through the table.
#[inline(always)]
fn shift(c: u32) -> u32 {
    // The index is masked to 0..=255: the lookup cannot miss.
    TABLE.get((c & 0xFF) as usize).copied().unwrap_or(0) ^ (c >> 8)
}

/// CRC-32 of `bytes`.
#[inline]
pub fn checksum(bytes: &[u8]) -> u32 {
    // Eight bytes (two words) a turn, so the loop's own count and branch come once per two
    // words (a frame's payload is 60 to 90 bytes); then at most one word and three bytes.
    let (pairs, rest) = bytes.as_chunks::<8>();
    let mut crc = INIT;
    for p in pairs {
        let (lo, hi) = p.split_at(4);
        let (Ok(lo), Ok(hi)) = (<[u8; 4]>::try_from(lo), <[u8; 4]>::try_from(hi)) else {
            continue;
        };
        crc = update_word(crc, u32::from_le_bytes(lo));
        crc = update_word(crc, u32::from_le_bytes(hi));
    }
    let (words, rest) = rest.as_chunks::<4>();
    for w in words {
        crc = update_word(crc, u32::from_le_bytes(*w));
    }
    finish(rest.iter().fold(crc, |c, &b| update(c, b)))
}

#[cfg(test)]
mod tests {
    #[test]
    fn check_value() {
        // The catalogue's check value for "123456789".
        assert_eq!(super::checksum(b"123456789"), 0xCBF4_3926);
        assert_eq!(super::checksum(b""), 0);
    }

    #[test]
    fn matches_the_crc_crate_on_random_data() {
        // The `crc` crate's CRC_32_ISO_HDLC, what the protocol specifies.
        let reference = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);
        let mut x = 0x9E37_79B9u32;
        for len in 0..300 {
            let data: Vec<u8> = (0..len)
                .map(|_| {
                    x ^= x << 13;
                    x ^= x >> 17;
                    x ^= x << 5;
                    x as u8
                })
                .collect();
            assert_eq!(
                super::checksum(&data),
                reference.checksum(&data),
                "len {len}"
            );
        }
    }
}
