//! The node role: the vehicle's thin image in the paper's layout, where the
//! control loop runs at the surface. The node reads its IMU at its own rate (at least
//! 400 Hz) and integrates the increments (delta angle, delta velocity), reads the pressure
//! sensor and its DVL's port ([`Sensors::dvl`]: the A50's reports parsed and gated here, only
//! an admitted velocity travels), sends them up the node link once a link period, and applies
//! the pulse widths the topside sends. Nothing of the controller core runs here.
//!
//! Generic over three `embedded_hal::pwm::SetDutyCycle` (the ESCs), an `embedded_io` port
//! (the link), a [`Monotonic`] clock and the firmware's [`Sensors`], so the same code runs on
//! the node MCU, on the emulated board and in the host tests with fakes.
//!
//! Failsafes, on the node's own clock, each applied by [`Node::tick`]:
//!
//! | condition | action | status bit |
//! | --- | --- | --- |
//! | boot | the three outputs at neutral (1500 us) in [`Node::new`], before the board enables them; disarmed, latched | `LATCHED` |
//! | the latest command older than its time to live (1..=100 ms) | neutral; counted once | `TTL_NEUTRAL` |
//! | no valid frame for 1 s | disarmed, neutral, latched: arms again only on a `Disarmed` then `Armed` command; a new topside session may then be served | `LATCHED` |
//! | a frame with bad COBS or CRC, too short or long, not a `Downlink` | never applied; `corrupt` | |
//! | another link version | never applied; `version` | |
//! | a pulse outside 1100-1900 us, a time to live outside 1..=100 ms | never applied; `out_of_range` | |
//! | another topside's session (crossed wires, two topsides), session 0 | never applied; `foreign` | |
//! | a sequence not above the last applied one of the session (a replay, at any distance: the `u64` sequence never wraps) | never applied; `replayed` | |
//! | a DVL line refused (bad checksum, malformed, no bottom lock, a poor figure of merit, overlong), or a velocity the uplink cannot carry | no velocity sent (a DVL gap for the topside's estimator); `dvl_refused` | |
//!
//! A refused frame changes nothing: not the outputs, the session, the sequence, the arm
//! state nor the silence timer.

use crate::app::Monotonic;
use crate::node_link::{
    low_16, seal, seq_after, status, ArmCommand, Downlink, LinkDecoder, LinkFrame, NodeCounters,
    Uplink, UplinkDvl, ESC_MAX_US, ESC_MIN_US, ESC_NEUTRAL_US, MAX_TTL_MS,
};
use crate::protocol::{DropReason, MAX_FRAME_LEN};
use crate::sensors::Sensors;
use embedded_hal::pwm::SetDutyCycle;
use embedded_io::{Read, ReadReady, Write, WriteReady};

/// Bytes read from the link at a time.
const RX_CHUNK: usize = 32;

/// The node's settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NodeConfig {
    /// IMU sampling period, microseconds (400 Hz: 2,500).
    pub imu_period_us: u32,
    /// Uplink period, microseconds (50 Hz: 20,000).
    pub link_period_us: u32,
    /// PWM period of the ESC outputs, microseconds (50 Hz: 20,000).
    pub pwm_period_us: u32,
    /// Silence after which the node disarms and latches, microseconds.
    pub disarm_after_us: u32,
    /// Age after which the pressure reading counts as lost, microseconds.
    pub pressure_timeout_us: u32,
    /// Most link bytes read per [`Node::tick`] (bounds the pass).
    pub max_rx_bytes_per_tick: usize,
}

impl NodeConfig {
    /// IMU at 400 Hz, the link at 50 Hz, 50 Hz PWM, disarm after 1 s, pressure lost after
    /// 0.5 s.
    pub const DEFAULT: Self = Self {
        imu_period_us: 2_500,
        link_period_us: crate::node_link::LINK_PERIOD_US,
        pwm_period_us: 20_000,
        disarm_after_us: 1_000_000,
        pressure_timeout_us: 500_000,
        max_rx_bytes_per_tick: 64,
    };
}

/// Why the node could not start.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum NodeConfigError {
    /// The IMU period is zero or slower than 400 Hz.
    ImuRate,
    /// The link period is zero or shorter than the IMU period.
    LinkRate,
    /// The PWM period cannot carry a 1,900 us pulse, or exceeds 20 ms.
    PwmPeriod,
    /// A PWM output has a zero maximum duty.
    PwmResolution,
    /// The disarm time is not above 100 ms (the longest time to live) or above 1 s.
    DisarmTime,
}

