//! The emulation harness of the paper's layout (`docs/deployment.md`, "Emulating
//! the topside layout"): how a host program drives the two emulated boards, the topside
//! (`topside-emu`, this crate) and the node (`node-emu`, crate `node-firmware`), each a QEMU
//! `netduinoplus2`.
//!
//! QEMU's timers run at emulated speed, not the host's, so the host is the one clock of the
//! emulation: each board has a harness UART on which the host sends a step, "your time is
//! now `t_us`", and the board answers with a report once it has run its loop at that time.
//! The step also tells how many bytes the host has delivered so far on the board's other
//! UARTs (the node link, the tether): the board waits for them before it runs, so what it
//! reads at `t_us` is exactly what the host sent before `t_us`, whatever order QEMU's two
//! sockets deliver in. The report tells how many bytes the board has written on them, so
//! the host reads exactly those before it moves time on. Runs are deterministic.
//!
//! - [`NodeStep`] (host -> node) also carries the sensors the plant gives the node: the IMU's
//!   angular rate and specific force at `t_us`, and a pressure; [`NodeReport`] (node -> host)
//!   the pulses the node applies after the step (the plant's thrust input, and the end of the
//!   sensor-to-pulse latency) and its status.
//! - [`TopsideStep`] / [`TopsideReport`]: the topside's clock. Its tether (USART1) and node
//!   link (USART2) carry today's bytes; the PC drives the tether as it drives any vehicle.
//!
//! The frames are the node link's (postcard + CRC-32 + COBS between zero delimiters, written
//! by the tether's own `protocol::encode_with_version`) with their own envelope version,
//! [`HARNESS_VERSION`]; [`HarnessDecoder`] is the node link's receiver for that version.
//! A step the board cannot take is answered with its [`HarnessRefusal`] and changes nothing.
//!
//! The passes themselves ([`node_pass`], [`topside_pass`]) are generic over the traits the
//! roles use (`embedded-hal`, `embedded-io`, [`Monotonic`], [`Sensors`]), so they run and are
//! tested on the host; the boards add only the UARTs.

use crate::app::{App, Monotonic};
use crate::node::Node;
use crate::node_link::LinkDecoder;
use crate::protocol::{EncodeError, MAX_FRAME_LEN};
use crate::sensors::{ImuSample, Sensors};
use crate::topside_link::{LinkSensors, LinkThruster, TopsideLink};
use core::cell::Cell;
use embedded_hal::pwm::SetDutyCycle;
use embedded_io::{ErrorType, Read, ReadReady, Write, WriteReady};
use serde::{Deserialize, Serialize};

/// Envelope version of the harness frames (the node link is 1, the tether 6): a frame of
/// the other links is never taken for a harness step.
pub const HARNESS_VERSION: u8 = 0x48;

/// At most this many loop passes at one step's time (each drains at most 64 bytes of the
/// node link, 128 of the topside's node link, the App's own budget of the tether).
pub const MAX_PASSES_PER_STEP: u32 = 32;

/// The receiver of harness frames of message `M`.
pub type HarnessDecoder<M> = LinkDecoder<M, HARNESS_VERSION>;

/// Encode a harness message as a frame (both delimiters included) into `out`.
pub fn seal<'a, M: Serialize>(
    seq: u16,
    msg: &M,
    out: &'a mut [u8; MAX_FRAME_LEN],
) -> Result<&'a [u8], EncodeError> {
    crate::protocol::encode_with_version(HARNESS_VERSION, 0, seq, msg, out)
}

/// One IMU sample the plant gives the node, body axes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HarnessImu {
    /// Angular rate `[p, q, r]`, rad/s.
    pub gyro_rad_s: [f32; 3],
    /// Specific force, m/s^2 (about `[0, 0, -9.81]` at rest, z down).
    pub accel_m_s2: [f32; 3],
}

/// Host -> emulated node: run the node at `t_us` with these sensors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct NodeStep {
    /// The node's time, microseconds since its boot; never goes back.
    pub t_us: u64,
    /// Bytes the host has delivered on the node link (USART1) since the node's boot.
    pub link_rx_bytes: u32,
    /// The IMU sample read at `t_us` if the node samples then (`None`: the IMU does not
    /// answer). The node samples on its own schedule (400 Hz); a sample it does not read is
    /// replaced by the next step's.
    pub imu: Option<HarnessImu>,
    /// A new pressure reading, Pa (`None`: no new one). The node reads it once a link period.
    pub pressure_pa: Option<f32>,
}

/// Emulated node -> host: what the node applies after a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct NodeReport {
    /// The step's time (0 in the hello the node sends at boot).
    pub t_us: u64,
    /// Pulse widths on the three ESC outputs, microseconds (`F1x`, `F2x`, `F3z`).
    pub pulse_us: [u16; 3],
    /// The node's status bits (`node_link::status`).
    pub status: u8,
    /// Downlink frames the node has applied (wraps).
    pub accepted: u16,
    /// Bytes the node has received on the node link since boot.
    pub link_rx_bytes: u32,
    /// Bytes the node has written on the node link since boot.
    pub link_tx_bytes: u32,
    /// The step was not taken, and why (nothing changed).
    pub refused: Option<HarnessRefusal>,
}

