//! The board's instruments in the loop pass: the DVL's lines on its UART and the health
//! inputs' frames, as the emulated board and a real board receive them.
//!
//! - `drv.a50_wrz` / `drv.a50_wrp`: `sensor_drivers::a50::parse` of one velocity report as
//!   host-sim's DVL prints it (velocities, figure of merit and covariance changing per call),
//!   and of one dead-reckoning report (the protocol page's example with its time changing).
//! - `loop.onboard_instruments_3d`: the pass of `loop.onboard_3d` with the DVL on a UART
//!   (`WithDvl`, a whole `wrz` line arriving before every 5th pass: 10 Hz, the A50's rate at a
//!   few metres' altitude) instead of its velocity over the tether, and a health frame on
//!   the harness UART before every pass (`HarnessHealth`: the emulated board's power-sense,
//!   leak and enclosure readings, with the health checks they feed). Every 50th pass has a
//!   DVL line, a health frame, a heartbeat, a compass heading and a USBL fix at once: the
//!   `max`.

use crate::bench::{Bench, Platform, CALLS};
use crate::onboard_bench::{run_onboard_with, BenchBusSensors};
use core::cell::RefCell;
use core::convert::Infallible;
use core::fmt::Write as _;
use firmware::harness::seal;
use firmware::health::HarnessHealth;
use firmware::protocol::{HealthSample, MAX_FRAME_LEN};
use firmware::sensors::dvl::a50::{self, VelocityGate};
use firmware::sensors::dvl::{DvlPort, WithDvl};

/// Bytes waiting on an emulated UART, shared between the bench (which queues them) and the
/// App's sensors (which read them).
pub(crate) struct ByteQueue {
    buf: [u8; 512],
    len: usize,
    pos: usize,
}

impl ByteQueue {
    pub(crate) const fn new() -> Self {
        Self {
            buf: [0; 512],
            len: 0,
            pos: 0,
        }
    }

    /// Add `bytes` behind those not read yet (dropped past the buffer's end).
    pub(crate) fn push(&mut self, bytes: &[u8]) {
        if self.pos >= self.len {
            (self.pos, self.len) = (0, 0);
        }
        let end = (self.len + bytes.len()).min(self.buf.len());
        if let (Some(d), Some(s)) = (self.buf.get_mut(self.len..end), bytes.get(..end - self.len)) {
            d.copy_from_slice(s);
        }
        self.len = end;
    }
}

/// A UART reading a [`ByteQueue`].
pub(crate) struct RamUart<'a>(pub(crate) &'a RefCell<ByteQueue>);

impl embedded_io::ErrorType for RamUart<'_> {
    type Error = Infallible;
}

impl embedded_io::Read for RamUart<'_> {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let Ok(mut q) = self.0.try_borrow_mut() else {
            return Ok(0);
        };
        let q = &mut *q;
        let src = q.buf.get(q.pos..q.len).unwrap_or(&[]);
        let n = src.len().min(buf.len());
        if let (Some(d), Some(s)) = (buf.get_mut(..n), src.get(..n)) {
            d.copy_from_slice(s);
        }
        q.pos += n;
        Ok(n)
    }
}

impl embedded_io::ReadReady for RamUart<'_> {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(self.0.try_borrow().is_ok_and(|q| q.pos < q.len))
    }
}

/// One line of text in a fixed buffer.
#[derive(Clone)]
pub(crate) struct Line {
    buf: [u8; 200],
    len: usize,
}

impl Line {
    const fn new() -> Self {
        Self {
            buf: [0; 200],
            len: 0,
        }
    }

    pub(crate) fn bytes(&self) -> &[u8] {
        self.buf.get(..self.len).unwrap_or(&[])
    }
}

impl core::fmt::Write for Line {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        let end = self.len + s.len();
        let dst = self.buf.get_mut(self.len..end).ok_or(core::fmt::Error)?;
        dst.copy_from_slice(s.as_bytes());
        self.len = end;
        Ok(())
    }
}

/// A fixed-point value printed with `decimals` digits after the point (integers only: no
/// float formatting in the image).
struct Fixed(i32, u32);

impl core::fmt::Display for Fixed {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let scale = 10_u32.pow(self.1);
        let sign = if self.0 < 0 { "-" } else { "" };
        let a = self.0.unsigned_abs();
        write!(
            f,
            "{sign}{}.{:0w$}",
            a / scale,
            a % scale,
            w = self.1 as usize
        )
    }
}