impl core::fmt::Display for NodeConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            NodeConfigError::ImuRate => "IMU period must be 1..=2,500 us (>= 400 Hz)",
            NodeConfigError::LinkRate => "link period must be at least the IMU period",
            NodeConfigError::PwmPeriod => "PWM period must be 1,900..=20,000 us",
            NodeConfigError::PwmResolution => "PWM output with zero max duty",
            NodeConfigError::DisarmTime => "disarm time must be 100 ms..=1 s",
        })
    }
}

impl core::error::Error for NodeConfigError {}

/// Why a downlink frame was not applied (each counted in [`NodeCounters`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Refusal {
    /// The framing dropped it (COBS, CRC, length, not a `Downlink`).
    Corrupt(DropReason),
    /// Another link version.
    Version,
    /// A pulse outside 1100-1900 us or a time to live outside 1..=100 ms.
    OutOfRange,
    /// Another topside's session, or session 0.
    Foreign,
    /// The sequence is not above the last applied one (a replay, at any distance).
    Replayed,
}

/// Duty for a pulse width: `pulse_us / period_us * max_duty`, rounded (integers only).
pub fn duty_for_pulse_us(pulse_us: u16, period_us: u32, max_duty: u16) -> u16 {
    let period = u64::from(period_us.max(1));
    let duty = (u64::from(pulse_us) * u64::from(max_duty) + period / 2) / period;
    duty.min(u64::from(max_duty)) as u16
}

/// The node.
pub struct Node<P, S, C, N> {
    pwm: [P; 3],
    serial: S,
    clock: C,
    sensors: N,
    config: NodeConfig,
    rx: LinkDecoder<Downlink>,
    tx_buf: [u8; MAX_FRAME_LEN],
    tx_sent: usize,
    tx_len: usize,
    tx_seq: u16,
    /// The topside session served (0: none; the next valid frame's is taken).
    session: u32,
    /// The sequence of the latest downlink applied in the session (`None`: none since the
    /// boot or the latch).
    last_seq: Option<u64>,
    armed: bool,
    /// A `Disarmed` command was seen since the boot or the latch: `Armed` may arm.
    armable: bool,
    /// The latest applied command, its arrival and how long it holds.
    pulse_us: [u16; 3],
    command_expires_us: u64,
    ttl_expired: bool,
    last_valid_us: u64,
    /// The latest applied downlink's send time on the topside's clock (echoed, with the
    /// time held since its arrival, `last_valid_us`).
    echo_t_us: u32,
    /// The pulses on the outputs now.
    output_us: [u16; 3],
    pwm_error: bool,
    // IMU integration over the current link period.
    prev_imu: Option<(u64, [f32; 3], [f32; 3])>,
    delta_angle_rad: [f32; 3],
    delta_velocity_m_s: [f32; 3],
    dt_us: u32,
    samples: u16,
    pressure_pa: f32,
    pressure_count: u8,
    last_pressure_us: Option<u64>,
    next_imu_us: u64,
    next_link_us: u64,
    counters: NodeCounters,
    /// The newest DVL velocity admitted since the last uplink, in the uplink's integers, and
    /// its time of validity (converted in the DVL's pass, not the uplink's).
    dvl: Option<(UplinkDvl, u64)>,
    /// Admitted DVL velocities the uplink could not carry (counted as refused).
    dvl_unsent: u32,
}

