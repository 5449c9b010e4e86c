//! The topside role: the same [`App`](crate::App) on the surface MCU, its
//! thrusters and its sensors at the far end of the node link.
//!
//! - [`LinkThruster`]: an `embedded_hal::pwm::SetDutyCycle` whose duty goes into the next
//!   downlink frame (one per ESC, the three sharing a [`NodeBridge`]);
//! - [`LinkSensors`]: the firmware's [`Sensors`], fed by the node's uplink: the increments of
//!   a link period become one IMU sample (their mean rate and specific force,
//!   `delta / dt`), a new pressure reading its pressure, the DVL velocity the node admitted
//!   a [`DvlFix`] on the IMU samples' timeline (the increments' newest sample is
//!   `imu_age_us` before the uplink was sealed, the velocity's time of validity `age_ms`
//!   before it);
//! - [`TopsideLink`]: owns the node link's port; decodes and checks the uplinks, sends a
//!   downlink after every control step (and at least once a link period), measures the
//!   round trip (the downlink's send time, echoed with the node's holding time) and the
//!   uplink's one-way time, places the increments' newest sample on its own clock
//!   ([`ImuStamp`]), and keeps the failsafes below.
//!
//! The board's loop: `app.tick()`, then `if link.poll(now, armed) { app.step_now() }` and
//! `link.send_if_due(now, armed)`: the control step runs when an uplink arrives, so an IMU
//! sample reaches the thrusters one uplink, one step and one downlink later; the App's own
//! period stays the fallback clock when the node is silent.
//!
//! Failsafes (the topside's; the node has its own, `node.rs`):
//!
//! | condition | action | fault bit (`Telemetry.faults`) |
//! | --- | --- | --- |
//! | no valid uplink for 3 link periods (60 ms) | the estimator gets no pressure and, until 250 ms, the last accepted IMU sample again (prediction only) | [`fault::NODE_LINK_LOST`] |
//! | no valid uplink for 250 ms | neutral pulses sent to the node; the estimator gets no IMU sample (its own `SENSOR_LOST` then runs) | [`fault::NODE_LINK_LOST`] |
//! | armed, and the node reports itself latched or timed out to neutral | (the node needs a `Disarmed` then `Armed`: disarm and arm again) | [`fault::NODE_NOT_ARMED`] |
//! | an uplink with NaN, a rate above 40 rad/s, a specific force above 160 m/s^2, a `dt` of 0 or above 4 periods, a pressure outside 10 kPa-4 MPa, a DVL speed above 20 m/s | refused, counted ([`TopsideCounters::bad_data`]); the estimate unchanged | |
//! | an uplink of another session (crossed wires), a repeated or older sequence, another version, a bad CRC | refused, counted | |
//! | after 250 ms without a valid uplink | the next uplink's sequence is taken whatever it is (a node restarted by its watchdog counts from 0) | |

use crate::node_link::{
    check_link_period, default_link_period_us, low_16, seal, seq_newer, status, wire_time_us,
    ArmCommand, Downlink, LinkDecoder, LinkFrame, LinkPeriodError, NodeCounters, Uplink, UplinkDvl,
    ESC_MAX_US, ESC_MIN_US, ESC_NEUTRAL_US, LINK_BAUD, LINK_PERIOD_US, MAX_DOWNLINK_FRAME_LEN,
    MAX_TTL_MS, MAX_UPLINK_FRAME_LEN,
};
use crate::protocol::{DropReason, MAX_FRAME_LEN};
use crate::sensors::Sensors;
use controller_core::nav::{DvlFix, ImuSample};
use core::cell::Cell;
use embedded_hal::pwm::SetDutyCycle;
use embedded_io::{Read, ReadReady, Write, WriteReady};

/// Fault bits of the topside layout, reported in `Telemetry.faults` / `Status.faults`
/// through [`Sensors::faults`]: the two top bits, defined with the others in
/// [`protocol::fault`].
pub mod fault {
    pub use protocol::fault::{NODE_LINK_LOST, NODE_NOT_ARMED};
}

/// Largest rate accepted from the node, rad/s (the ICM-42688-P's range is 2000 deg/s).
pub const MAX_RATE_RAD_S: f32 = 40.0;
/// Largest specific force accepted from the node, m/s^2 (its range is 16 g).
pub const MAX_ACCEL_M_S2: f32 = 160.0;
/// Pressure accepted from the node, Pa (the MS5837-30BA reads to 30 bar).
pub const PRESSURE_RANGE_PA: (f32, f32) = (1.0e4, 4.0e6);
/// Largest DVL speed accepted from the node, mm/s (the A50 reads to 20 m/s).
pub const MAX_DVL_MM_S: i16 = 20_000;

