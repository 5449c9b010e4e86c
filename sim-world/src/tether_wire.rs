//! A byte-level model of the tether's serial pair between the topside MCU and the vehicle's
//! node: bytes leave one at a time at the wire's rate (8N1: 10 bits a byte, so
//! 86.8 us a byte at 115,200 Bd), reach the far end after an added one-way latency with
//! jitter, may be corrupted at a given rate (a seeded RNG, so a run repeats), and stop at a
//! cut. The two directions are independent ([`Duplex`]: full duplex, as an RS-422 pair).
//!
//! Time is the simulation's (seconds, `f64`). A byte written at `t` starts on the wire when
//! the line is free (after the bytes before it), and is delivered when its stop bit has
//! arrived: `start + 10 / baud + latency + jitter`. Jitter is drawn once per write (a
//! frame), uniform in `[0, jitter_s]`, and never reorders bytes: a byte is never delivered
//! before the one written before it. A corrupted byte is XORed with a random non-zero
//! pattern. After a cut at `cut_at_s` nothing is delivered: a byte due at or after the cut
//! is lost, and so is every byte written later.

use anyhow::{bail, Result};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::VecDeque;

/// Bits on the wire per byte with 8N1 framing: a start bit, 8 data bits, a stop bit.
pub const BITS_PER_BYTE: f64 = 10.0;

/// The default rate of the node link (Bd), as the firmware's USART.
pub const DEFAULT_BAUD: u32 = 115_200;

/// What one direction of the wire does to the bytes (the other direction is the same unless
/// told otherwise).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WireSpec {
    /// Line rate (Bd), 8N1.
    pub baud: u32,
    /// Added one-way latency (s): a long cable, a modem, a multiplexer.
    pub latency_s: f64,
    /// Extra latency drawn per write, uniform in `[0, jitter_s]` (s).
    pub jitter_s: f64,
    /// Probability that a byte arrives corrupted.
    pub corruption_rate: f64,
    /// The cable is cut at this time (s): nothing is delivered from then on.
    pub cut_at_s: Option<f64>,
}

impl Default for WireSpec {
    fn default() -> Self {
        Self {
            baud: DEFAULT_BAUD,
            latency_s: 0.0,
            jitter_s: 0.0,
            corruption_rate: 0.0,
            cut_at_s: None,
        }
    }
}

impl WireSpec {
    /// Time one byte takes on the wire (s).
    pub fn byte_time_s(&self) -> f64 {
        BITS_PER_BYTE / f64::from(self.baud)
    }

    /// Refuse a wire that cannot exist, naming the field and the value.
    pub fn validate(&self) -> Result<()> {
        if !(300..=100_000_000).contains(&self.baud) {
            bail!("tether_baud = {} is outside 300..=100000000 Bd", self.baud);
        }
        if !(self.latency_s.is_finite() && (0.0..=10.0).contains(&self.latency_s)) {
            bail!(
                "tether_latency_s = {} is outside 0..=10 s (a one-way latency)",
                self.latency_s
            );
        }
        if !(self.jitter_s.is_finite() && (0.0..=10.0).contains(&self.jitter_s)) {
            bail!("tether_jitter_s = {} is outside 0..=10 s", self.jitter_s);
        }
        if !(self.corruption_rate.is_finite() && (0.0..=1.0).contains(&self.corruption_rate)) {
            bail!(
                "tether_corruption = {} is not a probability (0..=1 of bytes)",
                self.corruption_rate
            );
        }
        if let Some(t) = self.cut_at_s {
            if !(t.is_finite() && t >= 0.0) {
                bail!("tether_cut_s = {t} is not a time >= 0 s");
            }
        }
        Ok(())
    }
}

/// What a direction did, for the reports.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct WireCounters {
    /// Bytes written into the wire.
    pub written: u64,
    /// Bytes delivered at the far end.
    pub delivered: u64,
    /// Delivered bytes that were corrupted.
    pub corrupted: u64,
    /// Bytes lost to the cut.
    pub lost_to_cut: u64,
}

/// One direction of the wire.
#[derive(Debug, Clone)]
pub struct Wire {
    spec: WireSpec,
    rng: ChaCha8Rng,
    /// When the line is free to start the next byte (s).
    line_free_s: f64,
    /// The latest delivery time given to a byte (s): bytes are not reordered.
    last_arrival_s: f64,
    /// Bytes on their way: (delivery time, byte).
    in_flight: VecDeque<(f64, u8)>,
    counters: WireCounters,
}

impl Wire {
    /// A direction with its own seeded RNG (jitter and corruption).
    pub fn new(spec: WireSpec, seed: u64) -> Self {
        Self {
            spec,
            rng: ChaCha8Rng::seed_from_u64(seed),
            line_free_s: 0.0,
            last_arrival_s: 0.0,
            in_flight: VecDeque::new(),
            counters: WireCounters::default(),
        }
    }

    /// The wire's figures.
    pub fn spec(&self) -> &WireSpec {
        &self.spec
    }

