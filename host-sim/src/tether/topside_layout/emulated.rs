//! The emulated roles of the topside layout: the `topside-emu` and `node-emu` images, each
//! in its own `qemu-system-arm -M netduinoplus2`, stepped through their harness UARTs
//! (`firmware::harness`, `docs/deployment.md`, "Emulating the topside layout").
//!
//! The host is the one clock: a [`NodeStep`] / [`TopsideStep`] gives a board its time, the
//! byte counts delivered on its other UARTs and (the node) the plant's IMU and pressure; the
//! board answers, once it has run its loop at that time, with its report, whose byte counts
//! say how many bytes to read from its other UARTs. Runs are deterministic, but for the
//! node's DVL UART (USART3): the simulated DVL's A50 reports are written to it before the
//! node's step and are not counted in it (as on the emulated onboard board), so a line
//! QEMU has not delivered by the step is read at the node's next one, 2.5 ms later.
//!
//! A pass steps only the boards that have something to do, as each exchange costs a round
//! trip to QEMU (milliseconds of wall time): the node at each of its IMU times (every
//! 2.5 ms: the node samples the IMU it is given at most once a step, and samples at 400 Hz)
//! and when node-link bytes reach it (a downlink is applied at the microsecond its last
//! byte arrives); the topside when an uplink's bytes reach it (its control step runs at the
//! microsecond the frame has arrived), every [`TOPSIDE_GRID_US`] (its telemetry, its
//! fallback period and failsafes), and at the node's next IMU time when the PC has bytes for
//! it (heartbeats and fixes wait up to 2.5 ms, so that they share an exchange time with the
//! node). The two boards of one pass run at the same time: both steps are sent before
//! either report is read.

use super::roles::{ControlView, NodePass, Roles, TopsidePass, NODE_IMU_PERIOD_US};
use crate::tether::qemu::{start_qemu_serials, LayoutElfs, QemuChild};
use anyhow::{anyhow, bail, Context, Result};
use controller_core::nav::{DvlFix, ImuSample};
use firmware::harness::{
    seal, HarnessDecoder, HarnessImu, NodeReport, NodeStep, TopsideReport, TopsideStep,
};
use firmware::node_link::{status, LinkFrame, NodeCounters};
use firmware::protocol::MAX_FRAME_LEN;
use firmware::topside_link::TopsideCounters;
use serde::de::DeserializeOwned;
use serde::Serialize;
use sim_world::sensors::DvlWire;
use std::collections::{BTreeSet, VecDeque};
use std::io::{BufReader, Read, Write};
use std::net::TcpStream;
use std::time::Duration;

/// The emulated topside runs its loop at least this often (us) without bytes to read.
pub const TOPSIDE_GRID_US: u64 = 10_000;

/// How long the host waits for a board's report or bytes before it calls the emulator hung.
pub const BOARD_TIMEOUT: Duration = Duration::from_secs(30);

/// A harness UART: steps out, reports in.
struct Harness {
    out: TcpStream,
    inp: BufReader<TcpStream>,
    seq: u16,
}

impl Harness {
    fn new(s: TcpStream) -> Result<Self> {
        Ok(Self {
            out: s.try_clone()?,
            inp: BufReader::new(s),
            seq: 0,
        })
    }

    fn send<M: Serialize>(&mut self, msg: &M) -> Result<()> {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let f = seal(self.seq, msg, &mut buf).map_err(|e| anyhow!("harness frame: {e:?}"))?;
        self.seq = self.seq.wrapping_add(1);
        self.out
            .write_all(f)
            .context("writing to the emulated board's harness UART")
    }