/// Host -> emulated topside: run the topside at `t_us`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct TopsideStep {
    /// The topside's time, microseconds since its boot; never goes back.
    pub t_us: u64,
    /// Bytes the host has delivered on the tether (USART1) since the topside's boot.
    pub tether_rx_bytes: u32,
    /// Bytes the host has delivered on the node link (USART2) since the topside's boot.
    pub link_rx_bytes: u32,
}

/// Emulated topside -> host, after a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct TopsideReport {
    /// The step's time (0 in the hello the topside sends at boot).
    pub t_us: u64,
    /// Bytes received on the tether since boot.
    pub tether_rx_bytes: u32,
    /// Bytes written on the tether since boot.
    pub tether_tx_bytes: u32,
    /// Bytes received on the node link since boot.
    pub link_rx_bytes: u32,
    /// Bytes written on the node link since boot.
    pub link_tx_bytes: u32,
    /// Control steps run on an accepted uplink since boot (`App::step_now`).
    pub uplink_steps: u32,
    /// The step was not taken, and why (nothing changed).
    pub refused: Option<HarnessRefusal>,
}

/// Why a board did not take a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum HarnessRefusal {
    /// `t_us` is before the board's time: time never goes back.
    TimeBack,
    /// Fewer bytes arrived on a UART than the step says were delivered, within the board's
    /// wait. More bytes between two steps than the UART's receive ring holds end here too
    /// (1,024 bytes on each USART1, 256 on the topside's node link): the board counts the
    /// bytes it lost.
    BytesMissing,
}

/// The board's clock when the host is the clock: the time of the latest step; `ticks` (the
/// App's work measure) from the board's own counter (TIM2: one tick an instruction under
/// QEMU `-icount shift=0`).
pub struct HostClock<'a, C> {
    now_us: &'a Cell<u64>,
    counter: C,
}

impl<'a, C> HostClock<'a, C> {
    /// A clock reading `now_us`, its ticks from `counter`.
    pub fn new(now_us: &'a Cell<u64>, counter: C) -> Self {
        Self { now_us, counter }
    }
}

impl<C: Monotonic> Monotonic for HostClock<'_, C> {
    fn now_us(&mut self) -> u64 {
        self.now_us.get()
    }

    fn ticks(&mut self) -> u32 {
        self.counter.ticks()
    }
}

/// The latest sensors of the steps, for the node's [`Sensors`].
#[derive(Debug, Default)]
pub struct HarnessInputs {
    imu: Cell<Option<HarnessImu>>,
    pressure_pa: Cell<Option<f32>>,
}

impl HarnessInputs {
    /// No sample yet.
    pub const fn new() -> Self {
        Self {
            imu: Cell::new(None),
            pressure_pa: Cell::new(None),
        }
    }

    /// The node's sensors, reading these inputs.
    pub fn sensors(&self) -> HarnessSensors<'_> {
        HarnessSensors { inputs: self }
    }
}

/// The node's sensors on the emulated board: what the host's steps gave. A sample is read
/// once: a step without one, then an IMU read, is an IMU that did not answer.
pub struct HarnessSensors<'a> {
    inputs: &'a HarnessInputs,
}

impl Sensors for HarnessSensors<'_> {
    fn imu(&mut self, now_us: u64) -> Option<ImuSample> {
        self.inputs.imu.take().map(|s| ImuSample {
            t_us: now_us,
            gyro_rad_s: s.gyro_rad_s,
            accel_m_s2: s.accel_m_s2,
        })
    }

    fn pressure_pa(&mut self, _now_us: u64) -> Option<f32> {
        self.inputs.pressure_pa.take()
    }
}

/// A port that counts the bytes read from it and written to it (the harness's byte counts).
pub struct CountingPort<S> {
    inner: S,
    read: u32,
    written: u32,
}

impl<S> CountingPort<S> {
    /// Count on `inner`.
    pub const fn new(inner: S) -> Self {
        Self {
            inner,
            read: 0,
            written: 0,
        }
    }

    /// Bytes read so far (wrapping).
    pub fn read_bytes(&self) -> u32 {
        self.read
    }

    /// Bytes written so far (wrapping).
    pub fn written_bytes(&self) -> u32 {
        self.written
    }
}

impl<S: ErrorType> ErrorType for CountingPort<S> {
    type Error = S::Error;
}

impl<S: Read> Read for CountingPort<S> {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, S::Error> {
        let n = self.inner.read(buf)?;
        self.read = self.read.wrapping_add(n as u32);
        Ok(n)
    }
}

impl<S: ReadReady> ReadReady for CountingPort<S> {
    fn read_ready(&mut self) -> Result<bool, S::Error> {
        self.inner.read_ready()
    }
}