/// The time an uplink's IMU sample is stamped with for the estimator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImuStamp {
    /// The uplink's arrival at the topside: the estimator runs at the topside's clock, one
    /// uplink (latency and wire time) behind the vehicle.
    Arrival,
    /// The node's newest sample of the increments, placed on the topside's clock through
    /// the round trip: the arrival less the uplink's one-way time (half the round trip,
    /// corrected for the two frames' wire times) and the sample's age at sending.
    NodeSample,
}

/// The topside's link settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TopsideConfig {
    /// The topside's session (never 0): from the MCU's unique id and the boot time, so a
    /// restarted topside is a new session.
    pub session: u32,
    /// Downlink at least this often, microseconds.
    pub link_period_us: u32,
    /// Time to live of each command, milliseconds (1..=100).
    pub ttl_ms: u8,
    /// Uplink silence that makes the estimator predict only, in link periods.
    pub silent_periods: u32,
    /// Uplink silence after which neutral is commanded, microseconds.
    pub neutral_after_us: u32,
    /// The link's rate (8N1): the uplink's one-way time from the round trip.
    pub baud: u32,
    /// What an uplink's IMU sample is stamped with.
    pub imu_stamp: ImuStamp,
}

impl TopsideConfig {
    /// At `baud`, the link period of [`default_link_period_us`] (20 ms at 115,200 Bd, 5 ms
    /// at 1 Mbd); otherwise as [`TopsideConfig::new`].
    pub const fn for_baud(session: u32, baud: u32) -> Self {
        let mut c = Self::new(session);
        c.baud = baud;
        c.link_period_us = default_link_period_us(baud);
        c
    }

    /// Check the link period against the node's IMU period and the link's rate.
    pub fn check(&self, imu_period_us: u32) -> Result<(), LinkPeriodError> {
        check_link_period(self.link_period_us, imu_period_us, self.baud)
    }

    /// 50 Hz, 100 ms time to live, prediction only after 3 silent periods, neutral at 250 ms.
    pub const fn new(session: u32) -> Self {
        Self {
            session,
            link_period_us: LINK_PERIOD_US,
            ttl_ms: MAX_TTL_MS,
            silent_periods: 3,
            neutral_after_us: 250_000,
            baud: LINK_BAUD,
            imu_stamp: ImuStamp::Arrival,
        }
    }
}

/// What the App's thrusters and sensors share with the link (a single-threaded loop: cells).
#[derive(Debug)]
pub struct NodeBridge {
    /// Duties written by the App, one per ESC.
    duty: [Cell<u16>; 3],
    /// A duty was written since the last downlink.
    written: Cell<bool>,
    /// Largest duty (the App's `max_duty_cycle`) and the PWM period it spans.
    max_duty: u16,
    period_us: u32,
    /// The latest accepted IMU sample not yet read, and the one read before.
    imu: Cell<Option<ImuSample>>,
    held: Cell<Option<ImuSample>>,
    /// How far the IMU samples' stamps are behind the clock (0: stamped at arrival), and
    /// the latest stamp given (the stamps only go forward).
    lag_us: Cell<u32>,
    last_stamp_us: Cell<Option<u64>>,
    pressure_pa: Cell<Option<f32>>,
    /// The latest DVL velocity from the node not yet read, stamped.
    dvl: Cell<Option<DvlFix>>,
    /// The uplink is silent past the prediction limit / the neutral limit.
    predict_only: Cell<bool>,
    neutral: Cell<bool>,
    faults: Cell<u16>,
}

impl NodeBridge {
    /// A bridge for a PWM period of `period_us` (the App's `pwm_hz`), one duty step a
    /// microsecond; the duties start at neutral; silent (no uplink yet: neutral).
    pub const fn new(period_us: u32) -> Self {
        let max = if period_us > u16::MAX as u32 {
            u16::MAX
        } else {
            period_us as u16
        };
        let n = Cell::new(ESC_NEUTRAL_US);
        Self {
            duty: [n, Cell::new(ESC_NEUTRAL_US), Cell::new(ESC_NEUTRAL_US)],
            written: Cell::new(false),
            max_duty: if max == 0 { 1 } else { max },
            period_us: if period_us == 0 { 1 } else { period_us },
            imu: Cell::new(None),
            held: Cell::new(None),
            lag_us: Cell::new(0),
            last_stamp_us: Cell::new(None),
            pressure_pa: Cell::new(None),
            dvl: Cell::new(None),
            predict_only: Cell::new(true),
            neutral: Cell::new(true),
            faults: Cell::new(fault::NODE_LINK_LOST),
        }
    }

