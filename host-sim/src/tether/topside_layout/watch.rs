//! The harness's passes: both MCUs run on the virtual clock with the wire between them, and
//! the bytes each side reads and writes are watched (without changing them) for the report.

use super::{NodePass, TopsideLayout, TopsidePass, HEARTBEAT_PERIOD_US, NODE_IMU_PERIOD_US};
use anyhow::Result;
use firmware::node::NodeConfig;
use firmware::node_link::{status, LinkFrame};
use protocol::{Command, Event};

/// The first microsecond at or after `t_s` (a byte delivered at `t_s` is read by a pass
/// then).
fn arrival_us(t_s: f64) -> u64 {
    let mut u = (t_s * 1e6).ceil().max(0.0) as u64;
    while (u as f64) * 1e-6 < t_s {
        u += 1;
    }
    u
}

impl TopsideLayout {
    /// One pass of both MCUs at virtual time `t_us`, with the wire between them.
    pub(super) fn pass(&mut self, t_us: u64) -> Result<()> {
        self.t_us = t_us;
        let t_s = t_us as f64 * 1e-6;
        // The wire delivers what has arrived.
        let mut node_in = Vec::new();
        self.wire.down.read_into(t_s, &mut node_in);
        let mut top_in = Vec::new();
        self.wire.up.read_into(t_s, &mut top_in);

        // The PC's bytes to the topside.
        if self.external.is_none() && self.pc.session() != 0 && t_us >= self.next_heartbeat_us {
            self.next_heartbeat_us = t_us + HEARTBEAT_PERIOD_US;
            let _ = self.pc_send(&Command::Heartbeat { t_us });
        }
        let (due, later): (Vec<_>, Vec<_>) = std::mem::take(&mut self.pending_pc)
            .into_iter()
            .partition(|(t, _)| *t <= t_us);
        self.pending_pc = later;
        let tether_in = match self.external.as_mut() {
            Some(pc) => {
                let inputs: Vec<Command> = due.into_iter().map(|(_, c)| c).collect();
                pc.to_topside(t_us, &inputs)?
            }
            None => {
                for (_, cmd) in due {
                    if let Ok(seq) = self.pc_send(&cmd) {
                        if matches!(cmd, Command::UsblFix(_)) {
                            self.usbl_seqs.insert(seq);
                        }
                    }
                }
                std::mem::take(&mut self.pc_out)
            }
        };
        // The node's pass, then the topside's (the board's loop).
        let (np, tp) = self.roles.pass(t_us, &node_in, &tether_in, &top_in)?;
        self.watch_node(t_us, np);
        self.watch_topside(t_s, tp)?;
        Ok(())
    }

    /// The node's side: what it read and applied, what it sent.
    pub(super) fn watch_node(&mut self, t_us: u64, np: NodePass) {
        let mut last_valid = None;
        for &b in &np.read {
            if let Some(LinkFrame::Frame { seq, msg }) = self.node_rx_dec.push(b) {
                last_valid = Some((seq, msg));
            }
        }
        let accepted = np.accepted;
        if accepted != self.node_accepted {
            self.report.downlinks_applied += u64::from(accepted.wrapping_sub(self.node_accepted));
            self.node_accepted = accepted;
            if let Some((seq, got)) = last_valid {
                let expect = self.sent.get(&seq).copied();
                // The frame taken is the one sent with its number, and the outputs carry
                // its pulses (armed; disarmed they stay neutral).
                let out = np.pulse_us;
                let right =
                    expect.is_some_and(|(d, _)| d == got && (!np.armed || d.pulse_us == out));
                if !right {
                    self.report.wrong_commands_applied += 1;
                }
                if let Some((_, Some(up))) = expect {
                    if let Some(&(newest, oldest)) = self.uplink_imu_us.get(&up) {
                        self.report.latency.samples_us.push(t_us - newest);
                        self.report.latency_oldest.samples_us.push(t_us - oldest);
                    }
                }
                if self.cut_at_us.is_none_or(|c| t_us < c) {
                    self.report.last_good_frame_s = Some(t_us as f64 * 1e-6);
                }
                self.schedule_failsafes(t_us, u64::from(got.ttl_ms) * 1_000);
            }
        }
        if let Some(cut) = self.cut_at_us {
            if t_us >= cut {
                let t_s = t_us as f64 * 1e-6;
                if self.report.node_neutral_s.is_none() && np.pulse_us == [1500; 3] {
                    self.report.node_neutral_s = Some(t_s);
                }
                let latched = np.status & status::LATCHED != 0;
                if self.report.node_latched_s.is_none() && !np.armed && latched {
                    self.report.node_latched_s = Some(t_s);
                }
            }
        }
        if !np.written.is_empty() {
            let imu = np.imu_read_us;
            for &b in &np.written {
                if let Some(LinkFrame::Frame { seq, msg }) = self.node_tx_dec.push(b) {
                    self.uplink_counters = Some(msg.counters);
                    self.report.dvl_uplinks += u64::from(msg.dvl.is_some());
                    self.uplink_samples += u64::from(msg.samples);
                    self.uplink_dt_us += u64::from(msg.dt_us);
                    if let Some(imu) = imu {
                        let oldest = self.prev_uplink_imu_us.unwrap_or(imu);
                        self.uplink_imu_us.insert(seq, (imu, oldest));
                        self.prev_uplink_imu_us = Some(imu);
                    }
                }
            }
            if let Some(arrives_s) = self.wire.up.write(t_us as f64 * 1e-6, &np.written) {
                self.on_arrival(arrives_s);
            }
        }
        self.node_view = NodePass {
            read: Vec::new(),
            written: Vec::new(),
            ..np
        };
    }