impl<P, S, C, N> Node<P, S, C, N>
where
    P: SetDutyCycle,
    S: Read + ReadReady + Write + WriteReady,
    C: Monotonic,
    N: Sensors,
{
    /// Check the settings and write neutral to the three outputs (before anything else,
    /// and before the board enables them); boot disarmed and latched.
    pub fn new(
        pwm: [P; 3],
        serial: S,
        mut clock: C,
        sensors: N,
        config: NodeConfig,
    ) -> Result<Self, NodeConfigError> {
        if !(1..=2_500).contains(&config.imu_period_us) {
            return Err(NodeConfigError::ImuRate);
        }
        if config.link_period_us < config.imu_period_us {
            return Err(NodeConfigError::LinkRate);
        }
        if !(u32::from(ESC_MAX_US)..=20_000).contains(&config.pwm_period_us) {
            return Err(NodeConfigError::PwmPeriod);
        }
        if pwm.iter().any(|p| p.max_duty_cycle() == 0) {
            return Err(NodeConfigError::PwmResolution);
        }
        if !(u32::from(MAX_TTL_MS) * 1_000 + 1..=1_000_000).contains(&config.disarm_after_us) {
            return Err(NodeConfigError::DisarmTime);
        }
        let mut pwm = pwm;
        let pwm_error = !write_pulses(&mut pwm, config.pwm_period_us, [ESC_NEUTRAL_US; 3]);
        let now = clock.now_us();
        Ok(Self {
            pwm,
            serial,
            clock,
            sensors,
            config,
            rx: LinkDecoder::new(),
            tx_buf: [0; MAX_FRAME_LEN],
            tx_sent: 0,
            tx_len: 0,
            tx_seq: 0,
            session: 0,
            last_seq: None,
            armed: false,
            armable: false,
            pulse_us: [ESC_NEUTRAL_US; 3],
            command_expires_us: 0,
            ttl_expired: false,
            last_valid_us: now,
            echo_t_us: 0,
            output_us: [ESC_NEUTRAL_US; 3],
            pwm_error,
            prev_imu: None,
            delta_angle_rad: [0.0; 3],
            delta_velocity_m_s: [0.0; 3],
            dt_us: 0,
            samples: 0,
            pressure_pa: 0.0,
            pressure_count: 0,
            last_pressure_us: None,
            next_imu_us: now,
            next_link_us: now.saturating_add(u64::from(config.link_period_us)),
            counters: NodeCounters::default(),
            dvl: None,
            dvl_unsent: 0,
        })
    }

    /// One pass of the node's loop: the waiting link bytes (at most
    /// `max_rx_bytes_per_tick`), the IMU when due, the failsafes and the outputs, then the
    /// uplink when due or else the DVL's port: a pass that seals an uplink parses no DVL
    /// line (the DVL's bytes wait in its port's ring for the next pass, 2.5 ms at most), so
    /// each of the two keeps its own time budget.
    pub fn tick(&mut self) {
        self.flush_tx();
        let mut budget = self.config.max_rx_bytes_per_tick;
        while budget > 0 && self.serial.read_ready().unwrap_or(false) {
            let mut chunk = [0u8; RX_CHUNK];
            let want = chunk.get_mut(..budget.min(RX_CHUNK)).unwrap_or_default();
            let n = match self.serial.read(want) {
                Ok(n @ 1..) => n.min(want.len()),
                _ => break,
            };
            budget = budget.saturating_sub(n);
            for &b in chunk.get(..n).unwrap_or_default() {
                if let Some(f) = self.rx.push(b) {
                    let now = self.clock.now_us();
                    let _ = self.on_frame(now, f);
                }
            }
        }
        let now = self.clock.now_us();
        if now >= self.next_imu_us {
            self.next_imu_us = next_due(self.next_imu_us, now, self.config.imu_period_us);
            self.sample_imu(now);
        }
        self.apply_failsafes(now);
        if now >= self.next_link_us {
            self.next_link_us = next_due(self.next_link_us, now, self.config.link_period_us);
            self.send_uplink(now);
        } else {
            self.read_dvl(now);
        }
    }

    /// The DVL's port: its newest admitted velocity kept for the next uplink, in integers;
    /// the refused count updated.
    fn read_dvl(&mut self, now: u64) {
        if let Some(fix) = self.sensors.dvl(now) {
            match UplinkDvl::ageless(&fix) {
                Some(d) => self.dvl = Some((d, fix.t_us)),
                None => self.dvl_unsent = self.dvl_unsent.wrapping_add(1),
            }
        }
        // The low byte of the count: the topside sums the differences.
        self.counters.dvl_refused = self.sensors.dvl_refused().wrapping_add(self.dvl_unsent) as u8;
    }

    /// Check and apply one frame from the link at `now`; a refused frame changes nothing
    /// but its counter.
    #[cfg_attr(feature = "no-panic", no_panic::no_panic)]
    pub fn on_frame(&mut self, now: u64, frame: LinkFrame<Downlink>) -> Result<(), Refusal> {
        let r = self.check(frame);
        let c = &mut self.counters;
        let counter = match r {
            Ok((seq, cmd)) => {
                self.apply(now, seq, &cmd);
                return Ok(());
            }
            Err(Refusal::Corrupt(_)) => &mut c.corrupt,
            Err(Refusal::Version) => &mut c.version,
            Err(Refusal::OutOfRange) => &mut c.out_of_range,
            Err(Refusal::Foreign) => &mut c.foreign,
            Err(Refusal::Replayed) => &mut c.replayed,
        };
        *counter = counter.wrapping_add(1);
        r.map(|_| ())
    }

    fn check(&self, frame: LinkFrame<Downlink>) -> Result<(u64, Downlink), Refusal> {
        // The envelope's sequence (the low 16 bits) is not read: the message's own is.
        let cmd = match frame {
            LinkFrame::Frame { msg, .. } => msg,
            LinkFrame::Dropped(DropReason::Version) => return Err(Refusal::Version),
            LinkFrame::Dropped(r) => return Err(Refusal::Corrupt(r)),
        };
        let pulses_ok = cmd
            .pulse_us
            .iter()
            .all(|p| (ESC_MIN_US..=ESC_MAX_US).contains(p));
        if !pulses_ok || !(1..=MAX_TTL_MS).contains(&cmd.ttl_ms) {
            return Err(Refusal::OutOfRange);
        }
        if cmd.session == 0 || (self.session != 0 && cmd.session != self.session) {
            return Err(Refusal::Foreign);
        }
        if !seq_after(cmd.seq, self.last_seq) {
            return Err(Refusal::Replayed);
        }
        Ok((cmd.seq, cmd))
    }

    fn apply(&mut self, now: u64, seq: u64, cmd: &Downlink) {
        self.counters.accepted = self.counters.accepted.wrapping_add(1);
        self.session = cmd.session;
        self.last_seq = Some(seq);
        self.last_valid_us = now;
        self.echo_t_us = cmd.t_us;
        match cmd.arm {
            ArmCommand::Disarmed => {
                self.armed = false;
                self.armable = true;
            }
            ArmCommand::Armed => self.armed |= self.armable,
        }
        self.pulse_us = cmd.pulse_us;
        self.command_expires_us = now.saturating_add(u64::from(cmd.ttl_ms) * 1_000);
        self.ttl_expired = false;
        self.apply_failsafes(now);
    }

    /// The silence latch and the time to live, then the outputs (written when they change).
    fn apply_failsafes(&mut self, now: u64) {
        if now.saturating_sub(self.last_valid_us) >= u64::from(self.config.disarm_after_us) {
            // Latched: disarmed until an explicit arm transition; the next topside session
            // may be served (a rebooted topside, a replaced cable).
            self.armed = false;
            self.armable = false;
            self.session = 0;
            self.last_seq = None;
        }
        let fresh = now < self.command_expires_us;
        if self.armed && !fresh && !self.ttl_expired {
            self.ttl_expired = true;
            self.counters.ttl_expired = self.counters.ttl_expired.wrapping_add(1);
        }
        let out = if self.armed && fresh {
            self.pulse_us
        } else {
            [ESC_NEUTRAL_US; 3]
        };
        if out != self.output_us {
            self.output_us = out;
            self.pwm_error |= !write_pulses(&mut self.pwm, self.config.pwm_period_us, out);
        }
    }

    /// Read the IMU and integrate since the previous sample (trapezoid): the increments of
    /// one link period cover the time from the previous period's last sample to this
    /// period's, with no gap. A sample more than four IMU periods after the previous one
    /// restarts the integration (no interval across a long gap).
    fn sample_imu(&mut self, now: u64) {
        let Some(s) = self.sensors.imu(now) else {
            self.counters.imu_errors = self.counters.imu_errors.wrapping_add(1);
            return;
        };
        let max_gap = 4 * u64::from(self.config.imu_period_us);
        if let Some((t0, w0, a0)) = self.prev_imu {
            let dt = now.saturating_sub(t0);
            if dt <= max_gap {
                let h = dt as f32 * 0.5e-6;
                for (d, (x0, x1)) in self
                    .delta_angle_rad
                    .iter_mut()
                    .zip(w0.iter().zip(&s.gyro_rad_s))
                {
                    *d += (x0 + x1) * h;
                }
                for (d, (x0, x1)) in self
                    .delta_velocity_m_s
                    .iter_mut()
                    .zip(a0.iter().zip(&s.accel_m_s2))
                {
                    *d += (x0 + x1) * h;
                }
                self.dt_us = self.dt_us.saturating_add(dt as u32);
                self.samples = self.samples.saturating_add(1);
            }
        }
        self.prev_imu = Some((now, s.gyro_rad_s, s.accel_m_s2));
    }

    /// The status bits now.
    pub fn status(&self, now: u64) -> u8 {
        let mut s = 0;
        if self.armed {
            s |= status::ARMED;
        } else if !self.armable {
            s |= status::LATCHED;
        }
        if self.armed && now >= self.command_expires_us {
            s |= status::TTL_NEUTRAL;
        }
        if self.samples == 0 {
            s |= status::IMU_LOST;
        }
        let timeout = u64::from(self.config.pressure_timeout_us);
        if self
            .last_pressure_us
            .is_none_or(|t| now.saturating_sub(t) > timeout)
        {
            s |= status::PRESSURE_LOST;
        }
        if self.pwm_error {
            s |= status::PWM_ERROR;
        }
        s
    }

    /// The uplink of the period ending now: read the pressure sensor (once a period, its own
    /// conversion cycle), send the increments, start the next period.
    fn send_uplink(&mut self, now: u64) {
        if let Some(p) = self.sensors.pressure_pa(now) {
            self.pressure_pa = p;
            self.pressure_count = self.pressure_count.wrapping_add(1);
            self.last_pressure_us = Some(now);
        }
        // The echoed time: the downlink's send time plus how long it was held here, so the
        // topside's clock minus it is the round trip (the two clocks never compared).
        let held_us = now
            .saturating_sub(self.last_valid_us)
            .min(u64::from(u32::MAX)) as u32;
        let echo_t_us = match self.last_seq {
            Some(_) => self.echo_t_us.wrapping_add(held_us),
            None => 0,
        };
        let imu_age_us = match (self.samples, self.prev_imu) {
            (1.., Some((t, _, _))) => now.saturating_sub(t).min(u64::from(u32::MAX)) as u32,
            _ => 0,
        };
        let dvl = self.dvl.take().and_then(|(d, t_us)| {
            let d = d.aged(t_us, now);
            if d.is_none() {
                self.dvl_unsent = self.dvl_unsent.wrapping_add(1);
                self.counters.dvl_refused = self.counters.dvl_refused.wrapping_add(1);
            }
            d
        });
        let up = Uplink {
            session: self.session,
            echo_seq: low_16(self.last_seq.unwrap_or(0)),
            echo_t_us,
            imu_age_us,
            dt_us: self.dt_us,
            samples: self.samples,
            delta_angle_rad: self.delta_angle_rad,
            delta_velocity_m_s: self.delta_velocity_m_s,
            pressure_pa: self.pressure_pa,
            pressure_count: self.pressure_count,
            status: self.status(now),
            counters: self.counters,
            dvl,
        };
        (self.delta_angle_rad, self.delta_velocity_m_s) = ([0.0; 3], [0.0; 3]);
        (self.dt_us, self.samples) = (0, 0);
        // A frame still going out is cut short (the port is slower than the link period);
        // the receiver drops the cut frame and resynchronizes on this one's delimiter.
        let seq = self.tx_seq;
        self.tx_seq = seq.wrapping_add(1);
        (self.tx_sent, self.tx_len) = match seal(seq, &up, &mut self.tx_buf) {
            Ok(f) => (0, f.len()),
            Err(_) => (0, 0),
        };
        self.flush_tx();
    }

    /// Hand the port what it takes of the frame being sent; never waits.
    fn flush_tx(&mut self) {
        while self.tx_sent < self.tx_len && self.serial.write_ready().unwrap_or(false) {
            let rest = self
                .tx_buf
                .get(self.tx_sent..self.tx_len)
                .unwrap_or_default();
            match self.serial.write(rest) {
                Ok(n) if n > 0 => self.tx_sent += n.min(rest.len()),
                _ => return,
            }
        }
    }

    /// The pulses on the outputs now, microseconds.
    pub fn output_us(&self) -> [u16; 3] {
        self.output_us
    }

    /// Armed (the outputs follow the commands while they are fresh).
    pub fn armed(&self) -> bool {
        self.armed
    }

    /// The topside session served (0: none).
    pub fn session(&self) -> u32 {
        self.session
    }

    /// The counters.
    pub fn counters(&self) -> NodeCounters {
        self.counters
    }

    /// The link receiver's own counters (frames and drops by reason).
    pub fn link_decoder(&self) -> &LinkDecoder<Downlink> {
        &self.rx
    }

    /// The outputs, port, clock and sensors (for tests and the board).
    pub fn parts_mut(&mut self) -> (&mut [P; 3], &mut S, &mut C, &mut N) {
        (
            &mut self.pwm,
            &mut self.serial,
            &mut self.clock,
            &mut self.sensors,
        )
    }
}

/// The next due time of a periodic task that ran at `now` and was due at `due`: one period
/// on, or one period from now after a missed period (no burst of catch-up passes).
fn next_due(due: u64, now: u64, period_us: u32) -> u64 {
    let period = u64::from(period_us);
    if now.saturating_sub(due) >= period {
        now.saturating_add(period)
    } else {
        due.saturating_add(period)
    }
}

/// Write three pulse widths; `false` when an output reported an error.
fn write_pulses<P: SetDutyCycle>(pwm: &mut [P; 3], period_us: u32, pulse_us: [u16; 3]) -> bool {
    let mut ok = true;
    for (o, p) in pwm.iter_mut().zip(pulse_us) {
        let d = duty_for_pulse_us(p, period_us, o.max_duty_cycle());
        ok &= o.set_duty_cycle(d).is_ok();
    }
    ok
}

#[cfg(test)]
mod tests;
