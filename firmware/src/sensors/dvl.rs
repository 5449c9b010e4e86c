//! The DVL on a vehicle UART (the onboard layout): a Water Linked DVL A50 / A125 in its
//! serial protocol (`wrz` velocity reports, 115200 8N1 by default).
//!
//! [`DvlPort`] drains the UART without blocking, assembles lines, checks each line's CRC-8
//! and fields (`sensor_drivers::a50`), and admits a velocity report through the
//! validity / figure-of-merit gate. An admitted report becomes the estimator's
//! [`DvlFix`] exactly as a fix from the tether does: surge and sway in body axes (the A50's
//! vehicle frame is x forward, y starboard, z down, the body's), the figure of merit as the
//! standard deviation, and the time of validity in the vehicle's clock: the line's arrival
//! less the DVL's own latency (time of transmission - time of validity, both on the DVL's
//! clock) and the line's time on the wire. A refused report (no bottom lock, poor figure of
//! merit, bad checksum, malformed) gives no fix: the estimator sees a DVL gap, as in a
//! dropout, and the refusal is counted in [`DvlStats`].
//!
//! [`WithDvl`] adds the port to any [`Sensors`].

use super::Sensors;
use controller_core::nav::{DvlFix, ImuSample};
use embedded_io::{Read, ReadReady};
/// The A50 protocol (parser, CRC-8, gate), for the simulator's DVL that speaks it.
pub use sensor_drivers::a50;
use sensor_drivers::a50::{FrameError, Refusal, Report, VelocityGate};
use sensor_drivers::line::LineBuffer;

/// Longest line kept (bytes): a `wrz` report with a full covariance is under 200.
pub const DVL_LINE_MAX: usize = 256;
/// Most bytes taken from the UART per poll: two seconds of reports at 15 Hz, so that a
/// backlog cannot hold the loop.
pub const DVL_MAX_BYTES_PER_POLL: usize = 512;
/// Smallest standard deviation handed to the estimator (m/s): the report prints the figure
/// of merit to 1 mm/s, and 0.000 occurs.
pub const DVL_MIN_STD_M_S: f32 = 1e-3;

/// What the port did with the DVL's lines.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DvlStats {
    /// Velocity reports admitted to the estimator.
    pub accepted: u32,
    /// Lines refused for their CRC-8.
    pub bad_checksum: u32,
    /// Lines refused for their framing or fields (no `wr`, no checksum, a malformed or
    /// out-of-range field, a transmission before its validity or more than
    /// `a50::MAX_LATENCY_US` after it), or reports that contradict themselves
    /// (`a50::Refusal::Inconsistent`: an asymmetric covariance, a negative variance or
    /// valid altitude).
    pub malformed: u32,
    /// Velocity reports marked invalid (no bottom lock).
    pub no_lock: u32,
    /// Velocity reports with a figure of merit above the gate's.
    pub poor_fom: u32,
    /// Lines longer than [`DVL_LINE_MAX`], dropped.
    pub overflows: u32,
    /// Other reports (`wru`, `wrp`, ...), checksum right, not used.
    pub other: u32,
    /// UART read errors.
    pub uart_errors: u32,
}

impl DvlStats {
    /// Every refused line or report.
    pub fn refused(&self) -> u32 {
        self.bad_checksum
            .saturating_add(self.malformed)
            .saturating_add(self.no_lock)
            .saturating_add(self.poor_fom)
            .saturating_add(self.overflows)
    }
}

/// Bytes read from the UART at a time.
const CHUNK: usize = 64;

/// A DVL on a UART.
pub struct DvlPort<U> {
    uart: U,
    line: LineBuffer<DVL_LINE_MAX>,
    gate: VelocityGate,
    wire_us_per_byte: u32,
    stats: DvlStats,
    /// Bytes read from the UART and not yet taken into a line (a poll that stops at a line's
    /// end leaves the rest here for the next).
    chunk: [u8; CHUNK],
    chunk_at: usize,
    chunk_len: usize,
    max_bytes_per_poll: usize,
    max_lines_per_poll: usize,
}