    fn recv<M: DeserializeOwned>(&mut self, d: &mut HarnessDecoder<M>, who: &str) -> Result<M> {
        let mut b = [0u8; 1];
        loop {
            match self.inp.read(&mut b) {
                Ok(1) => {}
                Ok(_) => bail!("the emulated {who} closed its harness UART (QEMU exited)"),
                Err(e) => {
                    return Err(e).with_context(|| {
                        format!(
                            "no report from the emulated {who} within {} s",
                            BOARD_TIMEOUT.as_secs()
                        )
                    })
                }
            }
            match d.push(b[0]) {
                Some(LinkFrame::Frame { msg, .. }) => return Ok(msg),
                Some(LinkFrame::Dropped(r)) => {
                    bail!("a bad harness frame from the emulated {who}: {r:?}")
                }
                None => {}
            }
        }
    }
}

/// Exactly `n` bytes from `s`.
fn take(s: &mut TcpStream, n: u32, what: &str) -> Result<Vec<u8>> {
    let mut v = vec![0u8; n as usize];
    s.read_exact(&mut v)
        .with_context(|| format!("reading {n} bytes of the {what}"))?;
    Ok(v)
}

/// The two emulated boards.
pub struct EmulatedRoles {
    node_link: TcpStream,
    /// The node's DVL UART (USART3, `-serial` 2) and the simulated DVL's reports waiting
    /// for it.
    node_dvl: TcpStream,
    dvl: DvlWire,
    node_h: Harness,
    node_reports: HarnessDecoder<NodeReport>,
    top_tether: TcpStream,
    top_link: TcpStream,
    top_h: Harness,
    top_reports: HarnessDecoder<TopsideReport>,
    /// The two QEMU children, killed when dropped (after the sockets above: fields drop in
    /// order).
    _qemu: [QemuChild; 2],
    /// Bytes delivered to / read from each UART since boot.
    node_link_in: u32,
    node_link_out: u32,
    tether_in: u32,
    tether_out: u32,
    top_link_in: u32,
    top_link_out: u32,
    uplink_steps: u32,
    /// The topside's hello on the tether, for the first pass's PC.
    hello: Vec<u8>,
    /// The PC's bytes waiting for the topside's next step.
    held_tether: Vec<u8>,
    /// Times the node runs at whatever it is given (its failsafes' times).
    node_wakes: BTreeSet<u64>,
    next_top_us: u64,
    /// The plant's sensors for the node.
    imu: VecDeque<ImuSample>,
    current_imu: Option<ImuSample>,
    pressure: VecDeque<(u64, f32)>,
    /// A conversion the node has not read yet (it reads once a link period, when it sends
    /// its uplink).
    new_pressure: Option<f32>,
    last_imu_read_us: Option<u64>,
    /// The node's latest report.
    node_last: NodePass,
}

impl EmulatedRoles {
    /// Boot both images (`qemu`: the QEMU binary) and wait for their hellos.
    pub fn start(elfs: &LayoutElfs, qemu: &str) -> Result<Self> {
        let (nq, mut ns) = start_qemu_serials(qemu, &elfs.node, 3, None, BOARD_TIMEOUT)
            .context("starting the emulated node")?;
        let (tq, mut ts) = start_qemu_serials(qemu, &elfs.topside, 3, None, BOARD_TIMEOUT)
            .context("starting the emulated topside")?;
        let (Some(node_dvl), Some(node_h), Some(node_link)) = (ns.pop(), ns.pop(), ns.pop()) else {
            bail!("the emulated node's serial ports did not connect");
        };
        let (Some(top_h), Some(top_link), Some(top_tether)) = (ts.pop(), ts.pop(), ts.pop()) else {
            bail!("the emulated topside's serial ports did not connect");
        };
        let mut r = Self {
            node_link,
            node_dvl,
            dvl: DvlWire::default(),
            node_h: Harness::new(node_h)?,
            node_reports: HarnessDecoder::new(),
            top_tether,
            top_link,
            top_h: Harness::new(top_h)?,
            top_reports: HarnessDecoder::new(),
            _qemu: [nq, tq],
            node_link_in: 0,
            node_link_out: 0,
            tether_in: 0,
            tether_out: 0,
            top_link_in: 0,
            top_link_out: 0,
            uplink_steps: 0,
            hello: Vec::new(),
            held_tether: Vec::new(),
            node_wakes: BTreeSet::new(),
            next_top_us: 0,
            imu: VecDeque::new(),
            current_imu: None,
            pressure: VecDeque::new(),
            new_pressure: None,
            last_imu_read_us: None,
            node_last: NodePass::default(),
        };
        let n = r.node_h.recv(&mut r.node_reports, "node")?;
        r.node_last = NodePass {
            pulse_us: n.pulse_us,
            status: n.status,
            accepted: n.accepted,
            armed: n.status & status::ARMED != 0,
            ..NodePass::default()
        };
        let t = r.top_h.recv(&mut r.top_reports, "topside")?;
        r.hello = take(&mut r.top_tether, t.tether_tx_bytes, "topside's hello")?;
        r.tether_out = t.tether_tx_bytes;
        Ok(r)
    }