    /// What the direction did so far.
    pub fn counters(&self) -> WireCounters {
        self.counters
    }

    /// Cut the wire at `t_s` (or uncut it with `None`), e.g. from a test's script.
    pub fn set_cut(&mut self, cut_at_s: Option<f64>) {
        self.spec.cut_at_s = cut_at_s;
    }

    /// Write `bytes` at time `t_s` (the transmitter's FIFO: they follow the bytes still
    /// being sent). Returns when the last of them is delivered (s), if it is.
    pub fn write(&mut self, t_s: f64, bytes: &[u8]) -> Option<f64> {
        if bytes.is_empty() {
            return None;
        }
        let byte_s = self.spec.byte_time_s();
        let jitter_s = if self.spec.jitter_s > 0.0 {
            self.rng.random::<f64>() * self.spec.jitter_s
        } else {
            0.0
        };
        let mut start_s = self.line_free_s.max(t_s);
        let mut last = None;
        for &b in bytes {
            self.counters.written += 1;
            let sent_s = start_s + byte_s;
            start_s = sent_s;
            let arrival_s = (sent_s + self.spec.latency_s + jitter_s).max(self.last_arrival_s);
            self.last_arrival_s = arrival_s;
            if self.spec.cut_at_s.is_some_and(|cut| arrival_s >= cut) {
                self.counters.lost_to_cut += 1;
                continue;
            }
            let b = if self.spec.corruption_rate > 0.0
                && self.rng.random::<f64>() < self.spec.corruption_rate
            {
                self.counters.corrupted += 1;
                b ^ self.rng.random_range(1..=255u8)
            } else {
                b
            };
            self.in_flight.push_back((arrival_s, b));
            last = Some(arrival_s);
        }
        self.line_free_s = start_s;
        last
    }

    /// The bytes delivered by `t_s` (in order), appended to `out`.
    pub fn read_into(&mut self, t_s: f64, out: &mut Vec<u8>) {
        let cut = self.spec.cut_at_s;
        while let Some(&(arrival_s, b)) = self.in_flight.front() {
            if arrival_s > t_s {
                break;
            }
            self.in_flight.pop_front();
            // A cut set after the byte was written still stops it.
            if cut.is_some_and(|c| arrival_s >= c) {
                self.counters.lost_to_cut += 1;
                continue;
            }
            self.counters.delivered += 1;
            out.push(b);
        }
    }

    /// The bytes delivered by `t_s` (in order).
    pub fn read(&mut self, t_s: f64) -> Vec<u8> {
        let mut out = Vec::new();
        self.read_into(t_s, &mut out);
        out
    }
}

/// Both directions of the tether's pair: down (topside -> node) and up (node -> topside).
#[derive(Debug, Clone)]
pub struct Duplex {
    /// Topside -> node.
    pub down: Wire,
    /// Node -> topside.
    pub up: Wire,
}

impl Duplex {
    /// Both directions with the same figures and their own RNG streams from `seed`.
    pub fn new(spec: WireSpec, seed: u64) -> Self {
        Self {
            down: Wire::new(spec, seed.wrapping_mul(2).wrapping_add(1)),
            up: Wire::new(spec, seed.wrapping_mul(2).wrapping_add(2)),
        }
    }

