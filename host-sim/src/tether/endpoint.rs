//! Hardware in the loop: the real firmware (in QEMU, or on a board over serial or TCP)
//! closes the loop around the simulated vehicle, in lock-step simulated time.
//!
//! ```text
//! host-sim hil <scenario> [--qemu ELF | --serial DEVICE --baud N | --tcp HOST:PORT | --in-process]
//! ```
//!
//! With `--qemu`, the host binds `127.0.0.1:0`, starts `qemu-system-arm -M netduinoplus2`
//! with the image, its USART1 on that socket (`-serial tcp:127.0.0.1:PORT,nodelay=on`) and
//! `-icount shift=0,align=off,sleep=off` (deterministic: one instruction per emulated
//! nanosecond), and owns the child (killed on drop, also when the host panics). It waits for
//! the firmware's `Hello` (the emulated USART drops bytes sent before it is enabled).
//!
//! Each control period `k` (time `t = k * control_period_s`, the firmware's clock in
//! lock-step mode):
//! 1. the host sends `Heartbeat { t }` (unless the scenario of a link-loss test stopped
//!    them) and `Nav { t, measurement }`;
//! 2. the firmware runs one control step and answers with `Telemetry`, whose pulse widths
//!    are what its PWM outputs were set to;
//! 3. the plant applies the thrust those pulses make (the ESC map of the core,
//!    [`PwmMap::thrust_n`]) for one period.
//!
//! The loop itself is [`crate::closed_loop`]'s, the same as a software run's; this module is
//! the controller endpoint at the far end of the tether ([`TetherEndpoint`]). With
//! `--in-process` that far end is the firmware library's `App` in this process
//! ([`crate::tether::in_process`]), so the whole data path runs without an emulator.
//!
//! A frame lost on the way (noise injection) is detected by a reply timeout and sent again
//! with the same sequence number. Outputs: the same `summary.json` (plus a `hil` object with
//! the link statistics), `timeseries.csv` and plots as `host-sim run`, and
//! `telemetry.csv` with what the firmware reported each step.

use crate::closed_loop::{ratio, ControllerEndpoint, StepReply};
use crate::tether::board_wires::BoardWires;
use crate::tether::link::{Link, Noise};
use crate::tether::measurement::command_of;
pub use crate::tether::options::{
    HilOptions, HilTarget, DEFAULT_NAV_READY_LIMIT_S, MAX_REPLY_WAIT,
};
pub use crate::tether::report::{HilOutput, HilReport, TelemetryRow};
use anyhow::{anyhow, bail, Result};
use controller_core::alloc::PwmMap;
use controller_core::nav::onboard::OnboardConfig;
use controller_core::nav::POSITION_READY_STD_M;
use controller_core::params::VehicleParams;
use controller_core::reference::{RefSample, Reference};
use controller_core::state::NavState;
use firmware::protocol::{
    fault, Command, LinkStats, Mode, NackReason, NavSample, Reply, Telemetry,
};
use sim_scenario::setup::RunSetup;
use sim_world::clock::us;
use sim_world::sensors::NavSource;
use sim_world::sensors::{DvlWire, Measurement};
use std::time::{Duration, Instant};