    /// The topside's side: the uplink it accepted (the cause of its step), the downlinks it
    /// wrote (kept: what was sent; then onto the wire), what it told the PC (returned).
    pub(super) fn watch_topside(&mut self, t_s: f64, tp: TopsidePass) -> Result<Vec<Event>> {
        let mut last = None;
        for &b in &tp.link_read {
            if let Some(LinkFrame::Frame { seq, .. }) = self.top_rx_dec.push(b) {
                last = Some(seq);
            }
        }
        let cause = if tp.stepped { last } else { None };
        if !tp.link_written.is_empty() {
            for &b in &tp.link_written {
                if let Some(LinkFrame::Frame { seq, msg }) = self.top_tx_dec.push(b) {
                    self.sent.insert(seq, (msg, cause));
                }
            }
            if let Some(arrives_s) = self.wire.down.write(t_s, &tp.link_written) {
                self.on_arrival(arrives_s);
            }
        }
        if let Some(pc) = self.external.as_mut() {
            pc.topside_wrote(&tp.tether_written)?;
        }
        Ok(self.pc_receive(tp.tether_written))
    }

    /// A write's last byte arrives at `arrives_s`: the emulated roles run a pass then.
    pub(super) fn on_arrival(&mut self, arrives_s: f64) {
        if self.roles.pass_period_us().is_none() {
            self.events.insert(arrival_us(arrives_s));
        }
    }

    /// With a cut to come, the emulated node also runs a pass when the downlink it applied
    /// at `t_us` expires (`ttl_us` later) and when it would latch without another (the node's
    /// 1 s), so that the cut's timings are the node's own, not those of its next IMU time.
    pub(super) fn schedule_failsafes(&mut self, t_us: u64, ttl_us: u64) {
        let Some(cut) = self.cut_at_us else { return };
        if self.roles.pass_period_us().is_some() {
            return;
        }
        let disarm = u64::from(NodeConfig::DEFAULT.disarm_after_us);
        for e in [t_us + ttl_us, t_us + disarm] {
            if e >= cut {
                self.events.insert(e);
                self.roles.wake_node_at(e);
            }
        }
    }

    /// Run both MCUs up to `t_us` (inclusive): one pass every [`PASS_US`] in process; the
    /// emulated roles at the node's IMU times, at frame arrivals and at `t_us`.
    pub(super) fn run_to(&mut self, t_us: u64) -> Result<()> {
        if let Some(period) = self.roles.pass_period_us() {
            let mut next = (self.t_us / period + 1) * period;
            while next <= t_us {
                self.pass(next)?;
                next += period;
            }
            return Ok(());
        }
        loop {
            let imu = u64::from(NODE_IMU_PERIOD_US);
            let mut next = ((self.t_us / imu + 1) * imu).min(t_us);
            if let Some(&e) = self.events.range(self.t_us + 1..).next() {
                next = next.min(e);
            }
            if next <= self.t_us {
                return Ok(());
            }
            self.events = self.events.split_off(&(next + 1));
            self.pass(next)?;
        }
    }
}