    /// Send the node its step at `t_us`: the link's and the DVL's bytes first, then the
    /// step.
    fn node_send(&mut self, t_us: u64, link_in: &[u8]) -> Result<()> {
        self.node_link
            .write_all(link_in)
            .context("writing the node link to the emulated node")?;
        let mut dvl = vec![0u8; self.dvl.pending()];
        let n = embedded_io::Read::read(&mut self.dvl, &mut dvl).unwrap_or(0);
        self.node_dvl
            .write_all(&dvl[..n])
            .context("writing the DVL's UART to the emulated node")?;
        self.node_link_in = self.node_link_in.wrapping_add(link_in.len() as u32);
        while self.imu.front().is_some_and(|s| s.t_us <= t_us) {
            self.current_imu = self.imu.pop_front();
        }
        while self.pressure.front().is_some_and(|&(t, _)| t <= t_us) {
            self.new_pressure = self.pressure.pop_front().map(|(_, p)| p);
        }
        let imu = self.current_imu.map(|s| HarnessImu {
            gyro_rad_s: s.gyro_rad_s,
            accel_m_s2: s.accel_m_s2,
        });
        // The node samples at each multiple of its IMU period (each is a step).
        if imu.is_some() && t_us.is_multiple_of(u64::from(NODE_IMU_PERIOD_US)) {
            self.last_imu_read_us = Some(t_us);
        }
        self.node_h.send(&NodeStep {
            t_us,
            link_rx_bytes: self.node_link_in,
            imu,
            pressure_pa: self.new_pressure,
        })
    }

    fn node_recv(&mut self, t_us: u64, read: Vec<u8>) -> Result<NodePass> {
        let r = self.node_h.recv(&mut self.node_reports, "node")?;
        if let Some(why) = r.refused {
            bail!("the emulated node refused its step at {t_us} us: {why:?}");
        }
        let n = r.link_tx_bytes.wrapping_sub(self.node_link_out);
        let written = take(&mut self.node_link, n, "node's uplink")?;
        self.node_link_out = r.link_tx_bytes;
        if !written.is_empty() {
            // It sent its uplink, and read its pressure sensor for it.
            self.new_pressure = None;
        }
        self.node_last = NodePass {
            read,
            written,
            pulse_us: r.pulse_us,
            status: r.status,
            accepted: r.accepted,
            armed: r.status & status::ARMED != 0,
            imu_read_us: self.last_imu_read_us,
        };
        Ok(self.node_last.clone())
    }

    fn top_send(&mut self, t_us: u64, tether_in: &[u8], link_in: &[u8]) -> Result<()> {
        self.top_tether
            .write_all(tether_in)
            .context("writing the tether to the emulated topside")?;
        self.top_link
            .write_all(link_in)
            .context("writing the node link to the emulated topside")?;
        self.tether_in = self.tether_in.wrapping_add(tether_in.len() as u32);
        self.top_link_in = self.top_link_in.wrapping_add(link_in.len() as u32);
        self.next_top_us = (t_us / TOPSIDE_GRID_US + 1) * TOPSIDE_GRID_US;
        self.top_h.send(&TopsideStep {
            t_us,
            tether_rx_bytes: self.tether_in,
            link_rx_bytes: self.top_link_in,
        })
    }