/// The firmware at the other end of the tether as the loop's controller: each control tick
/// is one lock-step exchange (`Heartbeat` and `Nav` out, `Telemetry` back), sent again with
/// the same sequence numbers until answered.
pub struct TetherEndpoint {
    link: Link,
    mode: Mode,
    reference: Reference,
    noise: Option<Noise>,
    pwm: PwmMap,
    /// The scenario's vehicle, sent to the firmware at the start.
    vehicle: VehicleParams,
    reply_timeout: Duration,
    max_tries: u32,
    apply_pulses: bool,
    wall: Instant,
    wall_limit: Duration,
    ticks_sum: u64,
    report: HilReport,
    telemetry: Vec<TelemetryRow>,
    /// The on-board estimator's settings, when the firmware estimates.
    onboard: Option<OnboardConfig>,
    /// Sequence numbers of the measurements sent since the last step (their `Nack`s count).
    sent_measurements: Vec<u16>,
    /// Keep a telemetry row per step.
    telemetry_rows: bool,
    /// The latest telemetry.
    latest: Telemetry,
    /// The scenario's mode, not yet set: it needs a position and the on-board estimate was
    /// not ready at the start. Set as soon as the vehicle takes it.
    pending_mode: Option<Mode>,
    /// [`HilOptions::nav_ready_limit_s`].
    nav_ready_limit_s: f64,
    /// Why the vehicle refused the pending mode the last time it was asked.
    not_ready: Option<NackReason>,
    /// Do not ask for the pending mode again before this simulated time (s).
    next_mode_try_s: Option<f64>,
    /// `[calibration]`: the turn's `(yaw rate, time limit)`, not yet started.
    calibration: Option<(f32, f32)>,
    /// The calibration turn is flying.
    calibrating: bool,
    /// `[identification]`: the manoeuvre's `(radius, depth band)`, not yet started.
    identification: Option<(f32, f32)>,
    /// When the reference the firmware flies began ([`ControllerEndpoint::reference_start_s`]).
    reference_start_s: f64,
    /// The firmware's DVL port, when it has one: the DVL's fixes go there as the DVL's
    /// serial reports instead of as `DvlFix` commands.
    dvl_wire: Option<DvlWire>,
    /// The emulated board's DVL and health wires (sent before each step).
    board_wires: Option<BoardWires>,
}

impl TetherEndpoint {
    /// Wait for the firmware's `Hello` on `link` (the emulator sends it at boot; a board may
    /// have sent it long ago: `hello_required` says whether its absence is an error).
    pub fn connect(
        mut link: Link,
        sc: &RunSetup,
        opts: &HilOptions,
        target_name: String,
        hello_wait: Duration,
        hello_required: bool,
    ) -> Result<Self> {
        let hello = link.wait_for(
            hello_wait,
            |r| match r {
                Reply::Hello {
                    board, lockstep, ..
                } => Some((*board, *lockstep)),
                _ => None,
            },
            |_| {},
        )?;
        let board = match hello {
            Some((b, true)) => format!("{b:?}"),
            Some((b, false)) => bail!(
                "the firmware on {b:?} runs fixed-rate; hardware in the loop needs the \
                 lock-step firmware (Config::lockstep)"
            ),
            None if hello_required => {
                bail!(
                    "no Hello from the firmware within {} s",
                    hello_wait.as_secs()
                )
            }
            None => "unknown (no Hello)".into(),
        };
        Ok(Self {
            link,
            mode: Mode::from(sc.mode()),
            reference: *sc.reference(),
            noise: opts.noise.map(Noise::new),
            pwm: PwmMap::for_vehicle(sc.vehicle()),
            // With `[identification]` the firmware flies with the prior, the plant is the
            // scenario's vehicle.
            vehicle: sc
                .identification
                .as_ref()
                .map_or(sc.vehicle_params, |i| i.prior_params),
            reply_timeout: opts.reply_timeout,
            max_tries: opts.max_tries,
            apply_pulses: opts.apply_pulses,
            wall: Instant::now(),
            wall_limit: opts.wall_limit,
            ticks_sum: 0,
            report: HilReport {
                target: target_name,
                board,
                heartbeat_stop_s: opts.heartbeat_stop_s,
                onboard_estimator: sc.navigation.source == NavSource::Estimator,
                ..HilReport::default()
            },
            telemetry: Vec::new(),
            onboard: (sc.navigation.source == NavSource::Estimator)
                .then(|| crate::closed_loop::estimator_nav::onboard_config(sc)),
            sent_measurements: Vec::new(),
            telemetry_rows: opts.telemetry_rows,
            latest: Telemetry::default(),
            pending_mode: None,
            nav_ready_limit_s: opts.nav_ready_limit_s,
            not_ready: None,
            next_mode_try_s: None,
            calibration: sc
                .calibration
                .map(|c| (c.yaw_rate_rad_s as f32, c.time_limit_s as f32)),
            calibrating: false,
            identification: sc
                .identification
                .as_ref()
                .map(|i| (i.radius_m as f32, i.depth_band_m as f32)),
            reference_start_s: 0.0,
            dvl_wire: None,
            board_wires: None,
        })
    }