    /// The three ESC outputs for the App.
    pub fn thrusters(&self) -> [LinkThruster<'_>; 3] {
        [0, 1, 2].map(|ch| LinkThruster { bridge: self, ch })
    }

    /// The App's sensors.
    pub fn sensors(&self) -> LinkSensors<'_> {
        LinkSensors { bridge: self }
    }

    /// The pulse widths the App asks for, microseconds, within the ESC's range.
    pub fn pulses_us(&self) -> [u16; 3] {
        let m = u64::from(self.max_duty);
        self.duty.each_ref().map(|d| {
            let p = (u64::from(d.get()) * u64::from(self.period_us) + m / 2) / m;
            p.clamp(u64::from(ESC_MIN_US), u64::from(ESC_MAX_US)) as u16
        })
    }

    /// The topside layout's fault bits now ([`fault`]).
    pub fn faults(&self) -> u16 {
        self.faults.get()
    }
}

/// One ESC of the node, seen from the App.
#[derive(Debug)]
pub struct LinkThruster<'a> {
    bridge: &'a NodeBridge,
    ch: usize,
}

impl embedded_hal::pwm::ErrorType for LinkThruster<'_> {
    type Error = core::convert::Infallible;
}

impl SetDutyCycle for LinkThruster<'_> {
    fn max_duty_cycle(&self) -> u16 {
        self.bridge.max_duty
    }

    /// Kept for the next downlink frame.
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Self::Error> {
        if let Some(d) = self.bridge.duty.get(self.ch) {
            d.set(duty.min(self.bridge.max_duty));
        }
        self.bridge.written.set(true);
        Ok(())
    }
}

/// The node's IMU and pressure sensor, seen from the App.
#[derive(Debug)]
pub struct LinkSensors<'a> {
    bridge: &'a NodeBridge,
}

impl Sensors for LinkSensors<'_> {
    /// The latest uplink's mean rate and specific force, stamped now less the lag of the
    /// configured [`ImuStamp`] (never at or before the previous stamp); while the uplink is
    /// late (up to the neutral limit) the previous sample again, so the estimator keeps
    /// predicting; then nothing.
    fn imu(&mut self, now_us: u64) -> Option<ImuSample> {
        let b = self.bridge;
        let s = match b.imu.take() {
            Some(s) => {
                b.held.set(Some(s));
                s
            }
            None if !b.neutral.get() => b.held.get()?,
            None => return None,
        };
        let t_us = now_us.saturating_sub(u64::from(b.lag_us.get()));
        if b.last_stamp_us.get().is_some_and(|last| t_us <= last) {
            return None;
        }
        b.last_stamp_us.set(Some(t_us));
        Some(ImuSample { t_us, ..s })
    }

    /// A new pressure reading from the node, none while the uplink is silent.
    fn pressure_pa(&mut self, _now_us: u64) -> Option<f32> {
        if self.bridge.predict_only.get() {
            return None;
        }
        self.bridge.pressure_pa.take()
    }

    /// The node's newest admitted DVL velocity, once.
    fn dvl(&mut self, _now_us: u64) -> Option<DvlFix> {
        self.bridge.dvl.take()
    }

    fn faults(&self) -> u16 {
        self.bridge.faults()
    }
}

/// Why an uplink was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum UplinkRefusal {
    /// The framing dropped it (COBS, CRC, length, not an `Uplink`).
    Corrupt(DropReason),
    /// Another link version.
    Version,
    /// The node serves another topside's session.
    Foreign,
    /// The sequence repeats or goes back.
    Replayed,
    /// NaN or a value out of range.
    BadData,
}

