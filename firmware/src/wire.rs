//! The per-step messages in postcard's wire format, written and read by hand.
//!
//! Every control step the firmware reads one `Command::Nav` and writes one
//! `Reply::Telemetry`. Through serde, postcard spent about 1,100 instructions on the
//! Cortex-M4 on the telemetry of protocol version 2 (36 fields: one outlined call per field
//! and a `memcpy` per varint, measured with `scripts/mcu-profile.py`), more than the CRC and
//! COBS of the whole frame; the hand-written writer takes ~430 for version 3's 23 fields. This module writes exactly the bytes postcard writes for those two messages, with
//! straight-line stores, and reads a `Nav` envelope the same way:
//!
//! - `u8` and `bool`: one byte; `u16`, `u32`, `u64` and enum variant indices: postcard's
//!   varint (7 bits a byte, least significant first, high bit = more bytes follow);
//!   `f32`: four bytes, little-endian; structs and arrays: their fields in order, no
//!   length or tag.
//!
//! Postcard stays the definition: every other message goes through it, the topside decodes
//! the hand-written telemetry with postcard and the firmware's `Nav` reader hands anything
//! it does not recognize (another message, a non-minimal varint, trailing bytes) back to
//! postcard. Tests compare both directions with postcard on random messages
//! (`tests/tests/fuzz.rs` and the unit tests below): equal bytes when writing, equal values
//! when reading, and nothing accepted that postcard would refuse.

use crate::protocol::{Command, Law, Mode, NavSample, Plane, Telemetry};
use controller_core::state::NavState;

/// Postcard's variant index of [`Command::Nav`] (declaration order; a test checks it).
const NAV_VARIANT: u32 = 6;
const _: () = assert!(NAV_VARIANT < 0x80);
/// Postcard's variant index of `Reply::Telemetry`.
const TELEMETRY_VARIANT: u32 = 1;

/// Writes postcard's encoding into a byte slice; remembers if it ran out of room.
pub(crate) struct Writer<'a> {
    buf: &'a mut [u8],
    len: usize,
    full: bool,
}

impl<'a> Writer<'a> {
    pub(crate) fn new(buf: &'a mut [u8]) -> Self {
        Self {
            buf,
            len: 0,
            full: false,
        }
    }

    /// Bytes written, or `None` if the slice was too short.
    pub(crate) fn finish(self) -> Option<usize> {
        (!self.full).then_some(self.len)
    }

    #[inline(always)]
    fn u8(&mut self, b: u8) {
        match self.buf.get_mut(self.len) {
            Some(d) => {
                *d = b;
                self.len += 1;
            }
            None => self.full = true,
        }
    }

    #[inline(always)]
    fn bool(&mut self, b: bool) {
        self.u8(u8::from(b));
    }

    /// The next `N` bytes, with one bounds check (`None`, and the writer full, if they do
    /// not fit).
    #[inline(always)]
    fn reserve<const N: usize>(&mut self) -> Option<&mut [u8; N]> {
        let d = self
            .buf
            .get_mut(self.len..self.len + N)
            .and_then(|d| <&mut [u8; N]>::try_from(d).ok());
        match d {
            Some(_) => self.len += N,
            None => self.full = true,
        }
        d
    }

    /// `f32`s in a row, four bytes each: one bounds check for all of them.
    #[inline(always)]
    fn f32s<const N: usize, const B: usize>(&mut self, v: [f32; N]) {
        const { assert!(B == 4 * N) };
        if let Some(d) = self.reserve::<B>() {
            for (d, v) in d.as_chunks_mut::<4>().0.iter_mut().zip(v) {
                *d = v.to_bits().to_le_bytes();
            }
        }
    }

    #[inline(always)]
    fn varint_u32(&mut self, mut v: u32) {
        while v >= 0x80 {
            self.u8(v as u8 | 0x80);
            v >>= 7;
        }
        self.u8(v as u8);
    }

    #[inline(always)]
    fn varint_u16(&mut self, v: u16) {
        self.varint_u32(u32::from(v));
    }

    fn varint_u64(&mut self, v: u64) {
        // The low 28 bits first in 32-bit arithmetic (cheaper on a 32-bit core), the rest
        // only when there is any.
        let mut lo = v as u32;
        let mut hi = v >> 28;
        for _ in 0..4 {
            if lo < 0x80 && hi == 0 {
                self.u8(lo as u8);
                return;
            }
            self.u8(lo as u8 | 0x80);
            lo >>= 7;
        }
        while hi >= 0x80 {
            self.u8(hi as u8 | 0x80);
            hi >>= 7;
        }
        self.u8(hi as u8);
    }