    /// Send the DVL's fixes on `wire` (the firmware's DVL port) as the DVL's serial reports.
    pub fn set_dvl_wire(&mut self, wire: DvlWire) {
        self.dvl_wire = Some(wire);
    }

    /// The emulated board's DVL and health wires: the scenario's health parameters are
    /// given to the vehicle at the start, the health inputs sent before each step, and with
    /// `dvl_on_uart` the DVL's fixes go on its UART as its reports.
    pub fn set_board_wires(&mut self, wires: BoardWires, dvl_on_uart: bool) {
        if dvl_on_uart {
            self.dvl_wire = Some(wires.dvl_wire());
        }
        self.board_wires = Some(wires);
    }

    /// The emulated board's wires, if any (the simulated battery's truth).
    pub fn board_wires(&self) -> Option<&BoardWires> {
        self.board_wires.as_ref()
    }

    /// After the run: ask the firmware for its counters (the answer to one more heartbeat
    /// or, if that is lost on a noisy link, the latest answer) and hand over the report and
    /// the telemetry rows.
    pub fn finish(mut self, t_end_s: f64) -> Result<(HilReport, Vec<TelemetryRow>)> {
        let hb = self.link.send(&Command::Heartbeat { t_us: us(t_end_s) })?;
        let end_status = self.link.wait_for(
            Duration::from_millis(500),
            |r| match r {
                Reply::Status(st) if st.heartbeat_seq == hb => Some(*st),
                _ => None,
            },
            |_| {},
        )?;
        let end_status = end_status.or(self.link.last_status);
        if self.onboard.is_some() {
            self.report.nav_health = end_status.map(|st| st.nav_health);
        }
        self.report.compass_cal = end_status.map(|st| st.compass_cal);
        self.report.ident = end_status.map(|st| st.ident);
        let fw: LinkStats = end_status.map(|st| st.link).unwrap_or_default();
        let rep = &mut self.report;
        rep.firmware_rx_frames = fw.rx_frames;
        rep.firmware_dropped_frames = fw.dropped.total();
        rep.firmware_tx_frames = fw.tx_frames;
        rep.firmware_nacks = fw.nacks;
        rep.loop_ticks_mean = ratio(self.ticks_sum, rep.steps);
        rep.host = self.link.stats;
        Ok((self.report, self.telemetry))
    }

    /// One lock-step exchange at `t_s`, resent until answered.
    fn exchange(&mut self, t_s: f64, nav: &NavState) -> Result<Telemetry> {
        let t_us = us(t_s);
        if let Some(w) = self.board_wires.as_mut() {
            w.send()?;
        }
        let heartbeats = self.report.heartbeat_stop_s.is_none_or(|stop| t_s < stop);
        let nav_cmd = match self.onboard {
            Some(_) => Command::Step { t_us },
            None => Command::Nav(NavSample { t_us, state: *nav }),
        };
        let hb_cmd = Command::Heartbeat { t_us };
        if heartbeats {
            self.link.send(&hb_cmd)?;
        }
        // A resend carries a new sequence number (the firmware refuses a repeated one as a
        // replay); the Telemetry answering any of them counts.
        let mut nav_seqs = vec![self.link.send(&nav_cmd)?];
        let mut tries = 1;
        let sent = std::mem::take(&mut self.sent_measurements);
        loop {
            let refused = &mut self.report.measurements_refused;
            let wait = (self.reply_timeout * 2u32.saturating_pow(tries - 1)).min(MAX_REPLY_WAIT);
            let got = self.link.wait_for(
                wait,
                |r| match r {
                    Reply::Telemetry(tl) if nav_seqs.contains(&tl.nav_seq) => Some(Ok(*tl)),
                    Reply::Nack { seq, reason } if nav_seqs.contains(seq) => Some(Err(*reason)),
                    _ => None,
                },
                |r| {
                    if let Reply::Nack { seq, .. } = r {
                        *refused += u64::from(sent.contains(seq));
                    }
                },
            )?;
            match got {
                Some(Ok(tl)) => {
                    if tries > 1 {
                        self.report.steps_resent += 1;
                    }
                    return Ok(tl);
                }
                Some(Err(reason)) => {
                    bail!("the firmware refused the NavState at t = {t_s:.3} s: {reason:?}")
                }
                None => {
                    self.link.stats.timeouts += 1;
                    if tries >= self.max_tries {
                        bail!(
                            "control lost: no Telemetry for the NavState at t = {t_s:.3} s \
                             after {tries} sends"
                        );
                    }
                    tries += 1;
                    self.link.stats.resends += 1;
                    if heartbeats {
                        self.link.send(&hb_cmd)?;
                    }
                    nav_seqs.push(self.link.send(&nav_cmd)?);
                }
            }
        }
    }