/// The topside's counters of uplinks (wrapping).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TopsideCounters {
    /// Uplinks accepted.
    pub accepted: u32,
    /// [`UplinkRefusal::Corrupt`].
    pub corrupt: u32,
    /// [`UplinkRefusal::Version`].
    pub version: u32,
    /// [`UplinkRefusal::Foreign`].
    pub foreign: u32,
    /// [`UplinkRefusal::Replayed`].
    pub replayed: u32,
    /// [`UplinkRefusal::BadData`].
    pub bad_data: u32,
    /// Downlinks sent.
    pub sent: u32,
    /// DVL velocities taken from the node's uplinks (handed to the estimator).
    pub dvl_fixes: u32,
    /// DVL lines and reports the node refused, summed from its wrapping count.
    pub node_dvl_refused: u32,
}

/// Longest round trip taken, microseconds (10 s: the wire model's latency limit, twice;
/// a longer one is an echo of a stale or foreign time).
pub const MAX_ROUND_TRIP_US: u32 = 20_000_000;

/// The topside's end of the node link.
pub struct TopsideLink<'a, S> {
    bridge: &'a NodeBridge,
    serial: S,
    config: TopsideConfig,
    rx: LinkDecoder<Uplink>,
    tx_buf: [u8; MAX_FRAME_LEN],
    tx_sent: usize,
    tx_len: usize,
    /// The latest downlink's sequence (`u64`, from 1, never wrapping).
    tx_seq: u64,
    next_downlink_us: u64,
    last_uplink_us: Option<u64>,
    last_up_seq: Option<u16>,
    last_pressure_count: Option<u8>,
    last_dvl_refused: Option<u8>,
    round_trip_us: Option<u32>,
    one_way_us: Option<u32>,
    node_status: u8,
    node_counters: NodeCounters,
    counters: TopsideCounters,
}

