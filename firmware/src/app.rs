//! The application: the [`Autopilot`] behind three PWM outputs, a serial port and a clock.
//!
//! Generic over `embedded_hal::pwm::SetDutyCycle` (the ESCs), `embedded_io`
//! `Read + ReadReady + Write` (the tether) and [`Monotonic`] (time), so the same code runs on the STM32F4, on
//! QEMU and in the host tests with fakes.
//!
//! Two timings ([`Timing`]):
//! - **fixed-rate**: call [`App::tick`] often; it reads every waiting byte, runs the control
//!   step every `control_period_us` of the board's clock and sends telemetry every
//!   `telemetry_period_us`;
//! - **lock-step** (hardware in the loop): the firmware's clock is the host's time, i.e. the
//!   latest `t_us` received in a `Heartbeat` or `NavState`; each `NavState` runs one control
//!   step at once and is answered by a `Telemetry` that carries the thruster commands. The
//!   failsafes then run in simulated time, deterministically.

use crate::autopilot::{Autopilot, Failsafe, StepOutput};
use crate::protocol::{
    encode, fault, Board, Command, Decoded, DropReason, FrameDecoder, LinkStats, NackReason, Reply,
    Status, Telemetry, MAX_FRAME_LEN,
};
use crate::sensors::{NoSensors, Sensors};
use controller_core::alloc::{PwmMap, ESC_MAX_US, ESC_MIN_US, ESC_NEUTRAL_US};
use controller_core::controller::Controller;
use embedded_hal::pwm::SetDutyCycle;
use embedded_io::{Read, ReadReady, Write, WriteReady};
use heapless::Deque;

/// Bytes read from the serial port at a time (on the stack, then to the decoder).
const RX_CHUNK: usize = 64;

/// Replies waiting for the serial port behind the frame being sent.
pub const TX_QUEUE_LEN: usize = 4;

/// Fixed-rate mode: how far a surface time stamp (`Nav`, `Imu`, `Pressure`) may run ahead
/// of the previous one of its kind beyond the time that passed on the vehicle's clock
/// (0.5 s: the tether's jitter and the clocks' drift are milliseconds). One frame stamped
/// far ahead is refused `ClockAhead` and moves nothing (issue 22).
pub const STAMP_AHEAD_TOLERANCE_US: u64 = 500_000;

/// Lock-step mode: the largest step of the host's clock one frame may make (1 s; the
/// simulation steps 20 ms). A frame stamped further ahead is refused `ClockAhead`, so one
/// frame cannot move the firmware's time (and its failsafe timers) an hour on. The first
/// stamped frame after boot sets the time base (the host's time starts where it starts; the
/// vehicle is disarmed then).
pub const LOCKSTEP_MAX_STEP_US: u64 = 1_000_000;

/// Session numbers are 14 bits (1..=16383).
const SESSION_MASK: u32 = 0x3FFF;

/// The latest accepted surface time stamp of one kind and the vehicle's time it came at.
#[derive(Debug, Clone, Copy, Default)]
struct Stamp {
    /// `(stamp, vehicle time)`; `None` before the first of the session.
    last: Option<(u64, u64)>,
}

impl Stamp {
    /// The surface clock now, as projected from the latest stamp by the vehicle's clock.
    fn projected(&self, now_us: u64) -> Option<u64> {
        self.last
            .map(|(t, rx)| t.saturating_add(now_us.saturating_sub(rx)))
    }

    /// True when `t_us` is not too far ahead of the projection (the first stamp of a session
    /// sets it).
    fn ok(&self, t_us: u64, now_us: u64) -> bool {
        self.projected(now_us)
            .is_none_or(|p| t_us <= p.saturating_add(STAMP_AHEAD_TOLERANCE_US))
    }

    /// Take `t_us` (accepted) at `now_us`.
    fn take(&mut self, t_us: u64, now_us: u64) {
        let p = self.projected(now_us).unwrap_or(t_us);
        self.last = Some((t_us.max(p), now_us));
    }
}

