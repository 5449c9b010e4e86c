//! The two MCUs' surroundings in the topside layout: the virtual clock both read, the
//! node link's ends on the wire model, the node's sensors fed from the plant, and the
//! topside's PC tether when its PC is outside the simulation.

use anyhow::Result;
use controller_core::nav::ImuSample;
use firmware::Monotonic;
use protocol::Command;
use std::cell::{Cell, RefCell};
use std::collections::VecDeque;
use std::convert::Infallible;
use std::rc::Rc;

/// The virtual clock both MCUs read (us).
#[derive(Debug, Clone, Default)]
pub struct VClock(pub(super) Rc<Cell<u64>>);

impl Monotonic for VClock {
    fn now_us(&mut self) -> u64 {
        self.0.get()
    }
}

/// One end of the node link: `rx` is what the wire delivered, `tx` what the MCU wrote;
/// `read_log` keeps what the MCU read, for the harness's own decoding.
#[derive(Debug, Clone, Default)]
pub struct WirePort {
    pub(super) rx: Rc<RefCell<VecDeque<u8>>>,
    pub(super) tx: Rc<RefCell<Vec<u8>>>,
    pub(super) read_log: Rc<RefCell<Vec<u8>>>,
}

impl embedded_io::ErrorType for WirePort {
    type Error = Infallible;
}

impl embedded_io::Read for WirePort {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let mut q = self.rx.borrow_mut();
        let n = buf.len().min(q.len());
        let mut log = self.read_log.borrow_mut();
        for (b, x) in buf.iter_mut().zip(q.drain(..n)) {
            *b = x;
            log.push(x);
        }
        Ok(n)
    }
}

impl embedded_io::ReadReady for WirePort {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(!self.rx.borrow().is_empty())
    }
}

impl embedded_io::Write for WirePort {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        self.tx.borrow_mut().extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

impl embedded_io::WriteReady for WirePort {
    /// The UART's transmit FIFO takes the frame; the wire sends it at its rate.
    fn write_ready(&mut self) -> Result<bool, Infallible> {
        Ok(true)
    }
}

/// The node's IMU and pressure sensor: the plant's simulated readings, each available from
/// its time stamp on (a data-ready register: a read returns the latest conversion).
#[derive(Debug, Clone, Default)]
pub struct PlantSensors {
    pub(super) shared: Rc<RefCell<SensorFeed>>,
}

#[derive(Debug, Default)]
pub(super) struct SensorFeed {
    pub(super) imu: VecDeque<ImuSample>,
    pub(super) current_imu: Option<ImuSample>,
    pub(super) pressure: VecDeque<(u64, f32)>,
    /// The node's latest IMU read (us).
    pub(super) last_imu_read_us: Option<u64>,
    /// IMU reads, for the rate check.
    pub(super) imu_reads: u64,
}

impl firmware::Sensors for PlantSensors {
    fn imu(&mut self, now_us: u64) -> Option<ImuSample> {
        let mut f = self.shared.borrow_mut();
        while f.imu.front().is_some_and(|s| s.t_us <= now_us) {
            f.current_imu = f.imu.pop_front();
        }
        let s = f.current_imu?;
        f.last_imu_read_us = Some(now_us);
        f.imu_reads += 1;
        Some(ImuSample { t_us: now_us, ..s })
    }

    /// A new conversion since the last read, else none (the node counts each new one).
    fn pressure_pa(&mut self, now_us: u64) -> Option<f32> {
        let mut f = self.shared.borrow_mut();
        let mut latest = None;
        while f.pressure.front().is_some_and(|&(t, _)| t <= now_us) {
            latest = f.pressure.pop_front().map(|(_, p)| p);
        }
        latest
    }
}

/// The topside's PC tether when its PC is outside the simulation.
pub trait ExternalPc {
    /// The bytes for the topside's pass at `t_us`: `inputs` (the instruments' readings due
    /// now) framed, and what the PC sent since the previous pass.
    fn to_topside(&mut self, t_us: u64, inputs: &[Command]) -> Result<Vec<u8>>;
    /// What the topside wrote to its PC tether in a pass.
    fn topside_wrote(&mut self, bytes: &[u8]) -> Result<()>;
}