impl<U: Read + ReadReady> DvlPort<U> {
    /// A port on `uart`; `gate` admits reports; `wire_us_per_byte` is one byte's time on the
    /// wire (87 at 115200 8N1; 0 for an in-memory link).
    pub fn new(uart: U, gate: VelocityGate, wire_us_per_byte: u32) -> Self {
        Self {
            uart,
            line: LineBuffer::new(),
            gate,
            wire_us_per_byte,
            stats: DvlStats::default(),
            chunk: [0; CHUNK],
            chunk_at: 0,
            chunk_len: 0,
            max_bytes_per_poll: DVL_MAX_BYTES_PER_POLL,
            max_lines_per_poll: usize::MAX,
        }
    }

    /// The port with at most `max_bytes` taken and `max_lines` lines ended (parsed) per
    /// [`Self::poll`] (at least one of each): bounds a poll's time on a small MCU (the node
    /// parses one line a pass). The defaults: [`DVL_MAX_BYTES_PER_POLL`], every line.
    pub fn with_poll_limits(mut self, max_bytes: usize, max_lines: usize) -> Self {
        self.max_bytes_per_poll = max_bytes.max(1);
        self.max_lines_per_poll = max_lines.max(1);
        self
    }

    /// The counts so far.
    pub fn stats(&self) -> DvlStats {
        DvlStats {
            overflows: self.line.overflows,
            ..self.stats
        }
    }

    /// The UART (to feed it in a simulation, or to reconfigure it).
    pub fn uart_mut(&mut self) -> &mut U {
        &mut self.uart
    }

    /// Drain what the UART holds (at most [`DVL_MAX_BYTES_PER_POLL`], or the limits of
    /// [`Self::with_poll_limits`]) at `now_us`; the newest admitted report of those lines as
    /// a fix, else `None`.
    pub fn poll(&mut self, now_us: u64) -> Option<DvlFix> {
        let mut newest = None;
        let mut budget = self.max_bytes_per_poll;
        let mut lines = self.max_lines_per_poll;
        while budget > 0 && lines > 0 {
            if self.chunk_at >= self.chunk_len && !self.refill(budget) {
                break;
            }
            let Some(&b) = self.chunk.get(self.chunk_at) else {
                break;
            };
            self.chunk_at += 1;
            budget -= 1;
            if let Some(judged) = self.on_byte(b, now_us) {
                lines -= 1;
                if judged.is_some() {
                    newest = judged;
                }
            }
        }
        newest
    }

    /// Read at most `want` bytes (and [`CHUNK`]) into the chunk; `false` when none came.
    fn refill(&mut self, want: usize) -> bool {
        (self.chunk_at, self.chunk_len) = (0, 0);
        match self.uart.read_ready() {
            Ok(true) => {}
            Ok(false) => return false,
            Err(_) => {
                self.stats.uart_errors = self.stats.uart_errors.saturating_add(1);
                self.line.clear();
                return false;
            }
        }
        let want = want.min(CHUNK);
        match self
            .uart
            .read(self.chunk.get_mut(..want).unwrap_or_default())
        {
            Ok(0) => false,
            Ok(n) => {
                self.chunk_len = n.min(want);
                true
            }
            Err(_) => {
                self.stats.uart_errors = self.stats.uart_errors.saturating_add(1);
                self.line.clear();
                false
            }
        }
    }

    /// Take one byte; `Some` when it ended a line, with the fix when the line was an
    /// admitted report.
    fn on_byte(&mut self, byte: u8, now_us: u64) -> Option<Option<DvlFix>> {
        let line = self.line.push(byte)?;
        let wire_us = u64::from(self.wire_us_per_byte).saturating_mul(line.len() as u64 + 2);
        Some(judge(line, &self.gate, &mut self.stats, wire_us, now_us))
    }
}