    fn mode(&mut self, m: Mode) {
        match m {
            Mode::Idle => self.u8(0),
            Mode::Manual => self.u8(1),
            Mode::Track { plane, law } => {
                self.u8(2);
                self.u8(match plane {
                    Plane::Xz => 0,
                    Plane::Xy => 1,
                    Plane::ThreeD => 2,
                });
                self.u8(match law {
                    Law::Paper => 0,
                    Law::Tracking => 1,
                });
            }
            Mode::Hold => self.u8(3),
        }
    }

    /// `Envelope { version, seq, msg: Reply::Telemetry(t) }`.
    pub(crate) fn telemetry_envelope(&mut self, version: u8, seq: u16, t: &Telemetry) {
        self.u8(version);
        self.varint_u16(seq);
        self.varint_u32(TELEMETRY_VARIANT);
        self.varint_u64(t.t_us);
        self.mode(t.mode);
        self.bool(t.armed);
        self.varint_u16(t.nav_seq);
        // The fourteen `f32` fields follow each other (errors, requested, achieved,
        // thrust_n): written as one block, with one bounds check instead of fourteen.
        let (e, r, a, th) = (&t.errors, &t.requested, &t.achieved, &t.thrust_n);
        self.f32s::<14, 56>([
            e.x_m,
            e.y_m,
            e.z_m,
            e.pitch_rad,
            e.yaw_rad,
            r.surge_n,
            r.yaw_n_m,
            r.heave_n,
            a.surge_n,
            a.yaw_n_m,
            a.heave_n,
            th[0],
            th[1],
            th[2],
        ]);
        for p in t.pulse_us {
            self.varint_u16(p);
        }
        self.varint_u16(t.faults);
        self.varint_u32(t.loop_ticks);
    }
}

/// Reads postcard's encoding from a byte slice. Accepts only what postcard writes: a varint
/// must be minimal and fit its type. Anything else is `None`, and the caller lets postcard
/// judge the payload.
struct Reader<'a> {
    bytes: &'a [u8],
}

impl Reader<'_> {
    #[inline(always)]
    fn u8(&mut self) -> Option<u8> {
        let (&b, rest) = self.bytes.split_first()?;
        self.bytes = rest;
        Some(b)
    }

    /// A minimal varint whose value fits in 16 bits.
    fn varint_u16(&mut self) -> Option<u16> {
        let mut v = 0u32;
        for k in 0..3 {
            let b = self.u8()?;
            v |= u32::from(b & 0x7F) << (7 * k);
            if b & 0x80 == 0 {
                // Minimal (no zero last byte after the first) and within 16 bits.
                return ((k == 0 || b != 0) && v <= 0xFFFF).then_some(v as u16);
            }
        }
        None
    }

    /// A minimal varint of a `u64`: the first four bytes (28 bits) in 32-bit arithmetic,
    /// the cheap case on a 32-bit core, the up to six others in 64-bit.
    fn varint_u64(&mut self) -> Option<u64> {
        let mut lo = 0u32;
        for k in 0..4 {
            let b = self.u8()?;
            lo |= u32::from(b & 0x7F) << (7 * k);
            if b & 0x80 == 0 {
                return (k == 0 || b != 0).then_some(u64::from(lo));
            }
        }
        let mut hi = 0u64;
        for k in 0..6 {
            let b = self.u8()?;
            hi |= u64::from(b & 0x7F) << (7 * k);
            if b & 0x80 == 0 {
                // Minimal, and the tenth byte of a u64 holds its top bit only.
                return (b != 0 && (k < 5 || b <= 1)).then_some(u64::from(lo) | hi << 28);
            }
        }
        None
    }
}

/// `f32` number `k` of a block of twelve (little-endian).
#[inline(always)]
fn f32_at(block: &[u8; 48], k: usize) -> f32 {
    let b = block.get(4 * k..4 * k + 4).unwrap_or(&[0; 4]);
    f32::from_bits(<[u8; 4]>::try_from(b).map_or(0, u32::from_le_bytes))
}

