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

mod duty;
mod pwm;
mod serial_fault;
mod session;
mod stamp;
mod telemetry;

use duty::set_duties;
pub use duty::{duty_for_pulse, pulse_for_duty};
use serial_fault::serial_ok;
use stamp::Stamp;
pub use stamp::STAMP_AHEAD_TOLERANCE_US;

use crate::autopilot::{Autopilot, Failsafe, StepOutput};
use crate::protocol::{
    fault, Board, Command, Decoded, DropReason, FrameDecoder, LinkStats, NackReason, Reply,
    MAX_FRAME_LEN,
};
use crate::sensors::{NoSensors, Sensors};
use controller_core::alloc::ESC_NEUTRAL_US;
use controller_core::controller::Controller;
use embedded_hal::pwm::SetDutyCycle;
use embedded_io::{Read, ReadReady, Write, WriteReady};
use heapless::Deque;

/// Bytes read from the serial port at a time (on the stack, then to the decoder).
const RX_CHUNK: usize = 64;

/// Replies waiting for the serial port behind the frame being sent.
pub const TX_QUEUE_LEN: usize = 4;

/// Lock-step mode: the largest step of the host's clock one frame may make (1 s; the
/// simulation steps 20 ms). A frame stamped further ahead is refused `ClockAhead`, so one
/// frame cannot move the firmware's time (and its failsafe timers) an hour on. The first
/// stamped frame after boot sets the time base (the host's time starts where it starts; the
/// vehicle is disarmed then).
pub const LOCKSTEP_MAX_STEP_US: u64 = 1_000_000;

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

    /// Load the vehicle's stored health parameters (a board reads them from its flash at
    /// boot); checked and refused as a `SetHealth` from the surface is.
    pub fn set_health_params(
        &mut self,
        params: &crate::protocol::HealthParams,
    ) -> Result<(), NackReason> {
        let now = self.now_us();
        self.autopilot.handle(now, 0, &Command::SetHealth(*params))
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

    /// Every reply handed to the port: none queued, none partly written.
    pub fn replies_sent(&self) -> bool {
        self.tx_queue.is_empty() && self.tx_sent >= self.tx_len
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
    /// period from now. The topside layout (`topside_link.rs`) steps when the
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
        self.read_health(now);
        if self.autopilot.onboard_nav().is_none() {
            return;
        }
        if let Some(imu) = self.sensors.imu(now) {
            let _ =
                self.autopilot
                    .handle_nav(now, crate::autopilot::OWN_READING, &Command::Imu(imu));
        }
        if let Some(pressure_pa) = self.sensors.pressure_pa(now) {
            let cmd = Command::Pressure {
                t_us: now,
                pressure_pa,
            };
            let _ = self
                .autopilot
                .handle_nav(now, crate::autopilot::OWN_READING, &cmd);
        }
    }

    /// Drain the DVL's port (if the sensors have one) and feed an admitted velocity to the
    /// on-board estimator as a tether `DvlFix` would be (refused without one).
    fn read_dvl(&mut self, now: u64) {
        if let Some(fix) = self.sensors.dvl(now) {
            let _ = self.autopilot.handle_nav(
                now,
                crate::autopilot::OWN_READING,
                &Command::DvlFix(fix),
            );
        }
    }

    /// Read the health inputs and run the health checks, which may switch to SURFACE or
    /// disarm before this step; on a board without health inputs the depth limit's warning
    /// is still checked.
    fn read_health(&mut self, now: u64) {
        let s = self.sensors.health(now).unwrap_or_default();
        self.autopilot.health_check(now, &s);
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
                    self.read_health(now);
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
}