    /// What the loop gets of a step's telemetry.
    fn reply(&self, tel: &Telemetry, applied: [f64; 3]) -> StepReply {
        let std_m = self.onboard.map(|_| tel.nav_pos_std_m.map(f64::from));
        StepReply::from_telemetry(tel, applied, std_m)
    }

    /// While the scenario's mode waits for the vehicle's estimate: once the latest telemetry
    /// reports a horizontal position standard deviation within
    /// [`POSITION_READY_STD_M`], ask for the mode (the firmware's own check, which includes
    /// the heading, decides); refused as not ready, ask again a second later. Past
    /// [`HilOptions::nav_ready_limit_s`] the run fails with the latest reason.
    fn try_pending_mode(&mut self, t_s: f64) -> Result<()> {
        if self.pending_mode.is_some() || self.calibrating || self.calibration.is_some() {
            // The scenario's reference has not started on the vehicle yet.
            self.reference_start_s = t_s;
        }
        if self.pending_mode.is_none() {
            self.advance_calibration(t_s)?;
            return self.start_identification(t_s);
        }
        let Some(mode) = self.pending_mode else {
            return Ok(());
        };
        if t_s > self.nav_ready_limit_s {
            bail!(
                "the vehicle's estimate was not ready for {mode:?} within {} s of simulated \
                 time (latest refusal: {:?}; position std {:?} m); the launch point must be \
                 known better or the USBL must reach the vehicle",
                self.nav_ready_limit_s,
                self.not_ready,
                self.latest.nav_pos_std_m
            );
        }
        let [sx, sy, _] = self.latest.nav_pos_std_m;
        let position_ok = sx <= POSITION_READY_STD_M && sy <= POSITION_READY_STD_M;
        let due = self.next_mode_try_s.is_none_or(|t| t_s >= t);
        if !(position_ok && due) {
            return Ok(());
        }
        match self.link.command(
            &Command::SetMode(mode),
            Duration::from_millis(500),
            5,
            |_| {},
        )? {
            Ok(()) => {
                self.pending_mode = None;
                if self.calibration.is_none() {
                    self.report.mode_set_at_s = Some(t_s);
                }
            }
            Err(reason @ NackReason::NavNotReady(_)) => {
                self.not_ready = Some(reason);
                self.next_mode_try_s = Some(t_s + 1.0);
            }
            Err(reason) => bail!("the firmware refused {mode:?} at t = {t_s:.3} s: {reason:?}"),
        }
        Ok(())
    }

    /// `[identification]`, once in `Hold` with the estimate ready (and any calibration turn
    /// over): start the manoeuvre; the vehicle stays in `Hold` after it.
    fn start_identification(&mut self, t_s: f64) -> Result<()> {
        if self.calibrating || self.calibration.is_some() {
            return Ok(());
        }
        if let Some((radius_m, depth_band_m)) = self.identification.take() {
            let cmd = Command::StartIdent {
                radius_m,
                depth_band_m,
            };
            if let Err(reason) = self
                .link
                .command(&cmd, Duration::from_millis(500), 5, |_| {})?
            {
                bail!("the firmware refused the identification manoeuvre at t = {t_s:.3} s: {reason:?}");
            }
            self.report.mode_set_at_s = Some(t_s);
        }
        Ok(())
    }