impl<'a, S> TopsideLink<'a, S>
where
    S: Read + ReadReady + Write + WriteReady,
{
    /// The link over `serial`, sharing `bridge` with the App.
    pub fn new(bridge: &'a NodeBridge, serial: S, config: TopsideConfig) -> Self {
        Self {
            bridge,
            serial,
            config,
            rx: LinkDecoder::new(),
            tx_buf: [0; MAX_FRAME_LEN],
            tx_sent: 0,
            tx_len: 0,
            tx_seq: 0,
            next_downlink_us: 0,
            last_uplink_us: None,
            last_up_seq: None,
            last_pressure_count: None,
            last_dvl_refused: None,
            round_trip_us: None,
            one_way_us: None,
            node_status: 0,
            node_counters: NodeCounters::default(),
            counters: TopsideCounters::default(),
        }
    }

    /// Read what the node sent (at most 128 bytes), update the silence failsafes; `true`
    /// when an uplink was accepted (the App's step may run now).
    pub fn poll(&mut self, now: u64, armed: bool) -> bool {
        self.flush_tx();
        // The silence limits first: a sequence restart is taken from the first uplink after
        // 250 ms of silence.
        self.update_faults(now, armed);
        let mut fresh = false;
        let mut budget = 128usize;
        while budget > 0 && self.serial.read_ready().unwrap_or(false) {
            let mut chunk = [0u8; 32];
            let n = match self.serial.read(&mut chunk) {
                Ok(n @ 1..) => n.min(chunk.len()),
                _ => break,
            };
            budget = budget.saturating_sub(n);
            for &b in chunk.get(..n).unwrap_or_default() {
                if let Some(f) = self.rx.push(b) {
                    fresh |= self.on_frame(now, f).is_ok();
                }
            }
        }
        self.update_faults(now, armed);
        fresh
    }

    /// Send a downlink when the App wrote its duties since the last one, or a link period
    /// after it.
    pub fn send_if_due(&mut self, now: u64, armed: bool) {
        if self.bridge.written.get() || now >= self.next_downlink_us {
            self.send_downlink(now, armed);
        }
    }

    /// Check one uplink; an accepted one feeds the bridge.
    #[cfg_attr(feature = "no-panic", no_panic::no_panic)]
    pub fn on_frame(&mut self, now: u64, frame: LinkFrame<Uplink>) -> Result<(), UplinkRefusal> {
        let r = self.check(frame);
        let c = &mut self.counters;
        let counter = match r {
            Ok((seq, up)) => {
                self.accept(now, seq, &up);
                return Ok(());
            }
            Err(UplinkRefusal::Corrupt(_)) => &mut c.corrupt,
            Err(UplinkRefusal::Version) => &mut c.version,
            Err(UplinkRefusal::Foreign) => &mut c.foreign,
            Err(UplinkRefusal::Replayed) => &mut c.replayed,
            Err(UplinkRefusal::BadData) => &mut c.bad_data,
        };
        *counter = counter.wrapping_add(1);
        r.map(|_| ())
    }

    fn check(&self, frame: LinkFrame<Uplink>) -> Result<(u16, Uplink), UplinkRefusal> {
        let (seq, up) = match frame {
            LinkFrame::Frame { seq, msg } => (seq, msg),
            LinkFrame::Dropped(DropReason::Version) => return Err(UplinkRefusal::Version),
            LinkFrame::Dropped(r) => return Err(UplinkRefusal::Corrupt(r)),
        };
        if up.session != 0 && up.session != self.config.session {
            return Err(UplinkRefusal::Foreign);
        }
        if self.last_up_seq.is_some_and(|last| !seq_newer(seq, last)) {
            return Err(UplinkRefusal::Replayed);
        }
        if up.samples > 0 && imu_of(&up, self.config.link_period_us).is_none() {
            return Err(UplinkRefusal::BadData);
        }
        let (lo, hi) = PRESSURE_RANGE_PA;
        let new_pressure = self.last_pressure_count != Some(up.pressure_count);
        if new_pressure && up.pressure_count != 0 && !(lo..=hi).contains(&up.pressure_pa) {
            return Err(UplinkRefusal::BadData);
        }
        let dvl_in_range = |d: &UplinkDvl| {
            d.velocity_mm_s
                .iter()
                .all(|v| v.unsigned_abs() <= MAX_DVL_MM_S.unsigned_abs())
        };
        if up.dvl.as_ref().is_some_and(|d| !dvl_in_range(d)) {
            return Err(UplinkRefusal::BadData);
        }
        Ok((seq, up))
    }

    fn accept(&mut self, now: u64, seq: u16, up: &Uplink) {
        self.counters.accepted = self.counters.accepted.wrapping_add(1);
        self.last_up_seq = Some(seq);
        self.last_uplink_us = Some(now);
        if up.samples > 0 {
            self.bridge.imu.set(imu_of(up, self.config.link_period_us));
        }
        if self.last_pressure_count != Some(up.pressure_count) && up.pressure_count != 0 {
            self.bridge.pressure_pa.set(Some(up.pressure_pa));
        }
        self.last_pressure_count = Some(up.pressure_count);
        // The round trip: the echoed send time carries the node's holding time, so the
        // clock now less it is the two ways' time (both clocks' low 32 bits, wrapping). Only
        // from a node serving this session (0: no downlink applied yet).
        if up.session == self.config.session {
            let rt = (now as u32).wrapping_sub(up.echo_t_us);
            if rt <= MAX_ROUND_TRIP_US {
                self.round_trip_us = Some(rt);
                // One way up: half of it, plus half the difference of the two frames'
                // wire times (the uplink is the longer).
                let up_us = wire_time_us(MAX_UPLINK_FRAME_LEN, self.config.baud);
                let down_us = wire_time_us(MAX_DOWNLINK_FRAME_LEN, self.config.baud);
                let one_way = (rt.saturating_add(up_us).saturating_sub(down_us)) / 2;
                self.one_way_us = Some(one_way.min(rt));
            }
        }
        let lag = match self.config.imu_stamp {
            ImuStamp::Arrival => 0,
            ImuStamp::NodeSample => self
                .one_way_us
                .unwrap_or(0)
                .saturating_add(up.imu_age_us.min(MAX_ROUND_TRIP_US)),
        };
        self.bridge.lag_us.set(lag);
        if let Some(d) = up.dvl {
            // On the IMU samples' timeline: the increments' newest sample is stamped now less
            // the lag, and was `imu_age_us` old at the sealing; the velocity `age_ms` old (never
            // after that sample: the estimator's newest time).
            let imu_age_us = if up.samples > 0 {
                u64::from(up.imu_age_us.min(MAX_ROUND_TRIP_US))
            } else {
                0
            };
            let age_us = u64::from(d.age_ms) * 1_000;
            let t_us = now
                .saturating_sub(u64::from(lag))
                .saturating_sub(age_us.saturating_sub(imu_age_us));
            self.bridge.dvl.set(Some(d.to_fix(t_us)));
            self.counters.dvl_fixes = self.counters.dvl_fixes.wrapping_add(1);
        }
        // The node counts from its boot (0); after a silence (a restarted node) from 0 again.
        let refused = up.counters.dvl_refused;
        let new_refused = refused.wrapping_sub(self.last_dvl_refused.unwrap_or(0));
        self.counters.node_dvl_refused = self
            .counters
            .node_dvl_refused
            .wrapping_add(u32::from(new_refused));
        self.last_dvl_refused = Some(refused);
        self.node_status = up.status;
        self.node_counters = up.counters;
    }

    /// The silence failsafes and the fault bits.
    fn update_faults(&mut self, now: u64, armed: bool) {
        let silent_us = self
            .last_uplink_us
            .map_or(u64::MAX, |t| now.saturating_sub(t));
        let predict = u64::from(self.config.silent_periods) * u64::from(self.config.link_period_us);
        let b = self.bridge;
        b.predict_only.set(silent_us >= predict);
        b.neutral
            .set(silent_us >= u64::from(self.config.neutral_after_us));
        if b.neutral.get() {
            // A node reset by its watchdog numbers its uplinks from 0 again: after 250 ms
            // without a valid uplink, any sequence is taken (the replay check restarts).
            self.last_up_seq = None;
            self.last_dvl_refused = None;
        }
        let mut f = 0;
        if b.predict_only.get() {
            f |= fault::NODE_LINK_LOST;
        }
        let node_off = status::LATCHED | status::TTL_NEUTRAL;
        if armed && self.last_uplink_us.is_some() && self.node_status & node_off != 0 {
            f |= fault::NODE_NOT_ARMED;
        }
        b.faults.set(f);
    }

    /// The next downlink: the App's pulses (neutral once the uplink is silent 250 ms).
    fn send_downlink(&mut self, now: u64, armed: bool) {
        self.update_faults(now, armed);
        let b = self.bridge;
        b.written.set(false);
        let pulse_us = if b.neutral.get() {
            [ESC_NEUTRAL_US; 3]
        } else {
            b.pulses_us()
        };
        let seq = self.tx_seq.saturating_add(1);
        self.tx_seq = seq;
        let cmd = Downlink {
            session: self.config.session,
            seq,
            pulse_us,
            ttl_ms: self.config.ttl_ms.clamp(1, MAX_TTL_MS),
            arm: if armed {
                ArmCommand::Armed
            } else {
                ArmCommand::Disarmed
            },
            t_us: now as u32,
        };
        self.next_downlink_us = now.saturating_add(u64::from(self.config.link_period_us));
        // A frame still going out is cut short: the node drops it and takes this one.
        (self.tx_sent, self.tx_len) = match seal(low_16(seq), &cmd, &mut self.tx_buf) {
            Ok(f) => (0, f.len()),
            Err(_) => (0, 0),
        };
        self.counters.sent = self.counters.sent.wrapping_add(1);
        self.flush_tx();
    }

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

    /// The latest round trip (a downlink sent -> its echo back, less the node's holding
    /// time), microseconds.
    pub fn round_trip_us(&self) -> Option<u32> {
        self.round_trip_us
    }

    /// The latest uplink's one-way time (from the round trip), microseconds.
    pub fn one_way_us(&self) -> Option<u32> {
        self.one_way_us
    }

    /// The node's latest status bits and counters.
    pub fn node_report(&self) -> (u8, NodeCounters) {
        (self.node_status, self.node_counters)
    }

    /// The topside's counters.
    pub fn counters(&self) -> TopsideCounters {
        self.counters
    }

    /// The port (for tests and the board).
    pub fn serial_mut(&mut self) -> &mut S {
        &mut self.serial
    }
}

/// The mean rate and specific force of an uplink's increments, or `None` when a value is
/// NaN, infinite or out of range, or `dt` is 0 or longer than four link periods.
fn imu_of(up: &Uplink, link_period_us: u32) -> Option<ImuSample> {
    if up.dt_us == 0 || u64::from(up.dt_us) > 4 * u64::from(link_period_us) {
        return None;
    }
    let dt_s = up.dt_us as f32 * 1e-6;
    let mean = |d: [f32; 3], max: f32| {
        let m = d.map(|x| x / dt_s);
        m.iter().all(|x| x.abs() <= max).then_some(m) // NaN fails the comparison
    };
    Some(ImuSample {
        t_us: 0,
        gyro_rad_s: mean(up.delta_angle_rad, MAX_RATE_RAD_S)?,
        accel_m_s2: mean(up.delta_velocity_m_s, MAX_ACCEL_M_S2)?,
    })
}

#[cfg(test)]
mod tests;