    fn top_recv(&mut self, t_us: u64, link_read: Vec<u8>) -> Result<TopsidePass> {
        let r = self.top_h.recv(&mut self.top_reports, "topside")?;
        if let Some(why) = r.refused {
            bail!("the emulated topside refused its step at {t_us} us: {why:?}");
        }
        let n = r.link_tx_bytes.wrapping_sub(self.top_link_out);
        let link_written = take(&mut self.top_link, n, "topside's downlink")?;
        self.top_link_out = r.link_tx_bytes;
        let n = r.tether_tx_bytes.wrapping_sub(self.tether_out);
        let mut tether_written = std::mem::take(&mut self.hello);
        tether_written.extend(take(&mut self.top_tether, n, "topside's tether")?);
        self.tether_out = r.tether_tx_bytes;
        let stepped = r.uplink_steps != self.uplink_steps;
        self.uplink_steps = r.uplink_steps;
        Ok(TopsidePass {
            link_read,
            link_written,
            tether_written,
            stepped,
        })
    }
}

impl Roles for EmulatedRoles {
    fn pass(
        &mut self,
        t_us: u64,
        node_in: &[u8],
        tether_in: &[u8],
        top_in: &[u8],
    ) -> Result<(NodePass, TopsidePass)> {
        let on_grid = t_us.is_multiple_of(u64::from(NODE_IMU_PERIOD_US));
        let woken = self.node_wakes.remove(&t_us);
        self.node_wakes = self.node_wakes.split_off(&t_us);
        let node_due = on_grid || !node_in.is_empty() || woken;
        self.held_tether.extend_from_slice(tether_in);
        let top_due = (on_grid && (t_us >= self.next_top_us || !self.held_tether.is_empty()))
            || !top_in.is_empty()
            || !self.hello.is_empty();
        // Both steps out, then both reports: the two QEMUs run at the same time.
        if node_due {
            self.node_send(t_us, node_in)?;
        }
        if top_due {
            let tether = std::mem::take(&mut self.held_tether);
            self.top_send(t_us, &tether, top_in)?;
        }
        let np = if node_due {
            // The node reads every byte delivered before its step (its harness pass runs
            // until none waits).
            self.node_recv(t_us, node_in.to_vec())?
        } else {
            NodePass {
                read: Vec::new(),
                written: Vec::new(),
                ..self.node_last.clone()
            }
        };
        let tp = if top_due {
            self.top_recv(t_us, top_in.to_vec())?
        } else {
            TopsidePass::default()
        };
        Ok((np, tp))
    }

    /// A full step of the topside's loop at `t_us` (its harness pass is the board's loop).
    fn topside_tether(&mut self, t_us: u64, tether_in: &[u8]) -> Result<TopsidePass> {
        let mut tether = std::mem::take(&mut self.held_tether);
        tether.extend_from_slice(tether_in);
        self.top_send(t_us, &tether, &[])?;
        self.top_recv(t_us, Vec::new())
    }

    fn wake_node_at(&mut self, t_us: u64) {
        self.node_wakes.insert(t_us);
    }

    fn push_imu(&mut self, s: ImuSample) {
        self.imu.push_back(s);
    }

    fn push_pressure(&mut self, t_us: u64, pressure_pa: f32) {
        self.pressure.push_back((t_us, pressure_pa));
    }

    fn push_dvl(&mut self, fix: &DvlFix) {
        self.dvl.send_wrz(fix);
    }

    fn pass_period_us(&self) -> Option<u64> {
        None
    }

    fn control(&self) -> Option<ControlView> {
        None
    }

    fn node_imu_reads(&self) -> Option<u64> {
        None
    }

    fn node_counters(&self) -> Option<NodeCounters> {
        None
    }

    fn topside_counters(&self) -> Option<TopsideCounters> {
        None
    }

    fn round_trip_us(&self) -> Option<u32> {
        None
    }

    fn link_faults(&self) -> Option<u16> {
        None
    }

    fn describe(&self) -> &'static str {
        "emulated (QEMU netduinoplus2 x 2)"
    }
}
