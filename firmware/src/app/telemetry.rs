//! What the vehicle tells the surface: telemetry, status and nacks, queued behind the frame
//! being sent and handed to the port as it takes them.

use super::duty::pulse_for_duty;
use super::serial_fault::serial_ok;
use super::{App, Monotonic};
use crate::protocol::{encode, fault, NackReason, Reply, Status, Telemetry};
use crate::sensors::Sensors;
use embedded_hal::pwm::SetDutyCycle;
use embedded_io::{Read, ReadReady, Write, WriteReady};

impl<P, S, C, N> App<P, S, C, N>
where
    P: SetDutyCycle,
    S: Read + ReadReady + Write + WriteReady,
    C: Monotonic,
    N: Sensors,
{
    /// Telemetry as it would be sent now.
    pub fn telemetry(&mut self, now: u64) -> Telemetry {
        let period = self.config.pwm_period_us();
        let mut pulse_us = [0; 3];
        for ((p, &d), o) in pulse_us.iter_mut().zip(&self.duty).zip(&self.pwm) {
            *p = pulse_for_duty(d, period, o.max_duty_cycle());
        }
        let (nav_seq, _) = self.autopilot.latest_nav().unwrap_or((0, 0));
        Telemetry {
            t_us: now,
            mode: self.autopilot.mode(),
            armed: self.autopilot.armed(),
            nav_seq,
            errors: self.last.errors,
            requested: self.last.requested,
            achieved: self.last.allocation.achieved,
            thrust_n: self.last.allocation.thrust_n,
            pulse_us,
            faults: self.faults(),
            loop_ticks: self.loop_ticks,
            nav: self.autopilot.nav_state(),
            mission_reached: self.autopilot.mission_reached(now),
            nav_pos_std_m: self
                .autopilot
                .onboard_nav()
                .map_or([0.0; 3], |o| o.position_std_m()),
            dvl: self.autopilot.last_dvl(),
        }
    }

    /// Fault flags now: the latest step's, the I/O ones and the overrun flag.
    pub(super) fn faults(&self) -> u16 {
        let overrun = if self.overruns > 0 { fault::OVERRUN } else { 0 };
        self.last.faults | self.io_faults | overrun | self.sensors.faults()
    }

    /// The answer to the heartbeat `heartbeat_seq`: link counters and health.
    pub fn status(&self, now: u64, heartbeat_seq: u16) -> Status {
        let (_, nav_t_us) = self.autopilot.latest_nav().unwrap_or((0, 0));
        Status {
            t_us: now,
            heartbeat_seq,
            nav_t_us,
            link: self.link_stats(),
            steps: self.autopilot.steps,
            loop_ticks_max: self.loop_ticks_max,
            overruns: self.overruns,
            control_late_max_us: self.control_late_max_us,
            faults: self.faults(),
            nav_health: self
                .autopilot
                .onboard_nav()
                .map_or(Default::default(), |o| o.estimator().health()),
            compass_cal: self.autopilot.compass_calibration(),
            compass_swing: self.autopilot.swing_outcome(),
            battery: self.autopilot.health().battery.status(),
            ident: self.autopilot.ident_outcome(),
        }
    }

    pub(super) fn send_telemetry(&mut self, now: u64) {
        let t = self.telemetry(now);
        self.send(&Reply::Telemetry(t));
    }

    pub(super) fn nack(&mut self, seq: u16, reason: NackReason) {
        self.link.nacks = self.link.nacks.wrapping_add(1);
        self.send(&Reply::Nack { seq, reason });
    }

    /// Queue a reply (with its sequence number, given now) and hand the port what it takes.
    /// A reply that finds the queue full is dropped whole and counted (`tx_dropped`).
    pub(super) fn send(&mut self, reply: &Reply) {
        let seq = self.tx_seq;
        self.tx_seq = seq.wrapping_add(1);
        if self.tx_queue.push_back((seq, *reply)).is_err() {
            self.link.tx_dropped = self.link.tx_dropped.wrapping_add(1);
        }
        self.flush_tx();
    }

    /// Write while the port is ready: the rest of the frame being sent, then the next reply,
    /// encoded when its turn comes. Never waits. An encoding error (never: every reply fits,
    /// tested) raises [`fault::SERIAL_ERROR`] and drops that reply.
    pub(super) fn flush_tx(&mut self) {
        loop {
            if self.tx_sent >= self.tx_len {
                let Some((seq, reply)) = self.tx_queue.pop_front() else {
                    return;
                };
                // Replies carry session 0 (one varint byte): the surface does not need the
                // vehicle's session on its answers, and every byte costs the loop time.
                let encoded = encode(0, seq, &reply, &mut self.tx_buf).map(<[u8]>::len);
                let Some(len) = serial_ok(&mut self.io_faults, encoded) else {
                    continue;
                };
                (self.tx_sent, self.tx_len) = (0, len);
                self.link.tx_frames = self.link.tx_frames.wrapping_add(1);
            }
            if serial_ok(&mut self.io_faults, self.serial.write_ready()) != Some(true) {
                return;
            }
            let rest = self
                .tx_buf
                .get(self.tx_sent..self.tx_len)
                .unwrap_or_default();
            match self.serial.write(rest) {
                Ok(n) if n > 0 => self.tx_sent += n.min(rest.len()),
                _ => {
                    self.io_faults |= fault::SERIAL_ERROR;
                    return;
                }
            }
        }
    }
}