/// A monotonic clock.
pub trait Monotonic {
    /// Microseconds since an arbitrary origin; never decreases.
    fn now_us(&mut self) -> u64;
    /// A free-running counter for loop timing (wraps). Default: microseconds.
    fn ticks(&mut self) -> u32 {
        self.now_us() as u32
    }
}

/// When the control step runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Timing {
    /// On the board's clock.
    FixedRate {
        /// Control period, microseconds.
        control_period_us: u32,
        /// Telemetry period, microseconds (0 = no periodic telemetry).
        telemetry_period_us: u32,
    },
    /// On each `NavState`, in the host's time.
    LockStep,
}

/// Application settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Config {
    /// Timing.
    pub timing: Timing,
    /// PWM frequency, 50 to 400 Hz.
    pub pwm_hz: u16,
    /// Failsafe timeouts.
    pub failsafe: Failsafe,
    /// Which board (reported in `Hello`).
    pub board: Board,
    /// Most bytes read from the serial port per `tick` (bounds the loop time).
    pub max_rx_bytes_per_tick: usize,
}

impl Config {
    /// 50 Hz control, 10 Hz telemetry, 50 Hz PWM, the specified failsafes.
    pub const fn fixed_rate(board: Board) -> Self {
        Self {
            timing: Timing::FixedRate {
                control_period_us: 20_000,
                telemetry_period_us: 100_000,
            },
            pwm_hz: 50,
            failsafe: Failsafe::DEFAULT,
            board,
            max_rx_bytes_per_tick: 512,
        }
    }

    /// Lock-step (HIL), 50 Hz PWM, the specified failsafes.
    pub const fn lockstep(board: Board) -> Self {
        Self {
            timing: Timing::LockStep,
            ..Self::fixed_rate(board)
        }
    }

    /// PWM period, microseconds.
    pub fn pwm_period_us(&self) -> u32 {
        1_000_000 / u32::from(self.pwm_hz.max(1))
    }
}

/// Why the application could not start.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum ConfigError {
    /// PWM frequency outside 50-400 Hz.
    PwmFrequency,
    /// A PWM output has a zero maximum duty.
    PwmResolution,
    /// A zero control period.
    ControlPeriod,
}

impl core::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ConfigError::PwmFrequency => write!(f, "PWM frequency must be 50-400 Hz"),
            ConfigError::PwmResolution => write!(f, "PWM output with zero max duty"),
            ConfigError::ControlPeriod => write!(f, "control period must be > 0"),
        }
    }
}

impl core::error::Error for ConfigError {}

/// Duty for a pulse width: `pulse_us / period_us * max_duty`, rounded, with the pulse clamped
/// to the map's `[min_us, max_us]` and then to the ESC's range first (NaN -> the ESC's
/// neutral, [`ESC_NEUTRAL_US`]): no pulse outside 1100-1900 us ever reaches an output.
pub fn duty_for_pulse(pulse_us: f32, map: &PwmMap, period_us: u32, max_duty: u16) -> u16 {
    use controller_core::math::clamp;
    // `math::clamp`, not `f32::clamp`: the bounds come from the PWM map at run time, and
    // `f32::clamp` panics when `min > max`; the firmware has no panic path.
    let p = if pulse_us.is_nan() {
        ESC_NEUTRAL_US
    } else {
        clamp(
            clamp(pulse_us, map.min_us, map.max_us),
            ESC_MIN_US,
            ESC_MAX_US,
        )
    };
    // `as` saturates (a negative pulse is 0 us).
    let p = u64::from((p + 0.5) as u32);
    let period = u64::from(period_us.max(1));
    let max = u64::from(max_duty);
    ((p * max + period / 2) / period).min(max) as u16
}

/// Pulse width a duty gives, microseconds (what the ESC sees), rounded.
pub fn pulse_for_duty(duty: u16, period_us: u32, max_duty: u16) -> u16 {
    let m = u64::from(max_duty.max(1));
    let p = (u64::from(duty) * u64::from(period_us) + m / 2) / m;
    p.min(u64::from(u16::MAX)) as u16
}