    /// `[calibration]`, once in `Hold` with the estimate ready: start the turn; while it
    /// flies, watch the firmware's `Status` for its outcome; then set the scenario's mode
    /// (its reference starts then). A refused turn is reported and the scenario flown.
    fn advance_calibration(&mut self, t_s: f64) -> Result<()> {
        use firmware::compass_swing::SwingOutcome;
        if let Some((yaw_rate_rad_s, time_limit_s)) = self.calibration.take() {
            let cmd = Command::StartCompassCal {
                yaw_rate_rad_s,
                time_limit_s,
            };
            if let Err(reason) = self
                .link
                .command(&cmd, Duration::from_millis(500), 5, |_| {})?
            {
                bail!("the firmware refused the compass calibration turn at t = {t_s:.3} s: {reason:?}");
            }
            self.calibrating = true;
            return Ok(());
        }
        if !self.calibrating {
            return Ok(());
        }
        let outcome = self.link.last_status.map(|st| st.compass_swing);
        if let Some(
            o @ (SwingOutcome::Accepted { .. } | SwingOutcome::Refused(_) | SwingOutcome::Aborted),
        ) = outcome
        {
            self.calibrating = false;
            self.report.compass_swing = Some(o);
            self.report.calibration_end_s = Some(t_s);
            let mode = self.mode;
            if let Err(reason) = self.link.command(
                &Command::SetMode(mode),
                Duration::from_millis(500),
                5,
                |_| {},
            )? {
                bail!("the firmware refused {mode:?} after the calibration turn: {reason:?}");
            }
            self.report.mode_set_at_s = Some(t_s);
            self.reference_start_s = t_s;
        }
        Ok(())
    }

    /// Failsafe timings of a link-loss run.
    fn note_failsafes(&mut self, t_s: f64, tel: &Telemetry) {
        let rep = &mut self.report;
        if !tel.armed {
            rep.steps_disarmed += 1;
        }
        if tel.faults & (fault::HEARTBEAT_LOST | fault::LINK_DISARMED | fault::NAV_STALE) != 0 {
            rep.steps_failsafe += 1;
        }
        if let Some(stop) = rep.heartbeat_stop_s {
            if t_s >= stop {
                // Neutral because of the link failsafe (not merely a zero command).
                let neutral = tel
                    .pulse_us
                    .iter()
                    .all(|&p| f32::from(p) == self.pwm.neutral_us)
                    && tel.faults & (fault::HEARTBEAT_LOST | fault::LINK_DISARMED) != 0;
                if neutral && rep.neutral_after_s.is_none() {
                    rep.neutral_after_s = Some(t_s - stop);
                }
                if !tel.armed && rep.disarmed_after_s.is_none() {
                    rep.disarmed_after_s = Some(t_s - stop);
                }
            }
        }
    }
}

impl ControllerEndpoint for TetherEndpoint {
    /// Set-up in lock-step time 0: a heartbeat and a `Nav` (arming needs both), the
    /// reference starting at 0, the mode, arm. Sent on a clean link; the noise starts after.
    fn start(&mut self, nav0: &NavState) -> Result<()> {
        let tmo = Duration::from_millis(500);
        self.link.send(&Command::Heartbeat { t_us: 0 })?;
        // The scenario's vehicle (the firmware boots with the Observer's).
        let set_vehicle = Command::SetVehicle(self.vehicle);
        if let Err(reason) = self.link.command(&set_vehicle, tmo, 5, |_| {})? {
            bail!("the firmware refused the scenario's vehicle: {reason:?}");
        }
        if let Some(params) = self.board_wires.as_ref().map(BoardWires::health_params) {
            let set_health = Command::SetHealth(params);
            if let Err(reason) = self.link.command(&set_health, tmo, 5, |_| {})? {
                bail!("the firmware refused the scenario's health parameters: {reason:?}");
            }
        }
        if let Some(config) = self.onboard {
            // The estimator starts at the launch point; its sensors count as fresh from now.
            let start = Command::StartNav {
                t_us: 0,
                initial: *nav0,
                config,
            };
            if let Err(reason) = self
                .link
                .command(&start, Duration::from_secs(5), 5, |_| {})?
            {
                bail!("the firmware refused StartNav: {reason:?}");
            }
        } else {
            let s0 = self.link.send(&Command::Nav(NavSample {
                t_us: 0,
                state: *nav0,
            }))?;
            self.link
                .wait_for(
                    Duration::from_secs(5),
                    |r| match r {
                        Reply::Telemetry(t) if t.nav_seq == s0 => Some(()),
                        _ => None,
                    },
                    |_| {},
                )?
                .ok_or_else(|| anyhow!("no Telemetry for the first NavState"))?;
        }
        let set_reference = Command::SetReference {
            reference: self.reference,
            start_us: Some(0),
        };
        if let Err(reason) = self.link.command(&set_reference, tmo, 5, |_| {})? {
            bail!("the firmware refused {set_reference:?}: {reason:?}");
        }
        // A position mode on the on-board estimate: the vehicle refuses it until the
        // estimate is ready (an unknown start); arm in `Idle` (neutral) and set the mode
        // between the steps as soon as it is taken (`try_pending_mode`).
        // With `[calibration]`, the turn is flown in `Hold` first.
        let first = if self.calibration.is_some() || self.identification.is_some() {
            Mode::Hold
        } else {
            self.mode
        };
        let needs_position = matches!(first, Mode::Track { .. } | Mode::Hold | Mode::Auto);
        match self
            .link
            .command(&Command::SetMode(first), tmo, 5, |_| {})?
        {
            Ok(()) if self.calibration.is_none() && self.identification.is_none() => {
                self.report.mode_set_at_s = Some(0.0)
            }
            Ok(()) => {}
            Err(reason @ NackReason::NavNotReady(_)) if needs_position => {
                self.pending_mode = Some(first);
                self.not_ready = Some(reason);
            }
            Err(reason) => bail!("the firmware refused {first:?}: {reason:?}"),
        }
        if let Err(reason) = self.link.command(&Command::Arm, tmo, 5, |_| {})? {
            bail!("the firmware refused Arm: {reason:?}");
        }
        self.link.set_noise(self.noise.take());
        Ok(())
    }