/// The sequence number and the command of a payload that holds
/// `Envelope { version: _, seq, msg: Command::Nav(_) }` and nothing more, as postcard
/// would decode it; `None` for any other payload (postcard decides then).
pub(crate) fn nav_envelope(payload: &[u8]) -> Option<(u16, Command)> {
    let mut r = Reader { bytes: payload };
    let _version = r.u8()?;
    let seq = r.varint_u16()?;
    // The variant index is a varint; a minimal one below 128 is that one byte.
    if u32::from(r.u8()?) != NAV_VARIANT {
        return None;
    }
    let t_us = r.varint_u64()?;
    // Exactly the twelve f32 of the state are left.
    let f: &[u8; 48] = r.bytes.try_into().ok()?;
    let state = NavState {
        x_m: f32_at(f, 0),
        y_m: f32_at(f, 1),
        z_m: f32_at(f, 2),
        roll_rad: f32_at(f, 3),
        pitch_rad: f32_at(f, 4),
        yaw_rad: f32_at(f, 5),
        u_m_s: f32_at(f, 6),
        v_m_s: f32_at(f, 7),
        w_m_s: f32_at(f, 8),
        p_rad_s: f32_at(f, 9),
        q_rad_s: f32_at(f, 10),
        r_rad_s: f32_at(f, 11),
    };
    Some((seq, Command::Nav(NavSample { t_us, state })))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::{Envelope, Reply, PROTOCOL_VERSION};
    use controller_core::state::{BodyForces, TrackingErrors};
    use proptest::prelude::*;

    fn postcard_bytes<M: serde::Serialize>(m: &M) -> Vec<u8> {
        let mut buf = [0u8; 512];
        postcard::to_slice(m, &mut buf).unwrap().to_vec()
    }

    fn mode() -> impl Strategy<Value = Mode> {
        prop_oneof![
            Just(Mode::Idle),
            Just(Mode::Manual),
            Just(Mode::Hold),
            (0u8..3, any::<bool>()).prop_map(|(p, l)| Mode::Track {
                plane: [Plane::Xz, Plane::Xy, Plane::ThreeD][p as usize],
                law: if l { Law::Tracking } else { Law::Paper },
            }),
        ]
    }

    /// Any bit pattern, NaNs included.
    fn f32_bits() -> impl Strategy<Value = f32> {
        any::<u32>().prop_map(f32::from_bits)
    }

    /// Small and large integers alike (every varint length).
    fn u64_any() -> impl Strategy<Value = u64> {
        (any::<u64>(), 0u32..64).prop_map(|(v, s)| v >> s)
    }
    fn u32_any() -> impl Strategy<Value = u32> {
        (any::<u32>(), 0u32..32).prop_map(|(v, s)| v >> s)
    }

    fn telemetry() -> impl Strategy<Value = Telemetry> {
        (
            (u64_any(), mode(), any::<bool>(), any::<u16>()),
            prop::array::uniform14(f32_bits()),
            prop::array::uniform3(any::<u16>()),
            (any::<u16>(), u32_any()),
        )
            .prop_map(
                |((t_us, mode, armed, nav_seq), f, pulse_us, (faults, loop_ticks))| Telemetry {
                    t_us,
                    mode,
                    armed,
                    nav_seq,
                    errors: TrackingErrors {
                        x_m: f[0],
                        y_m: f[1],
                        z_m: f[2],
                        pitch_rad: f[3],
                        yaw_rad: f[4],
                    },
                    requested: BodyForces {
                        surge_n: f[5],
                        yaw_n_m: f[6],
                        heave_n: f[7],
                    },
                    achieved: BodyForces {
                        surge_n: f[8],
                        yaw_n_m: f[9],
                        heave_n: f[10],
                    },
                    thrust_n: [f[11], f[12], f[13]],
                    pulse_us,
                    faults,
                    loop_ticks,
                },
            )
    }

    fn nav() -> impl Strategy<Value = NavSample> {
        (u64_any(), prop::array::uniform12(f32_bits())).prop_map(|(t_us, f)| NavSample {
            t_us,
            state: NavState {
                x_m: f[0],
                y_m: f[1],
                z_m: f[2],
                roll_rad: f[3],
                pitch_rad: f[4],
                yaw_rad: f[5],
                u_m_s: f[6],
                v_m_s: f[7],
                w_m_s: f[8],
                p_rad_s: f[9],
                q_rad_s: f[10],
                r_rad_s: f[11],
            },
        })
    }

    /// Bit-exact equality (NaN payloads included) through the postcard bytes.
    fn same_command(a: &Command, b: &Command) -> bool {
        postcard_bytes(a) == postcard_bytes(b)
    }

    #[test]
    fn variant_indices_are_postcard_s() {
        let nav = postcard_bytes(&Command::Nav(NavSample::default()));
        assert_eq!(u32::from(nav[0]), NAV_VARIANT);
        let tel = postcard_bytes(&Reply::Telemetry(Telemetry::default()));
        assert_eq!(u32::from(tel[0]), TELEMETRY_VARIANT);
    }

    #[test]
    fn largest_telemetry_fits_the_payload() {
        let t = Telemetry {
            t_us: u64::MAX,
            nav_seq: u16::MAX,
            pulse_us: [u16::MAX; 3],
            faults: u16::MAX,
            loop_ticks: u32::MAX,
            mode: Mode::Track {
                plane: Plane::ThreeD,
                law: Law::Tracking,
            },
            ..Telemetry::default()
        };
        let mut buf = [0u8; crate::protocol::MAX_PAYLOAD_LEN];
        let mut w = Writer::new(&mut buf);
        w.telemetry_envelope(PROTOCOL_VERSION, u16::MAX, &t);
        assert!(w.finish().is_some());
        // And a short buffer is reported, not overrun.
        let mut small = [0u8; 40];
        let mut w = Writer::new(&mut small);
        w.telemetry_envelope(PROTOCOL_VERSION, 1, &t);
        assert_eq!(w.finish(), None);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4000))]

        #[test]
        fn telemetry_bytes_equal_postcard_s(t in telemetry(), seq in any::<u16>(), version in any::<u8>()) {
            let want = postcard_bytes(&Envelope { version, seq, msg: Reply::Telemetry(t) });
            let mut buf = [0u8; 256];
            let mut w = Writer::new(&mut buf);
            w.telemetry_envelope(version, seq, &t);
            let n = w.finish().unwrap();
            prop_assert_eq!(&buf[..n], &want[..]);
        }

        #[test]
        fn nav_reads_what_postcard_writes(n in nav(), seq in any::<u16>(), version in any::<u8>()) {
            let bytes = postcard_bytes(&Envelope { version, seq, msg: Command::Nav(n) });
            let (s, c) = nav_envelope(&bytes).unwrap();
            prop_assert_eq!(s, seq);
            prop_assert!(same_command(&c, &Command::Nav(n)));
            // A byte more or less is not a Nav envelope.
            let mut longer = bytes.clone();
            longer.push(0);
            prop_assert!(nav_envelope(&longer).is_none());
            prop_assert!(nav_envelope(&bytes[..bytes.len() - 1]).is_none());
        }

        /// On any bytes, the hand-written reader accepts nothing postcard refuses and
        /// agrees with postcard on what it accepts.
        #[test]
        fn nav_reader_never_disagrees_with_postcard(
            head in prop::collection::vec(any::<u8>(), 0..14),
            tail in prop::collection::vec(any::<u8>(), 44..52),
        ) {
            // Bias towards near-valid payloads: a Nav tag at byte 2 half the time.
            for bytes in [[head.clone(), tail.clone()].concat(), {
                let mut b = [head.clone(), tail.clone()].concat();
                if b.len() > 3 { b[1] &= 0x7F; b[2] = NAV_VARIANT as u8; }
                b
            }] {
                if let Some((seq, cmd)) = nav_envelope(&bytes) {
                    let env: Envelope<Command> = postcard::from_bytes(&bytes).unwrap();
                    prop_assert_eq!(env.seq, seq);
                    prop_assert!(same_command(&env.msg, &cmd));
                    // postcard consumed all of it too.
                    let (_, rest) = postcard::take_from_bytes::<Envelope<Command>>(&bytes).unwrap();
                    prop_assert!(rest.is_empty());
                }
            }
        }
    }

    #[test]
    fn non_minimal_varints_go_to_postcard() {
        let n = NavSample::default();
        let bytes = postcard_bytes(&Envelope {
            version: 2,
            seq: 5,
            msg: Command::Nav(n),
        });
        // seq 5 written as two bytes: 0x85 0x00.
        let mut odd = vec![bytes[0], 0x85, 0x00];
        odd.extend_from_slice(&bytes[2..]);
        assert!(nav_envelope(&odd).is_none());
        assert!(nav_envelope(&bytes).is_some());
        // t_us = u64::MAX takes ten bytes, the last one 0x01; 0x02 there overflows u64,
        // which postcard refuses, and so does the reader.
        let max = postcard_bytes(&Envelope {
            version: 2,
            seq: 5,
            msg: Command::Nav(NavSample {
                t_us: u64::MAX,
                ..n
            }),
        });
        assert_eq!(
            &max[3..13],
            &[0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x01]
        );
        assert!(nav_envelope(&max).is_some());
        let mut over = max.clone();
        over[12] = 0x02;
        assert!(nav_envelope(&over).is_none());
        assert!(postcard::from_bytes::<Envelope<Command>>(&over).is_err());
    }
}