    /// Cut (or uncut) both directions at `cut_at_s`.
    pub fn set_cut(&mut self, cut_at_s: Option<f64>) {
        self.down.set_cut(cut_at_s);
        self.up.set_cut(cut_at_s);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const US: f64 = 1e-6;

    #[test]
    fn a_frame_of_n_bytes_arrives_n_byte_times_plus_the_latency_later() {
        let spec = WireSpec {
            latency_s: 0.025,
            ..WireSpec::default()
        };
        assert!((spec.byte_time_s() - 86.805_555 * US).abs() < 0.001 * US);
        let mut w = Wire::new(spec, 1);
        let frame: Vec<u8> = (0..81).collect();
        let t0 = 1.0;
        let last = w.write(t0, &frame).unwrap();
        let expect = t0 + 81.0 * 86.805_555 * US + 0.025;
        assert!((last - expect).abs() < 0.01 * US, "{last} vs {expect}");
        // Nothing before the first byte's stop bit + latency; all of it at `expect`.
        assert!(w.read(t0 + 86.8 * US + 0.025 - 1.0 * US).is_empty());
        assert_eq!(w.read(t0 + 86.9 * US + 0.025).len(), 1);
        assert_eq!(w.read(expect - 1.0 * US).len(), 79);
        assert_eq!(w.read(expect + 1e-9), vec![80]);
        let c = w.counters();
        assert_eq!((c.written, c.delivered, c.corrupted), (81, 81, 0));
    }

    #[test]
    fn a_second_frame_waits_for_the_line_and_bytes_keep_their_order() {
        let spec = WireSpec {
            jitter_s: 0.010,
            ..WireSpec::default()
        };
        let mut w = Wire::new(spec, 7);
        let mut sent = Vec::new();
        let mut got = Vec::new();
        let mut last_arrival = 0.0;
        for k in 0..200u32 {
            let frame: Vec<u8> = (0..30).map(|i| (k * 31 + i) as u8).collect();
            let t = f64::from(k) * 0.001; // faster than the line carries: they queue
            let a = w.write(t, &frame).unwrap();
            assert!(a >= last_arrival);
            last_arrival = a;
            sent.extend(frame);
            w.read_into(t, &mut got);
        }
        w.read_into(1e9, &mut got);
        assert_eq!(got, sent);
        // 6,000 bytes at 86.8 us take 0.52 s on the line, whatever the write times.
        assert!(last_arrival >= 6000.0 * 86.8 * US);
        assert!(last_arrival <= 6000.0 * 86.9 * US + 0.010);
    }

    #[test]
    fn corruption_is_measured_at_its_rate_and_repeats_with_the_seed() {
        for rate in [1e-3, 1e-2] {
            let spec = WireSpec {
                corruption_rate: rate,
                baud: 1_000_000,
                ..WireSpec::default()
            };
            let n = 1_000_000usize;
            let bytes = vec![0x55u8; n];
            let mut w = Wire::new(spec, 42);
            w.write(0.0, &bytes);
            let got = w.read(1e9);
            let wrong = got.iter().filter(|&&b| b != 0x55).count();
            assert_eq!(
                wrong as u64,
                w.counters().corrupted,
                "each corruption changes the byte"
            );
            let measured = wrong as f64 / n as f64;
            // 5 standard deviations of a binomial count.
            let sd = (rate * (1.0 - rate) / n as f64).sqrt();
            assert!(
                (measured - rate).abs() < 5.0 * sd,
                "rate {rate}: measured {measured}"
            );
            let mut w2 = Wire::new(spec, 42);
            w2.write(0.0, &bytes);
            assert_eq!(w2.read(1e9), got, "same seed, same bytes");
        }
    }

    #[test]
    fn after_a_cut_nothing_is_delivered() {
        let spec = WireSpec {
            latency_s: 0.005,
            cut_at_s: Some(0.5),
            ..WireSpec::default()
        };
        let mut d = Duplex::new(spec, 3);
        let mut down = Vec::new();
        let mut up = Vec::new();
        for k in 0..100 {
            let t = f64::from(k) * 0.02;
            d.down.write(t, &[1; 20]);
            d.up.write(t, &[2; 60]);
            d.down.read_into(t, &mut down);
            d.up.read_into(t, &mut up);
        }
        d.down.read_into(1e9, &mut down);
        d.up.read_into(1e9, &mut up);
        // Frames written at 0, 0.02, ..., 0.48: the one at 0.48 arrives 0.48 + 60*86.8us +
        // 5 ms = 0.4902 < 0.5 (up) and is whole; everything later is lost.
        assert_eq!(down.len(), 25 * 20);
        assert_eq!(up.len(), 25 * 60);
        assert_eq!(d.up.counters().lost_to_cut, 75 * 60);
        // A cut set while bytes are in flight stops them too.
        let mut w = Wire::new(
            WireSpec {
                latency_s: 0.1,
                ..WireSpec::default()
            },
            1,
        );
        w.write(0.0, &[9; 10]);
        w.set_cut(Some(0.05));
        assert!(w.read(1.0).is_empty());
        assert_eq!(w.counters().lost_to_cut, 10);
    }

    #[test]
    fn the_two_directions_are_independent() {
        let mut d = Duplex::new(WireSpec::default(), 5);
        let a = d.down.write(0.0, &[0; 86]).unwrap();
        let b = d.up.write(0.0, &[0; 86]).unwrap();
        assert_eq!(a, b, "full duplex: neither waits for the other");
    }

    #[test]
    fn bad_figures_are_refused_with_the_key_named() {
        let bad = [
            (
                WireSpec {
                    baud: 0,
                    ..WireSpec::default()
                },
                "tether_baud",
            ),
            (
                WireSpec {
                    latency_s: -0.1,
                    ..WireSpec::default()
                },
                "tether_latency_s",
            ),
            (
                WireSpec {
                    latency_s: f64::NAN,
                    ..WireSpec::default()
                },
                "tether_latency_s",
            ),
            (
                WireSpec {
                    jitter_s: -1.0,
                    ..WireSpec::default()
                },
                "tether_jitter_s",
            ),
            (
                WireSpec {
                    corruption_rate: 1.5,
                    ..WireSpec::default()
                },
                "tether_corruption",
            ),
            (
                WireSpec {
                    cut_at_s: Some(-1.0),
                    ..WireSpec::default()
                },
                "tether_cut_s",
            ),
        ];
        for (spec, key) in bad {
            let e = spec.validate().unwrap_err().to_string();
            assert!(e.contains(key), "{e}");
        }
        assert!(WireSpec::default().validate().is_ok());
    }
}