    fn reference_start_s(&self) -> f64 {
        self.reference_start_s
    }

    fn step(&mut self, t_s: f64, nav: &NavState, _reference: &RefSample) -> Result<StepReply> {
        if self.wall.elapsed() > self.wall_limit {
            bail!(
                "wall-clock limit of {} s reached at t = {t_s:.3} s (hil --wall-limit SECONDS \
                 gives a long run more)",
                self.wall_limit.as_secs()
            );
        }
        let tel = self.exchange(t_s, nav)?;
        self.report.steps += 1;
        if let Some(w) = self.board_wires.as_mut() {
            w.advance(us(t_s), tel.pulse_us);
        }
        // Thrust the plant gets: from the pulse widths the ESCs see, or the commands.
        let applied = if self.apply_pulses {
            tel.pulse_us
                .map(|p| f64::from(self.pwm.thrust_n(f32::from(p))))
        } else {
            tel.thrust_n.map(f64::from)
        };
        self.ticks_sum += u64::from(tel.loop_ticks);
        self.report.loop_ticks_max = self.report.loop_ticks_max.max(tel.loop_ticks);
        self.note_failsafes(t_s, &tel);
        self.latest = tel;
        // After the exchange, so that the measurements' Nacks of this step are counted.
        self.try_pending_mode(t_s)?;
        if !self.telemetry_rows {
            return Ok(self.reply(&tel, applied));
        }
        self.telemetry.push(TelemetryRow {
            t_s,
            telemetry: tel,
            applied_n: applied,
            // From the answer to this step's heartbeat (it comes before the telemetry).
            fw_rx_frames: self.link.last_status.map_or(0, |st| st.link.rx_frames),
            fw_dropped: self
                .link
                .last_status
                .map_or(0, |st| st.link.dropped.total()),
        });
        Ok(self.reply(&tel, applied))
    }

    /// The measurements, as the commands the firmware takes; a depth travels as the pressure
    /// the sensor would read (the firmware converts it back, as on the real board).
    fn forward(&mut self, measurements: &[Measurement]) -> Result<()> {
        let Some(cfg) = self.onboard else {
            return Ok(());
        };
        for m in measurements {
            if let (Measurement::Dvl(d), Some(wire)) = (m, self.dvl_wire.as_mut()) {
                wire.send_wrz(d);
                continue;
            }
            let cmd = command_of(m, &cfg.pressure);
            let seq = self.link.send(&cmd)?;
            self.sent_measurements.push(seq);
        }
        Ok(())
    }
}
