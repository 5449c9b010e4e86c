//! The health inputs of the emulated board. QEMU's `netduinoplus2` models neither a GPIO a
//! host can drive nor an ADC whose reading a host can set, so the host sends what the
//! power-sense module's two ADC pins and the leak probe read (and the enclosure's sensor)
//! as a [`HealthSample`] in a harness frame (`crate::harness`: the node link's framing,
//! postcard + CRC-32 + COBS, with its own envelope version) on a UART of its own; the
//! firmware takes it exactly where a board's [`WithHealth`](super::WithHealth) reading
//! would go, into the same health checks. A corrupted frame is dropped (counted by the
//! decoder) and the previous reading stays; before the first frame there is no reading.

use crate::node_link::{LinkDecoder, LinkFrame};
use crate::protocol::HealthSample;
use crate::sensors::Sensors;
use controller_core::nav::{DvlFix, ImuSample};
use embedded_io::{Read, ReadReady};

/// Envelope version of the frames: the emulation harness's (`crate::harness::HARNESS_VERSION`,
/// whose `seal` the host writes them with; tested below), named here so that the health
/// checks do not depend on the harness's passes.
pub const HEALTH_FRAME_VERSION: u8 = 0x48;

/// Most bytes taken from the UART per reading (a frame is under 40 bytes; the host sends one
/// per control step), so that a flood cannot hold the loop.
pub const HARNESS_HEALTH_MAX_BYTES: usize = 256;

/// Sensors `N` plus the health inputs sent by the host on the UART `R`.
pub struct HarnessHealth<N, R> {
    /// The other sensors.
    pub inner: N,
    rx: R,
    decoder: LinkDecoder<HealthSample, HEALTH_FRAME_VERSION>,
    latest: Option<HealthSample>,
    /// Frames taken.
    pub frames: u32,
    /// UART read errors (overrun, framing): the frame they hit is dropped by its CRC.
    pub uart_errors: u32,
}

impl<N, R: Read + ReadReady> HarnessHealth<N, R> {
    /// The health inputs read from `rx`, around `inner`.
    pub fn new(inner: N, rx: R) -> Self {
        Self {
            inner,
            rx,
            decoder: LinkDecoder::new(),
            latest: None,
            frames: 0,
            uart_errors: 0,
        }
    }

    /// Take every whole frame waiting (at most [`HARNESS_HEALTH_MAX_BYTES`] bytes).
    fn drain(&mut self) {
        let mut budget = HARNESS_HEALTH_MAX_BYTES;
        let mut chunk = [0_u8; 32];
        while budget > 0 {
            match self.rx.read_ready() {
                Ok(true) => {}
                Ok(false) => break,
                Err(_) => {
                    self.uart_errors = self.uart_errors.wrapping_add(1);
                    break;
                }
            }
            let want = chunk.len().min(budget);
            let n = match self.rx.read(chunk.get_mut(..want).unwrap_or_default()) {
                Ok(0) => break,
                Ok(n) => n.min(want),
                Err(_) => {
                    self.uart_errors = self.uart_errors.wrapping_add(1);
                    break;
                }
            };
            budget = budget.saturating_sub(n);
            for &b in chunk.get(..n).unwrap_or_default() {
                if let Some(LinkFrame::Frame { msg, .. }) = self.decoder.push(b) {
                    self.latest = Some(msg);
                    self.frames = self.frames.wrapping_add(1);
                }
            }
        }
    }
}

impl<N: Sensors, R: Read + ReadReady> Sensors for HarnessHealth<N, R> {
    fn imu(&mut self, now_us: u64) -> Option<ImuSample> {
        self.inner.imu(now_us)
    }

    fn pressure_pa(&mut self, now_us: u64) -> Option<f32> {
        self.inner.pressure_pa(now_us)
    }

    fn dvl(&mut self, now_us: u64) -> Option<DvlFix> {
        self.inner.dvl(now_us)
    }

    /// The latest reading the host sent; the depth is left to the App (its estimate), as a
    /// board's reading leaves it.
    fn health(&mut self, _now_us: u64) -> Option<HealthSample> {
        self.drain();
        self.latest.map(|s| HealthSample { depth_m: None, ..s })
    }

    fn own_sensors(&self) -> bool {
        self.inner.own_sensors()
    }

    fn faults(&self) -> u16 {
        self.inner.faults()
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;
    use crate::harness::seal;
    use crate::protocol::MAX_FRAME_LEN;
    use crate::sensors::NoSensors;
    use std::collections::VecDeque;

    #[derive(Default)]
    struct Rx(VecDeque<u8>);

    impl embedded_io::ErrorType for Rx {
        type Error = core::convert::Infallible;
    }

    impl Read for Rx {
        fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
            let n = buf.len().min(self.0.len());
            for (b, x) in buf.iter_mut().zip(self.0.drain(..n)) {
                *b = x;
            }
            Ok(n)
        }
    }

    impl ReadReady for Rx {
        fn read_ready(&mut self) -> Result<bool, Self::Error> {
            Ok(!self.0.is_empty())
        }
    }

    fn frame(seq: u16, s: &HealthSample) -> Vec<u8> {
        let mut out = [0u8; MAX_FRAME_LEN];
        seal(seq, s, &mut out).unwrap().to_vec()
    }

    #[test]
    fn the_latest_frame_is_the_reading_and_a_corrupted_one_changes_nothing() {
        let mut h = HarnessHealth::new(NoSensors, Rx::default());
        assert_eq!(h.health(0), None);
        let dry = HealthSample {
            volt_pin_v: Some(1.5),
            curr_pin_v: Some(0.4),
            depth_m: Some(3.0),
            ..HealthSample::default()
        };
        let wet = HealthSample {
            leak_wet: true,
            ..dry
        };
        h.rx.0.extend(frame(0, &dry));
        h.rx.0.extend(frame(1, &wet));
        let got = h.health(20_000).unwrap();
        assert!(got.leak_wet);
        assert_eq!(got.volt_pin_v, Some(1.5));
        // The depth is the App's.
        assert_eq!(got.depth_m, None);
        assert_eq!(h.frames, 2);
        // A frame with a byte changed: dropped, the reading stays.
        let mut bad = frame(2, &dry);
        bad[5] ^= 0x10;
        h.rx.0.extend(bad);
        assert!(h.health(40_000).unwrap().leak_wet);
        assert_eq!(h.frames, 2);
        // Nothing new: the previous reading.
        assert!(h.health(60_000).unwrap().leak_wet);
        assert!(!h.own_sensors());
    }

    #[test]
    fn the_frames_are_the_harness_frames() {
        assert_eq!(HEALTH_FRAME_VERSION, crate::harness::HARNESS_VERSION);
    }

    #[test]
    fn one_reading_takes_a_bounded_number_of_bytes() {
        let mut h = HarnessHealth::new(NoSensors, Rx::default());
        h.rx.0.extend(core::iter::repeat_n(0x55, 1000));
        assert_eq!(h.health(0), None);
        assert_eq!(h.rx.0.len(), 1000 - HARNESS_HEALTH_MAX_BYTES);
    }
}