impl<S: Write> Write for CountingPort<S> {
    fn write(&mut self, buf: &[u8]) -> Result<usize, S::Error> {
        let n = self.inner.write(buf)?;
        self.written = self.written.wrapping_add(n as u32);
        Ok(n)
    }

    fn flush(&mut self) -> Result<(), S::Error> {
        self.inner.flush()
    }
}

impl<S: WriteReady> WriteReady for CountingPort<S> {
    fn write_ready(&mut self) -> Result<bool, S::Error> {
        self.inner.write_ready()
    }
}

/// `true` when `have` bytes cover `want` (wrapping counters, half a range apart at most).
pub fn arrived(have: u32, want: u32) -> bool {
    have.wrapping_sub(want) < 0x8000_0000
}

/// Run the node at a step's time: the sensors in, as many passes as the link's waiting
/// bytes need, and the report. `link_received` is what has arrived on the link port (read
/// plus waiting in its ring); the board waits for the step's count before it calls this.
pub fn node_pass<P, S, C, N>(
    node: &mut Node<P, CountingPort<S>, C, N>,
    now_us: &Cell<u64>,
    inputs: &HarnessInputs,
    step: &NodeStep,
    link_received: u32,
) -> NodeReport
where
    P: SetDutyCycle,
    S: Read + ReadReady + Write + WriteReady,
    C: Monotonic,
    N: Sensors,
{
    let refused = if step.t_us < now_us.get() {
        Some(HarnessRefusal::TimeBack)
    } else if !arrived(link_received, step.link_rx_bytes) {
        Some(HarnessRefusal::BytesMissing)
    } else {
        None
    };
    if refused.is_none() {
        now_us.set(step.t_us);
        inputs.imu.set(step.imu);
        inputs.pressure_pa.set(step.pressure_pa);
        for _ in 0..MAX_PASSES_PER_STEP {
            node.tick();
            if !node.parts_mut().1.read_ready().unwrap_or(false) {
                break;
            }
        }
    }
    let t = now_us.get();
    let (_, port, _, _) = node.parts_mut();
    let (rx, tx) = (port.read_bytes(), port.written_bytes());
    NodeReport {
        t_us: t,
        pulse_us: node.output_us(),
        status: node.status(t),
        accepted: node.counters().accepted,
        link_rx_bytes: rx,
        link_tx_bytes: tx,
        refused,
    }
}

/// The topside's App over the node link, as the boards build it.
pub type TopsideApp<'a, T, C> = App<LinkThruster<'a>, CountingPort<T>, C, LinkSensors<'a>>;

/// Run the topside at a step's time: the topside board's loop (`app.tick()`, an accepted
/// uplink runs `app.step_now()`, `link.send_if_due()`) until neither port has bytes
/// waiting, and the report. `tether_received` / `link_received`: what has arrived on each
/// port (read plus waiting); the board waits for the step's counts before it calls this.
/// `uplink_steps` counts the steps run on uplinks.
#[allow(clippy::too_many_arguments)]
pub fn topside_pass<T, L, C>(
    app: &mut TopsideApp<'_, T, C>,
    link: &mut TopsideLink<'_, CountingPort<L>>,
    now_us: &Cell<u64>,
    step: &TopsideStep,
    tether_received: u32,
    link_received: u32,
    uplink_steps: &mut u32,
) -> TopsideReport
where
    T: Read + ReadReady + Write + WriteReady,
    L: Read + ReadReady + Write + WriteReady,
    C: Monotonic,
{
    let refused = if step.t_us < now_us.get() {
        Some(HarnessRefusal::TimeBack)
    } else if !arrived(tether_received, step.tether_rx_bytes)
        || !arrived(link_received, step.link_rx_bytes)
    {
        Some(HarnessRefusal::BytesMissing)
    } else {
        None
    };
    if refused.is_none() {
        now_us.set(step.t_us);
        for _ in 0..MAX_PASSES_PER_STEP {
            app.tick();
            let now = app.now_us();
            let armed = app.autopilot().armed();
            if link.poll(now, armed) {
                app.step_now();
                *uplink_steps = uplink_steps.wrapping_add(1);
            }
            link.send_if_due(now, armed);
            let tether_waiting = app.parts_mut().1.read_ready().unwrap_or(false);
            let link_waiting = link.serial_mut().read_ready().unwrap_or(false);
            if !tether_waiting && !link_waiting {
                break;
            }
        }
    }
    let tether = app.parts_mut().1;
    let (tether_rx, tether_tx) = (tether.read_bytes(), tether.written_bytes());
    let port = link.serial_mut();
    TopsideReport {
        t_us: now_us.get(),
        tether_rx_bytes: tether_rx,
        tether_tx_bytes: tether_tx,
        link_rx_bytes: port.read_bytes(),
        link_tx_bytes: port.written_bytes(),
        uplink_steps: *uplink_steps,
        refused,
    }
}

#[cfg(target_os = "none")]
pub mod uart;

#[cfg(test)]
mod tests;