/// The Unix time (us) host-sim's DVL stamps its reports from.
const EPOCH_US: u64 = 1_767_225_600_000_000;

/// A `wrz` line as host-sim's DVL prints it for pass `i` at `t_us` (a vehicle holding still:
/// a few mm/s), with its CRC-8 and CR LF.
pub(crate) fn wrz_line(i: u32, t_us: u64) -> Line {
    let mut body = Line::new();
    let k = (i % 97) as i32;
    let fom_mm = 5 + (i % 7) as i32;
    let var = fom_mm * fom_mm;
    let tov = EPOCH_US + t_us;
    let _ = write!(
        body,
        "wrz,{},{},0.000,y,{},{},{}.{:03}e-5;0;0;0;{}.{:03}e-5;0;0;0;{}.{:03}e-5,{tov},{tov},100.00,0",
        Fixed(k % 5 - 2, 3),
        Fixed(2 - k % 3, 3),
        Fixed(320 + k, 2),
        Fixed(fom_mm, 3),
        var / 10,
        (var % 10) * 100,
        var / 10,
        (var % 10) * 100,
        var / 10,
        (var % 10) * 100,
    );
    seal_line(&body)
}

/// `body`, `*`, its CRC-8 in two hex digits, CR LF.
fn seal_line(body: &Line) -> Line {
    let mut line = body.clone();
    let _ = write!(line, "*{:02x}\r\n", a50::CRC8.checksum(body.bytes()));
    line
}

/// The protocol page's `wrp` example with its time stamp moved by `i` ms.
fn wrp_line(i: u32) -> Line {
    let mut body = Line::new();
    let ms = 809 + i;
    let _ = write!(
        body,
        "wrp,{}.{:03},0.41,0.15,1.23,0.4,53.9,13.0,19.3,0",
        49_056 + ms / 1000,
        ms % 1000
    );
    seal_line(&body)
}

/// The health inputs the host sends for pass `i` (a battery near 15.6 V drawing a few
/// amperes, dry, the enclosure at 1 bar and 25 degC).
fn health_sample(i: u32) -> HealthSample {
    let wobble = (i % 11) as f32 * 0.001;
    HealthSample {
        volt_pin_v: Some(1.412 + wobble),
        curr_pin_v: Some(0.330 + wobble),
        leak_wet: false,
        enclosure_pa: Some(101_325.0),
        enclosure_c: Some(25.0),
        depth_m: None,
    }
}

/// One DVL byte's time on the wire at 115,200 Bd 8N1 (us).
const DVL_US_PER_BYTE: u32 = 87;

/// Run the parser items and `loop.onboard_instruments_3d`.
pub fn run_instruments<P: Platform>(b: &Bench<'_, P>, p: &P) {
    b.run(
        "drv.a50_wrz",
        CALLS,
        |i| wrz_line(i, u64::from(i) * 100_000),
        |l| a50::parse(l.bytes()).is_ok(),
    );
    b.run("drv.a50_wrp", CALLS, wrp_line, |l| {
        a50::parse(l.bytes()).is_ok()
    });
    let dvl_q = RefCell::new(ByteQueue::new());
    let health_q = RefCell::new(ByteQueue::new());
    let mut seq = 0_u16;
    let mut frame = [0_u8; MAX_FRAME_LEN];
    let (mut dvl_sent, mut health_sent) = (0_u32, 0_u32);
    run_onboard_with(
        b,
        p,
        "loop.onboard_instruments_3d",
        false,
        |bus: BenchBusSensors| {
            HarnessHealth::new(
                WithDvl {
                    inner: bus,
                    dvl: DvlPort::new(RamUart(&dvl_q), VelocityGate::default(), DVL_US_PER_BYTE),
                },
                RamUart(&health_q),
            )
        },
        |_app, i, t_us| {
            if i.is_multiple_of(5) {
                if let Ok(mut q) = dvl_q.try_borrow_mut() {
                    q.push(wrz_line(i, t_us.saturating_sub(30_000)).bytes());
                    dvl_sent += 1;
                }
            }
            seq = seq.wrapping_add(1);
            if let (Ok(f), Ok(mut q)) = (
                seal(seq, &health_sample(i), &mut frame),
                health_q.try_borrow_mut(),
            ) {
                q.push(f);
                health_sent += 1;
            }
        },
    );
    p.print(format_args!(
        "INSTRUMENTS loop.onboard_instruments_3d: {dvl_sent} wrz lines and {health_sent} health frames sent"
    ));
}