/// The application.
pub struct App<P, S, C, N = NoSensors> {
    sensors: N,
    /// The ESCs of `F1x`, `F2x`, `F3z`.
    pwm: [P; 3],
    serial: S,
    clock: C,
    config: Config,
    autopilot: Autopilot,
    decoder: FrameDecoder<Command>,
    tx_seq: u16,
    /// The frame being sent (kept here, not on the stack: not zeroed for every frame).
    tx_buf: [u8; MAX_FRAME_LEN],
    /// Replies waiting for the port; the one being sent is encoded in `tx_buf`, of which
    /// `tx_sent..tx_len` is still to go. The loop hands the port what it takes, never waits.
    tx_queue: Deque<(u16, Reply), TX_QUEUE_LEN>,
    tx_sent: usize,
    tx_len: usize,
    control_late_max_us: u32,
    link: LinkStats,
    /// The surface session in force (0: none), sessions opened since boot, and the sequence
    /// number of the latest frame taken in the session.
    session: u32,
    sessions_opened: u32,
    last_seq: u16,
    /// Fixed-rate mode: the latest `Nav`, `Imu` and `Pressure` stamps of the session.
    stamps: [Stamp; 3],
    host_time_us: u64,
    /// Lock-step: a stamped command was taken since boot (the first one sets the host's
    /// time base, wherever it starts; later ones step it by at most `LOCKSTEP_MAX_STEP_US`).
    host_clock_set: bool,
    next_control_us: Option<u64>,
    next_telemetry_us: u64,
    last: StepOutput,
    duty: [u16; 3],
    io_faults: u16,
    loop_ticks: u32,
    loop_ticks_max: u32,
    /// Ticks of work (decoding, commands, sensors, control, telemetry) since the last control
    /// step, and the start of the work segment in progress.
    busy_ticks: u32,
    work_t0: u32,
    overruns: u32,
}

impl<P, S, C> App<P, S, C, NoSensors>
where
    P: SetDutyCycle,
    S: Read + ReadReady + Write + WriteReady,
    C: Monotonic,
{
    /// An application without sensors on its buses; see [`with_sensors`](Self::with_sensors).
    pub fn new(
        pwm: [P; 3],
        serial: S,
        clock: C,
        controller: Controller,
        config: Config,
    ) -> Result<Self, ConfigError> {
        Self::with_sensors(pwm, serial, clock, controller, config, NoSensors)
    }
}