/// A line judged and counted in `stats`: an admitted report's fix, stamped with its time of
/// validity on the clock of `now_us` (the line ended then, after `wire_us` on the wire).
fn judge(
    line: &[u8],
    gate: &VelocityGate,
    stats: &mut DvlStats,
    wire_us: u64,
    now_us: u64,
) -> Option<DvlFix> {
    let bump = |c: &mut u32| *c = c.saturating_add(1);
    let report = match a50::parse(line) {
        Ok(Report::Velocity(v)) => v,
        Ok(_) => {
            bump(&mut stats.other);
            return None;
        }
        Err(FrameError::Checksum { .. }) => {
            bump(&mut stats.bad_checksum);
            return None;
        }
        Err(_) => {
            bump(&mut stats.malformed);
            return None;
        }
    };
    let admitted = match gate.admit(&report) {
        Ok(r) => r,
        Err(Refusal::NoBottomLock) => {
            bump(&mut stats.no_lock);
            return None;
        }
        Err(Refusal::PoorFigureOfMerit { .. }) => {
            bump(&mut stats.poor_fom);
            return None;
        }
        Err(Refusal::Inconsistent) => {
            bump(&mut stats.malformed);
            return None;
        }
    };
    // At most `a50::MAX_LATENCY_US` (checked by the parser).
    let latency_us = admitted
        .time_of_transmission_us
        .saturating_sub(admitted.time_of_validity_us);
    bump(&mut stats.accepted);
    let [vx, vy, _] = admitted.velocity_m_s;
    Some(DvlFix {
        t_us: now_us.saturating_sub(latency_us.saturating_add(wire_us)),
        velocity_m_s: [vx, vy],
        std_m_s: admitted.fom_m_s.max(DVL_MIN_STD_M_S),
    })
}

/// Sensors `N` plus a DVL on a UART.
pub struct WithDvl<N, U> {
    /// The other sensors.
    pub inner: N,
    /// The DVL.
    pub dvl: DvlPort<U>,
}

impl<N: Sensors, U: Read + ReadReady> Sensors for WithDvl<N, U> {
    fn imu(&mut self, now_us: u64) -> Option<ImuSample> {
        self.inner.imu(now_us)
    }

    fn pressure_pa(&mut self, now_us: u64) -> Option<f32> {
        self.inner.pressure_pa(now_us)
    }

    fn dvl(&mut self, now_us: u64) -> Option<DvlFix> {
        self.dvl.poll(now_us)
    }

    fn dvl_refused(&self) -> u32 {
        self.dvl.stats().refused()
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
    use core::convert::Infallible;

    /// A UART holding the bytes given, read in pieces of at most `piece` bytes.
    struct Uart {
        bytes: std::collections::VecDeque<u8>,
        piece: usize,
    }

    impl Uart {
        fn new(text: &[u8], piece: usize) -> Self {
            Self {
                bytes: text.iter().copied().collect(),
                piece,
            }
        }
    }

    impl embedded_io::ErrorType for Uart {
        type Error = Infallible;
    }

    impl Read for Uart {
        fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
            let n = buf.len().min(self.bytes.len()).min(self.piece);
            for (b, x) in buf.iter_mut().zip(self.bytes.drain(..n)) {
                *b = x;
            }
            Ok(n)
        }
    }

    impl ReadReady for Uart {
        fn read_ready(&mut self) -> Result<bool, Infallible> {
            Ok(!self.bytes.is_empty())
        }
    }

    fn wrz(body: &str) -> String {
        let covered = format!("wrz,{body}");
        format!(
            "{covered}*{:02x}\r\n",
            a50::CRC8.checksum(covered.as_bytes())
        )
    }

    /// A report with lock, 0.01 m/s figure of merit, 50 ms between its time of validity and
    /// its transmission.
    const GOOD: &str = "0.250,-0.100,0.010,y,3.20,0.010,1e-4;0;0;0;1e-4;0;0;0;1e-4,1767225600000000,1767225600050000,200.00,0";

    #[test]
    fn an_admitted_report_is_the_estimators_dvl_fix() {
        let line = wrz(GOOD);
        for piece in [1, 7, 64] {
            let mut port = DvlPort::new(
                Uart::new(line.as_bytes(), piece),
                VelocityGate::default(),
                87,
            );
            let fix = port.poll(10_000_000).unwrap();
            // Arrival less the DVL's 50 ms and the line's time on the wire (87 us a byte).
            let wire_us = 87 * line.len() as u64;
            assert_eq!(fix.t_us, 10_000_000 - 50_000 - wire_us);
            assert_eq!(fix.velocity_m_s, [0.250, -0.100]);
            assert_eq!(fix.std_m_s, 0.010);
            assert_eq!(port.stats().accepted, 1);
            assert_eq!(port.stats().refused(), 0);
        }
    }

