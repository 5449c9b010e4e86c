//! The PC's side of the tether to the topside: its session (the protocol's `Client`), the
//! commands it sends, what it reads back (telemetry, status, refusals).

use super::TopsideLayout;
use anyhow::{anyhow, bail, Result};
use controller_core::nav::Refusal;
use firmware::topside_link::fault as link_fault;
use protocol::{Answer, Command, Event, NackReason, Reply, Telemetry};

impl TopsideLayout {
    /// Send a command to the topside over the PC's tether.
    pub(super) fn pc_send(&mut self, cmd: &Command) -> Result<u16> {
        let sent = self
            .pc
            .send(cmd, self.t_us)
            .map_err(|e| anyhow!("{cmd:?}: {e}"))?;
        self.pc_out.push(0);
        self.pc_out.extend_from_slice(sent.frame.bytes());
        Ok(sent.seq)
    }

    /// The PC's waiting bytes to the topside at once (no node-link pass in process),
    /// and what it answered.
    pub(super) fn pc_exchange(&mut self) -> Result<Vec<Event>> {
        let bytes = std::mem::take(&mut self.pc_out);
        let tp = self.roles.topside_tether(self.t_us, &bytes)?;
        self.watch_topside(self.t_us as f64 * 1e-6, tp)
    }

    /// What the topside sent the PC: the session, refusals, telemetry (the good frames, as
    /// the PC's client reports them).
    pub(super) fn pc_receive(&mut self, bytes: Vec<u8>) -> Vec<Event> {
        let mut out = Vec::new();
        let mut rest = bytes.as_slice();
        while let Some(e) = self.pc.receive(&mut rest) {
            if let Event::Reply { reply, .. } = e {
                match reply {
                    Reply::Telemetry(t) => {
                        self.report.telemetry_frames += 1;
                        self.on_ground_telemetry(&t);
                        self.latest_telemetry = Some(t);
                    }
                    Reply::Ack { seq } => {
                        self.usbl_seqs.remove(&seq);
                    }
                    Reply::Nack { seq, reason } => {
                        let usbl = self.usbl_seqs.remove(&seq);
                        if usbl && reason == NackReason::NavRefused(Refusal::Outlier) {
                            self.report.usbl_fixes_rejected += 1;
                        }
                        self.report.nacks += 1;
                        *self
                            .report
                            .nack_reasons
                            .entry(format!("{reason:?}"))
                            .or_default() += 1;
                    }
                    _ => {}
                }
                out.push(e);
            }
        }
        out
    }

    /// A `Telemetry` the ground station received (before it becomes the latest).
    pub(super) fn on_ground_telemetry(&mut self, t: &Telemetry) {
        let previous_dvl = self.latest_telemetry.map_or(0, |p| p.dvl.t_us);
        if t.dvl.is_some() && t.dvl.t_us != previous_dvl {
            self.report.dvl_fixes_on_ground += 1;
        }
        if let Some(cut) = self.cut_at_us {
            let lost = t.faults & link_fault::NODE_LINK_LOST != 0;
            if lost && t.t_us >= cut && self.report.ground_saw_loss_s.is_none() {
                self.report.ground_saw_loss_s = Some(t.t_us as f64 * 1e-6);
            }
        }
    }

    /// A command from the PC, answered (`Ack`) or refused, run at once in the topside.
    pub fn command(&mut self, cmd: &Command) -> Result<()> {
        if let Err(reason) = self.try_command(cmd)? {
            bail!("the topside refused {cmd:?}: {reason:?}")
        }
        Ok(())
    }

    /// [`command`](Self::command) with the refusal's reason as a value; an error only when
    /// the topside did not answer.
    fn try_command(&mut self, cmd: &Command) -> Result<Result<(), NackReason>> {
        let seq = self.pc_send(cmd)?;
        for e in self.pc_exchange()? {
            if let Event::Reply {
                answer: Some(Answer::Command { seq: s, result }),
                ..
            } = e
            {
                if s == seq {
                    return Ok(result);
                }
            }
        }
        bail!("the topside did not answer {cmd:?}")
    }

    /// Open the PC's session with the topside.
    pub(super) fn open_session(&mut self) -> Result<()> {
        let nonce = 0x2500_0001;
        let frame = self
            .pc
            .open(nonce, self.t_us)
            .map_err(|e| anyhow!("OpenSession: {e}"))?;
        self.pc_out.push(0);
        self.pc_out.extend_from_slice(frame.bytes());
        for e in self.pc_exchange()? {
            if let Event::Reply {
                answer: Some(Answer::Session { .. }),
                ..
            } = e
            {
                return Ok(());
            }
        }
        bail!("the topside did not open a session")
    }
}