impl<P, S, C, N> App<P, S, C, N>
where
    P: SetDutyCycle,
    S: Read + ReadReady + Write + WriteReady,
    C: Monotonic,
    N: Sensors,
{
    /// Check the settings, set the three outputs to neutral, boot disarmed; `sensors` feed
    /// the on-board estimator before each control step once the surface has started it.
    pub fn with_sensors(
        pwm: [P; 3],
        serial: S,
        clock: C,
        controller: Controller,
        config: Config,
        sensors: N,
    ) -> Result<Self, ConfigError> {
        if !(50..=400).contains(&config.pwm_hz) {
            return Err(ConfigError::PwmFrequency);
        }
        if pwm.iter().any(|p| p.max_duty_cycle() == 0) {
            return Err(ConfigError::PwmResolution);
        }
        if let Timing::FixedRate {
            control_period_us: 0,
            ..
        } = config.timing
        {
            return Err(ConfigError::ControlPeriod);
        }
        // Neutral on the three outputs before anything else, then the `App` is built in
        // its final place (no moves of it: it holds two frame buffers, see `build_app` in
        // `board.rs` for why that matters to the stack).
        let mut pwm = pwm;
        let neutral = StepOutput {
            pulse_us: [ESC_NEUTRAL_US; 3],
            ..StepOutput::default()
        };
        let (duty, ok) = set_duties(
            &mut pwm,
            controller.pwm_map(),
            config.pwm_period_us(),
            neutral.pulse_us,
        );
        Ok(Self {
            pwm,
            serial,
            clock,
            config,
            sensors,
            autopilot: Autopilot::new(controller, config.failsafe),
            decoder: FrameDecoder::new(),
            tx_seq: 0,
            tx_buf: [0; MAX_FRAME_LEN],
            tx_queue: Deque::new(),
            tx_sent: 0,
            tx_len: 0,
            control_late_max_us: 0,
            link: LinkStats::default(),
            session: 0,
            sessions_opened: 0,
            last_seq: 0,
            stamps: [Stamp::default(); 3],
            host_time_us: 0,
            host_clock_set: false,
            next_control_us: None,
            next_telemetry_us: 0,
            last: neutral,
            duty,
            io_faults: if ok { 0 } else { fault::PWM_ERROR },
            loop_ticks: 0,
            loop_ticks_max: 0,
            busy_ticks: 0,
            work_t0: 0,
            overruns: 0,
        })
    }

    /// Send the `Hello` frame (call once at boot, after the serial port is up).
    pub fn hello(&mut self) {
        let (lockstep, period) = match self.config.timing {
            Timing::LockStep => (true, 0),
            Timing::FixedRate {
                control_period_us, ..
            } => (false, control_period_us),
        };
        self.send(&Reply::Hello {
            protocol: crate::protocol::PROTOCOL_VERSION,
            board: self.config.board,
            lockstep,
            control_period_us: period,
            pwm_hz: self.config.pwm_hz,
        });
    }

    /// The state machine (read-only).
    pub fn autopilot(&self) -> &Autopilot {
        &self.autopilot
    }

    /// Duties last written to the three outputs.
    pub fn duties(&self) -> [u16; 3] {
        self.duty
    }

    /// The output of the latest step.
    pub fn last_output(&self) -> &StepOutput {
        &self.last
    }

    /// Link counters.
    pub fn link_stats(&self) -> LinkStats {
        let mut l = self.link;
        l.rx_frames = self.decoder.frames;
        l.dropped = self.decoder.dropped;
        l
    }

    /// The PWM outputs, serial port and clock (for tests and the board).
    pub fn parts_mut(&mut self) -> (&mut [P; 3], &mut S, &mut C) {
        (&mut self.pwm, &mut self.serial, &mut self.clock)
    }

    /// Firmware time: the board's clock (fixed-rate) or the host's time (lock-step).
    pub fn now_us(&mut self) -> u64 {
        match self.config.timing {
            Timing::FixedRate { .. } => self.clock.now_us(),
            Timing::LockStep => self.host_time_us,
        }
    }

    /// One pass of the main loop: read and handle every waiting frame (at most
    /// `max_rx_bytes_per_tick` bytes), then, in fixed-rate mode, run the control step and
    /// the telemetry when they are due.
    pub fn tick(&mut self) {
        self.flush_tx();
        let mut budget = self.config.max_rx_bytes_per_tick;
        while budget > 0 && serial_ok(&mut self.io_faults, self.serial.read_ready()) == Some(true) {
            let mut chunk = [0u8; RX_CHUNK];
            let want = chunk.get_mut(..budget.min(RX_CHUNK)).unwrap_or_default();
            let Some(n @ 1..) = serial_ok(&mut self.io_faults, self.serial.read(want)) else {
                break;
            };
            let n = n.min(want.len());
            budget = budget.saturating_sub(n);
            self.work_t0 = self.clock.ticks();
            self.on_bytes(chunk.get(..n).unwrap_or_default());
            self.end_work();
        }
        if let Timing::FixedRate {
            control_period_us,
            telemetry_period_us,
        } = self.config.timing
        {
            self.work_t0 = self.clock.ticks();
            let now = self.clock.now_us();
            let period = u64::from(control_period_us);
            let due = *self.next_control_us.get_or_insert(now);
            if now >= due {
                let late = now - due;
                let late_us = u32::try_from(late).unwrap_or(u32::MAX);
                self.control_late_max_us = self.control_late_max_us.max(late_us);
                if late >= period {
                    self.overruns = self.overruns.wrapping_add(1);
                    self.next_control_us = Some(now + period);
                } else {
                    self.next_control_us = Some(due + period);
                }
                self.read_sensors(now);
                self.control(now);
            }
            if telemetry_period_us > 0 && now >= self.next_telemetry_us {
                self.next_telemetry_us = now + u64::from(telemetry_period_us);
                self.send_telemetry(now);
            }
            self.end_work();
        }
    }

    /// Run the control step now (fixed-rate timing), the sensors read first, and restart the
    /// period from now. The topside layout (issue 25, `topside_link.rs`) steps when the
    /// node's uplink arrives; the period stays the fallback when the node is silent. Nothing
    /// in lock-step, where the host's `Nav` runs the step.
    pub fn step_now(&mut self) {
        let Timing::FixedRate {
            control_period_us, ..
        } = self.config.timing
        else {
            return;
        };
        self.work_t0 = self.clock.ticks();
        let now = self.clock.now_us();
        self.next_control_us = Some(now.saturating_add(u64::from(control_period_us)));
        self.read_sensors(now);
        self.control(now);
        self.end_work();
    }

    /// Feed the on-board estimator from the MCU's own sensors (when it runs). A missing or
    /// refused reading changes nothing; the estimator's timeouts raise `SENSOR_LOST`.
    fn read_sensors(&mut self, now: u64) {
        self.read_dvl(now);
        if self.autopilot.onboard_nav().is_none() {
            return;
        }
        if let Some(imu) = self.sensors.imu(now) {
            let _ = self.autopilot.handle_nav(now, 0, &Command::Imu(imu));
        }
        if let Some(pressure_pa) = self.sensors.pressure_pa(now) {
            let cmd = Command::Pressure {
                t_us: now,
                pressure_pa,
            };
            let _ = self.autopilot.handle_nav(now, 0, &cmd);
        }
    }

    /// Drain the DVL's port (if the sensors have one) and feed an admitted velocity to the
    /// on-board estimator as a tether `DvlFix` would be (refused without one).
    fn read_dvl(&mut self, now: u64) {
        if let Some(fix) = self.sensors.dvl(now) {
            let _ = self.autopilot.handle_nav(now, 0, &Command::DvlFix(fix));
        }
    }

    /// Close a work segment (see [`Telemetry::loop_ticks`]).
    fn end_work(&mut self) {
        let dt = self.clock.ticks().wrapping_sub(self.work_t0);
        self.busy_ticks = self.busy_ticks.wrapping_add(dt);
    }

    /// Feed received bytes to the decoder and act on every completed frame, in order.
    pub fn on_bytes(&mut self, mut bytes: &[u8]) {
        while !bytes.is_empty() {
            let d = self.decoder.push_slice(&mut bytes);
            self.on_decoded(d);
        }
    }

    /// Act on what the decoder made of a delimiter. A function of its own: folded into
    /// `on_bytes`, it cost 40 B of stack and 0.5 KiB of flash (measured 2026-11-25).
    fn on_decoded(&mut self, d: Option<Decoded<Command>>) {
        match d {
            None | Some(Decoded::Dropped { seq: None, .. }) => {}
            Some(Decoded::Frame { seq, session, msg }) => self.on_frame(seq, session, &msg),
            Some(Decoded::Dropped {
                reason,
                seq: Some(seq),
            }) => {
                let reason = match reason {
                    DropReason::Version => NackReason::UnsupportedVersion,
                    _ => NackReason::Malformed,
                };
                self.nack(seq, reason);
            }
        }
    }

    /// The session's gate (issue 22): `OpenSession` opens a new one at any time; any other
    /// frame must carry the session in force and a sequence number above the last one
    /// taken in it (the surface opens a new session before its numbers wrap), or it is
    /// refused and counted, and changes nothing.
    fn on_frame(&mut self, seq: u16, session: u32, cmd: &Command) {
        if let Command::OpenSession { nonce } = *cmd {
            return self.open_session(seq, nonce);
        }
        if session == 0 || session != self.session {
            self.link.no_session = self.link.no_session.wrapping_add(1);
            return self.nack(seq, NackReason::NoSession);
        }
        if seq <= self.last_seq {
            self.link.replayed = self.link.replayed.wrapping_add(1);
            return self.nack(seq, NackReason::Replayed);
        }
        self.last_seq = seq;
        self.on_command(seq, cmd);
    }

    /// Open a session: a number never 0 and not the previous one's, mixed from the surface's
    /// nonce and a count of the sessions (so a recording of an earlier session does not
    /// match a later one); the `OpenSession`'s own number starts the sequence.
    fn open_session(&mut self, seq: u16, nonce: u32) {
        self.sessions_opened = self.sessions_opened.wrapping_add(1);
        // 14 bits: a two-byte varint in every envelope (a full u32 is five, and each byte
        // costs every frame's decoding).
        let mut id = (nonce ^ self.sessions_opened.wrapping_mul(0x9E37_79B9)) & SESSION_MASK;
        if id == 0 || id == self.session {
            id = (id.wrapping_add(0x2F1B) & SESSION_MASK) | 1;
        }
        self.session = id;
        self.last_seq = seq;
        self.stamps = [Stamp::default(); 3];
        self.autopilot.new_session();
        self.send(&Reply::Session { nonce, session: id });
    }

    /// The surface stamp of a command and which [`Stamp`] slot checks it in fixed-rate mode.
    fn stamp_of(cmd: &Command) -> Option<(u64, Option<usize>)> {
        match cmd {
            Command::Heartbeat { t_us } | Command::Step { t_us } => Some((*t_us, None)),
            Command::Nav(n) => Some((n.t_us, Some(0))),
            Command::Imu(s) => Some((s.t_us, Some(1))),
            Command::Pressure { t_us, .. } => Some((*t_us, Some(2))),
            _ => None,
        }
    }

    fn on_command(&mut self, seq: u16, cmd: &Command) {
        let lockstep = self.config.timing == Timing::LockStep;
        let stamp = Self::stamp_of(cmd);
        let now = if lockstep {
            // The host's clock: the latest time stamp of an accepted stamped command (never
            // goes back, never jumps more than `LOCKSTEP_MAX_STEP_US`; a refused command
            // does not move it).
            let t = stamp.map_or(0, |(t, _)| t);
            let started = self.host_clock_set;
            if started && t > self.host_time_us.saturating_add(LOCKSTEP_MAX_STEP_US) {
                return self.nack(seq, NackReason::ClockAhead);
            }
            self.host_time_us.max(t)
        } else {
            self.clock.now_us()
        };
        let slot = match stamp {
            Some((t, Some(k))) if !lockstep => Some((t, k)),
            _ => None,
        };
        if let Some((t, k)) = slot {
            if !self.stamps.get(k).is_some_and(|s| s.ok(t, now)) {
                return self.nack(seq, NackReason::ClockAhead);
            }
        }
        if matches!(cmd, Command::Imu(_) | Command::Pressure { .. }) && self.sensors.own_sensors() {
            return self.nack(seq, NackReason::OwnSensors);
        }
        if matches!(cmd, Command::Step { .. }) && !lockstep {
            return self.nack(seq, NackReason::Unsupported);
        }
        let handled = match cmd {
            Command::StartNav { .. }
            | Command::Imu(_)
            | Command::Pressure { .. }
            | Command::UsblFix(_)
            | Command::DvlFix(_)
            | Command::Compass(_)
            | Command::SetCompassCal(_) => self.autopilot.handle_nav(now, seq, cmd),
            _ => self.autopilot.handle(now, seq, cmd),
        };
        if let Err(reason) = handled {
            return self.nack(seq, reason);
        }
        if let Some((t, k)) = slot {
            if let Some(s) = self.stamps.get_mut(k) {
                s.take(t, now);
            }
        }
        if lockstep {
            // Moves only for a command with a later time stamp (`now` is the host's time
            // otherwise).
            self.host_time_us = now;
            self.host_clock_set |= stamp.is_some();
        }
        match cmd {
            Command::Heartbeat { .. } => {
                let status = self.status(now, seq);
                self.send(&Reply::Status(status));
            }
            // High-rate inputs: no `Ack` (a refusal is still answered by a `Nack`).
            Command::ManualThrust(_) | Command::Imu(_) | Command::Pressure { .. } => {}
            Command::Nav(_) | Command::Step { .. } => {
                if lockstep {
                    self.read_dvl(now);
                    self.control(now);
                    self.send_telemetry(now);
                }
            }
            Command::Disarm => {
                // Neutral at once, not at the next step.
                self.last = self.autopilot.neutral(0);
                self.write_pwm(self.last.pulse_us);
                self.send(&Reply::Ack { seq });
            }
            _ => self.send(&Reply::Ack { seq }),
        }
    }

    /// Run the control step at `now` and write the outputs.
    /// The loop iteration it ends is all the work since the previous step: the frames
    /// decoded and handled (sensor readings and fixes into the estimator), this step, and the
    /// telemetry sent in between; idle polling is not counted.
    fn control(&mut self, now: u64) {
        self.last = self.autopilot.step(now);
        self.write_pwm(self.last.pulse_us);
        let t = self.clock.ticks();
        let dt = self.busy_ticks.wrapping_add(t.wrapping_sub(self.work_t0));
        (self.busy_ticks, self.work_t0) = (0, t);
        self.loop_ticks = dt;
        self.loop_ticks_max = self.loop_ticks_max.max(dt);
    }

    fn write_pwm(&mut self, pulse_us: [f32; 3]) {
        let map = *self.autopilot.controller().pwm_map();
        let period = self.config.pwm_period_us();
        let (duty, ok) = set_duties(&mut self.pwm, &map, period, pulse_us);
        if !ok {
            self.io_faults |= fault::PWM_ERROR;
        }
        self.duty = duty;
    }

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
        }
    }

    /// Fault flags now: the latest step's, the I/O ones and the overrun flag.
    fn faults(&self) -> u16 {
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
        }
    }

    fn send_telemetry(&mut self, now: u64) {
        let t = self.telemetry(now);
        self.send(&Reply::Telemetry(t));
    }

    fn nack(&mut self, seq: u16, reason: NackReason) {
        self.link.nacks = self.link.nacks.wrapping_add(1);
        self.send(&Reply::Nack { seq, reason });
    }

    /// Queue a reply (with its sequence number, given now) and hand the port what it takes.
    /// A reply that finds the queue full is dropped whole and counted (`tx_dropped`).
    fn send(&mut self, reply: &Reply) {
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
    fn flush_tx(&mut self) {
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

/// `r`'s value, or `None` with [`fault::SERIAL_ERROR`] raised in `faults`.
fn serial_ok<T, E>(faults: &mut u16, r: Result<T, E>) -> Option<T> {
    r.map_err(|_| *faults |= fault::SERIAL_ERROR).ok()
}

/// Write the duty cycles for `pulse_us` (ESC pulse widths, microseconds) to the three
/// outputs; returns the duties and whether every output took its duty.
fn set_duties<P: SetDutyCycle>(
    pwm: &mut [P; 3],
    map: &PwmMap,
    period_us: u32,
    pulse_us: [f32; 3],
) -> ([u16; 3], bool) {
    let mut duty = [0; 3];
    let mut ok = true;
    for ((d, o), p) in duty.iter_mut().zip(pwm).zip(pulse_us) {
        *d = duty_for_pulse(p, map, period_us, o.max_duty_cycle());
        ok &= o.set_duty_cycle(*d).is_ok();
    }
    (duty, ok)
}