    #[test]
    fn refused_reports_are_a_gap_and_counted() {
        let mut text = String::new();
        // No bottom lock, as the protocol page's invalid example.
        text += &wrz("0.000,0.000,0.000,n,-1.00,2.707,0;0;0;0;0;0;0;0;0,1767225600000000,1767225600000000,1075.51,1");
        // A figure of merit over the gate's 0.1 m/s.
        text += &wrz("0.250,-0.100,0.010,y,3.20,0.300,0;0;0;0;0;0;0;0;0,1767225600000000,1767225600000000,200.00,0");
        // A bad checksum: the good report with one digit changed.
        let mut bad = wrz(GOOD);
        bad.replace_range(5..6, "3");
        text += &bad;
        // Malformed: a field missing (checksum right).
        text += &wrz("0.250,-0.100,0.010,y,3.20,0.010,0;0;0;0;0;0;0;0;0,1767225600000000,1767225600000000,200.00");
        // Transmitted before its validity: mis-stamped.
        text += &wrz("0.250,-0.100,0.010,y,3.20,0.010,0;0;0;0;0;0;0;0;0,1767225600050000,1767225600000000,200.00,0");
        // A transducer report: not used.
        text += "wru,0,0.070,1.10,-40,-95*9c\r\n";
        // Garbage longer than the line buffer.
        text += &"x".repeat(DVL_LINE_MAX + 10);
        text += "\r\n";
        let mut port = DvlPort::new(Uart::new(text.as_bytes(), 64), VelocityGate::default(), 0);
        while !port.uart_mut().bytes.is_empty() {
            assert_eq!(port.poll(5_000_000), None);
        }
        let s = port.stats();
        assert_eq!(
            s,
            DvlStats {
                accepted: 0,
                bad_checksum: 1,
                malformed: 2,
                no_lock: 1,
                poor_fom: 1,
                overflows: 1,
                other: 1,
                uart_errors: 0,
            }
        );
        assert_eq!(s.refused(), 6);
        // The port goes on: the next good report is admitted.
        port.uart_mut().bytes.extend(wrz(GOOD).as_bytes());
        assert!(port.poll(6_000_000).is_some());
    }

    #[test]
    fn one_poll_takes_a_bounded_number_of_bytes_and_keeps_the_newest() {
        let mut text = String::new();
        for i in 0..20 {
            text += &wrz(&format!(
                "0.{i:03},0.000,0.000,y,3.20,0.010,0;0;0;0;0;0;0;0;0,1,1,200.00,0"
            ));
        }
        let mut port = DvlPort::new(Uart::new(text.as_bytes(), 64), VelocityGate::default(), 0);
        let first = port.poll(1_000).unwrap();
        assert!(port.uart_mut().bytes.len() == text.len() - DVL_MAX_BYTES_PER_POLL);
        let mut last = first;
        while let Some(f) = port.poll(2_000) {
            last = f;
        }
        assert_eq!(last.velocity_m_s[0], 0.019);
        assert_eq!(port.stats().accepted, 20);
    }

    #[test]
    fn a_port_limited_to_one_line_a_poll_keeps_the_rest_for_the_next() {
        // Three lines in one read: the first poll ends at the first line's end.
        let mut text = wrz(GOOD);
        text += "garbage*00\r\n";
        text += &wrz(GOOD);
        let mut port = DvlPort::new(Uart::new(text.as_bytes(), 512), VelocityGate::default(), 0)
            .with_poll_limits(64, 1);
        let mut polls = Vec::new();
        for _ in 0..20 {
            let before = port.stats();
            let fix = port.poll(1_000_000);
            let after = port.stats();
            let lines = (after.accepted + after.refused()) - (before.accepted + before.refused());
            assert!(lines <= 1, "{before:?} -> {after:?}");
            polls.push(fix.is_some());
        }
        let s = port.stats();
        assert_eq!((s.accepted, s.bad_checksum + s.malformed), (2, 1), "{s:?}");
        assert_eq!(polls.iter().filter(|&&f| f).count(), 2);
        // 64 bytes at most a poll: a line of 150+ bytes ends at the third poll.
        let first = polls.iter().position(|&f| f).unwrap();
        assert_eq!(first, wrz(GOOD).len().div_ceil(64) - 1);
    }

    #[test]
    fn with_dvl_keeps_the_inner_sensors() {
        let mut s = WithDvl {
            inner: super::super::NoSensors,
            dvl: DvlPort::new(
                Uart::new(wrz(GOOD).as_bytes(), 64),
                VelocityGate::default(),
                0,
            ),
        };
        assert!(!s.own_sensors());
        assert_eq!(s.imu(0), None);
        assert!(s.dvl(1_000_000).is_some());
        assert_eq!(s.dvl(1_000_000), None);
    }
}
