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
//! The loop itself is [`crate::sim_loop`]'s, the same as a software run's; this module is
//! the controller endpoint at the far end of the tether ([`TetherEndpoint`]). With
//! `--in-process` that far end is the firmware library's `App` in this process
//! ([`crate::in_process`]), so the whole data path runs without an emulator.
//!
//! A frame lost on the way (noise injection) is detected by a reply timeout and sent again
//! with the same sequence number. Outputs: the same `summary.json` (plus a `hil` object with
//! the link statistics), `timeseries.csv` and plots as `host-sim run`, and
//! `telemetry.csv` with what the firmware reported each step.

use crate::clock::us;
use crate::in_process::InProcessFirmware;
use crate::link::{open, Endpoint, HostLinkStats, Link, Noise, NoiseSpec, Port};
use crate::output::write_run;
use crate::qemu::{qemu_firmware_image, start_qemu_link, workspace_root, FirmwareImage};
use crate::scenario::Scenario;
use crate::sensors::Measurement;
use crate::sensors::NavSource;
use crate::sim_loop::{run_closed_loop, ControllerEndpoint, RunOptions, RunOutput, StepReply};
use anyhow::{anyhow, bail, Result};
use controller_core::alloc::PwmMap;
use controller_core::nav::onboard::OnboardConfig;
use controller_core::params::VehicleParams;
use controller_core::reference::{RefSample, Reference};
use controller_core::state::NavState;
use firmware::protocol::{fault, Command, LinkStats, Mode, NavSample, Reply, Telemetry};
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Where the firmware runs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum HilTarget {
    /// Start QEMU `netduinoplus2` with this ELF (the firmware's `qemu` image).
    Qemu {
        /// The ELF.
        elf: PathBuf,
    },
    /// A board (or an already running emulator) at an endpoint; it must run the lock-step
    /// firmware.
    Board(Endpoint),
    /// The firmware library's `App` in this process, behind an in-memory serial port: the
    /// same frames and the same code as on the board, without an emulator.
    InProcess,
}

/// The longest wait for one reply in a lock-step exchange ([`HilOptions::reply_timeout`]).
pub const MAX_REPLY_WAIT: Duration = Duration::from_secs(1);

/// Options of a HIL run.
#[derive(Debug, Clone)]
pub struct HilOptions {
    /// Where the firmware runs.
    pub target: HilTarget,
    /// Stop sending heartbeats from this simulated time on (link-loss test).
    pub heartbeat_stop_s: Option<f64>,
    /// Noise injected on the link (from arming on; the set-up is on a clean link).
    pub noise: Option<NoiseSpec>,
    /// Run this long instead of the scenario's duration.
    pub duration_s: Option<f64>,
    /// Wall-clock time to wait for a reply before sending again; each resend of the same
    /// step waits twice as long as the one before, up to [`MAX_REPLY_WAIT`] (an emulator
    /// starved for a moment by a loaded machine is not a lost link, and a resend storm only
    /// deepens the backlog).
    pub reply_timeout: Duration,
    /// Sends of one `NavState` before the run is declared lost.
    pub max_tries: u32,
    /// Apply the thrust of the reported pulse widths (true, what the ESCs see) or the
    /// reported thrust commands (false).
    pub apply_pulses: bool,
    /// The QEMU binary.
    pub qemu: String,
    /// Wall-clock limit of the whole run.
    pub wall_limit: Duration,
    /// Keep the per-step log (CSV, plots).
    pub record: bool,
    /// With `--qemu`: save the emulated SRAM here at the end of the run (stack high-water).
    pub ram_dump: Option<PathBuf>,
    /// At the start, set the scenario's reference and mode and arm (`hil`); without, only
    /// the vehicle description and the navigation are sent, and the rest comes from the
    /// ground stations (`topside --sim`).
    pub fly_scenario: bool,
    /// Keep a telemetry row per step (`telemetry.csv`, the failsafe checks); the topside,
    /// which runs for hours, keeps none.
    pub telemetry_rows: bool,
}

impl HilOptions {
    /// Defaults for a target.
    pub fn new(target: HilTarget) -> Self {
        Self {
            target,
            heartbeat_stop_s: None,
            noise: None,
            duration_s: None,
            reply_timeout: Duration::from_millis(100),
            max_tries: 20,
            apply_pulses: true,
            qemu: "qemu-system-arm".into(),
            wall_limit: Duration::from_secs(600),
            record: true,
            ram_dump: None,
            fly_scenario: true,
            telemetry_rows: true,
        }
    }
}

/// What the firmware reported in one step.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct TelemetryRow {
    /// Simulated time of the step (s).
    pub t_s: f64,
    /// Armed.
    pub armed: bool,
    /// Fault flags.
    pub faults: u16,
    /// Pulse widths written to the PWM outputs (us).
    pub pulse_us: [u16; 3],
    /// Thrust commands (N).
    pub thrust_n: [f32; 3],
    /// Thrust applied to the plant (N).
    pub applied_n: [f64; 3],
    /// Control iteration length on the board (instructions on QEMU with `-icount`).
    pub loop_ticks: u32,
    /// Frames the firmware accepted so far.
    pub fw_rx_frames: u32,
    /// Frames the firmware dropped so far.
    pub fw_dropped: u32,
}

/// Link and timing figures of a HIL run (the `hil` object of `summary.json`).
#[derive(Debug, Clone, Default, Serialize)]
pub struct HilReport {
    /// `qemu` or the endpoint.
    pub target: String,
    /// Board named in `Hello`.
    pub board: String,
    /// Host-side counters.
    pub host: HostLinkStats,
    /// Frames the firmware accepted.
    pub firmware_rx_frames: u32,
    /// Frames the firmware dropped (all reasons).
    pub firmware_dropped_frames: u32,
    /// Frames the firmware sent.
    pub firmware_tx_frames: u32,
    /// Nacks the firmware sent.
    pub firmware_nacks: u32,
    /// Lock-step exchanges done.
    pub steps: u64,
    /// Steps whose `NavState` had to be sent more than once.
    pub steps_resent: u64,
    /// Mean control iteration on the board (instructions under `-icount shift=0`).
    pub loop_ticks_mean: f64,
    /// Largest control iteration on the board.
    pub loop_ticks_max: u32,
    /// Steps in which the firmware was not armed (after arming).
    pub steps_disarmed: u64,
    /// Steps in which the firmware reported a link or navigation failsafe.
    pub steps_failsafe: u64,
    /// Heartbeats stopped at this simulated time (s).
    pub heartbeat_stop_s: Option<f64>,
    /// First time after the stop at which all outputs were neutral with the heartbeat
    /// failsafe flagged, minus the stop (s).
    pub neutral_after_s: Option<f64>,
    /// First time after the stop at which the firmware was disarmed, minus the stop (s).
    pub disarmed_after_s: Option<f64>,
    /// The firmware ran the estimator on board (the scenario's `source = "estimator"`): the
    /// host sent it sensor readings and fixes, not states.
    pub onboard_estimator: bool,
    /// Measurements the firmware's estimator refused (answered by a `Nack`).
    pub measurements_refused: u64,
    /// The on-board estimator's counters at the end of the run.
    pub nav_health: Option<controller_core::nav::NavHealth>,
    /// Wall-clock time (s).
    pub wall_time_s: f64,
}

/// The result of a HIL run.
#[derive(Debug, Clone, Default)]
pub struct HilOutput {
    /// Same as `host-sim run`.
    pub run: RunOutput,
    /// Link statistics and failsafe timings.
    pub report: HilReport,
    /// The firmware's telemetry, one row per step.
    pub telemetry: Vec<TelemetryRow>,
}

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
    heartbeat_stop_s: Option<f64>,
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
    /// Set the scenario's reference and mode and arm at the start.
    fly_scenario: bool,
    /// The latest telemetry.
    latest: Telemetry,
}

impl TetherEndpoint {
    /// Wait for the firmware's `Hello` on `link` (the emulator sends it at boot; a board may
    /// have sent it long ago: `hello_required` says whether its absence is an error).
    pub fn connect(
        mut link: Link,
        sc: &Scenario,
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
            mode: Mode::from(sc.control_mode()?),
            reference: sc.reference.to_core(),
            noise: opts.noise.map(Noise::new),
            pwm: PwmMap::for_vehicle(&sc.vehicle_model()?),
            vehicle: sc.vehicle_params,
            heartbeat_stop_s: opts.heartbeat_stop_s,
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
                .then(|| crate::estimator_nav::onboard_config(sc)),
            sent_measurements: Vec::new(),
            telemetry_rows: opts.telemetry_rows,
            fly_scenario: opts.fly_scenario,
            latest: Telemetry::default(),
        })
    }

    /// The link to the firmware (for commands between the steps: the topside's ground
    /// stations).
    pub fn link(&mut self) -> &mut Link {
        &mut self.link
    }

    /// The link's counters.
    pub fn link_stats(&self) -> &HostLinkStats {
        &self.link.stats
    }

    /// The telemetry of the latest step.
    pub fn latest(&self) -> &Telemetry {
        &self.latest
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
        let fw: LinkStats = end_status.map(|st| st.link).unwrap_or_default();
        let rep = &mut self.report;
        rep.firmware_rx_frames = fw.rx_frames;
        rep.firmware_dropped_frames = fw.dropped.total();
        rep.firmware_tx_frames = fw.tx_frames;
        rep.firmware_nacks = fw.nacks;
        rep.loop_ticks_mean = if rep.steps > 0 {
            self.ticks_sum as f64 / rep.steps as f64
        } else {
            0.0
        };
        rep.host = self.link.stats;
        rep.wall_time_s = self.wall.elapsed().as_secs_f64();
        Ok((self.report, self.telemetry))
    }

    /// One lock-step exchange at `t_s`, resent until answered.
    fn exchange(&mut self, t_s: f64, nav: &NavState) -> Result<Telemetry> {
        let t_us = us(t_s);
        let heartbeats = self.heartbeat_stop_s.is_none_or(|stop| t_s < stop);
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
        StepReply {
            requested: tel.requested,
            achieved: tel.achieved,
            thrust_cmd_n: tel.thrust_n,
            applied_n: applied,
            pulse_us: tel.pulse_us.map(f64::from),
            errors: tel.errors,
            saturated: tel.faults & fault::SATURATED != 0,
            estimate: self
                .onboard
                .map(|_| (tel.nav, tel.nav_pos_std_m.map(f64::from))),
        }
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
        if let Some(stop) = self.heartbeat_stop_s {
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
        let setup = [
            Command::SetReference {
                reference: self.reference,
                start_us: Some(0),
            },
            Command::SetMode(self.mode),
            Command::Arm,
        ];
        let setup = if self.fly_scenario { &setup[..] } else { &[] };
        for cmd in setup {
            if let Err(reason) = self.link.command(cmd, tmo, 5, |_| {})? {
                bail!("the firmware refused {cmd:?}: {reason:?}");
            }
        }
        self.link.set_noise(self.noise.take());
        Ok(())
    }

    fn step(&mut self, t_s: f64, nav: &NavState, _reference: &RefSample) -> Result<StepReply> {
        if self.wall.elapsed() > self.wall_limit {
            bail!(
                "wall-clock limit of {} s reached at t = {t_s:.3} s",
                self.wall_limit.as_secs()
            );
        }
        let tel = self.exchange(t_s, nav)?;
        self.report.steps += 1;
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
        if !self.telemetry_rows {
            return Ok(self.reply(&tel, applied));
        }
        self.telemetry.push(TelemetryRow {
            t_s,
            armed: tel.armed,
            faults: tel.faults,
            pulse_us: tel.pulse_us,
            thrust_n: tel.thrust_n,
            applied_n: applied,
            loop_ticks: tel.loop_ticks,
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
            let cmd = match *m {
                Measurement::Imu(s) => Command::Imu(s),
                Measurement::Depth(d) => Command::Pressure {
                    t_us: d.t_us,
                    pressure_pa: cfg.pressure.pressure_pa(d.depth_m),
                },
                Measurement::Heading(h) => Command::Compass(h),
                Measurement::Dvl(d) => Command::DvlFix(d),
                Measurement::Position(p, _) => Command::UsblFix(p),
            };
            let seq = self.link.send(&cmd)?;
            self.sent_measurements.push(seq);
        }
        Ok(())
    }
}

/// Run a scenario with the firmware in the loop. `qemu_log`: where QEMU's standard output
/// (semihosting, defmt frames) goes.
pub fn run_hil(sc: &Scenario, opts: &HilOptions, qemu_log: Option<&Path>) -> Result<HilOutput> {
    sc.validate()?;
    let mut qemu_guard = None;
    let (port, target_name, hello_wait, hello_required): (Box<dyn Port>, _, _, _) =
        match &opts.target {
            HilTarget::Qemu { elf } => {
                let (q, p) = start_qemu_link(&opts.qemu, elf, qemu_log, opts.ram_dump.is_some())?;
                qemu_guard = Some(q);
                (
                    p,
                    "qemu netduinoplus2".to_string(),
                    Duration::from_secs(30),
                    true,
                )
            }
            HilTarget::InProcess => (
                Box::new(InProcessFirmware::new()?),
                "in-process firmware library".to_string(),
                Duration::from_secs(1),
                true,
            ),
            HilTarget::Board(ep) => (open(ep)?, format!("{ep:?}"), Duration::from_secs(2), false),
        };
    let link = Link::new(port, None);
    let mut endpoint =
        TetherEndpoint::connect(link, sc, opts, target_name, hello_wait, hello_required)?;
    let mut nav = crate::estimator_nav::navigation_for_vehicle(sc)?;
    let run_opts = RunOptions {
        record: opts.record,
        duration_s: opts.duration_s,
        ..RunOptions::default()
    };
    let run = run_closed_loop(sc, &run_opts, nav.as_mut(), &mut endpoint)?;
    if let (Some(q), Some(p)) = (qemu_guard.as_mut(), opts.ram_dump.as_deref()) {
        q.dump_ram(p)?;
    }
    let (mut report, telemetry) = endpoint.finish(run.summary.simulated_s)?;
    report.wall_time_s = run.summary.wall_time_s;
    Ok(HilOutput {
        run,
        report,
        telemetry,
    })
}

/// Write `summary.json` (with a `hil` object), `timeseries.csv`, the plots and
/// `telemetry.csv` into `dir`.
pub fn write_hil(dir: &Path, out: &HilOutput) -> Result<()> {
    write_run(dir, &out.run)?;
    let mut v = serde_json::to_value(&out.run.summary)?;
    if let Some(o) = v.as_object_mut() {
        o.insert("hil".into(), serde_json::to_value(&out.report)?);
    }
    std::fs::write(
        dir.join("summary.json"),
        serde_json::to_string_pretty(&v)? + "\n",
    )?;
    let f = std::fs::File::create(dir.join("telemetry.csv"))?;
    let mut w = std::io::BufWriter::new(f);
    writeln!(
        w,
        "t_s,armed,faults,pwm1_us,pwm2_us,pwm3_us,f1x_cmd_n,f2x_cmd_n,f3z_cmd_n,\
         f1x_applied_n,f2x_applied_n,f3z_applied_n,loop_ticks,fw_rx_frames,fw_dropped"
    )?;
    for r in &out.telemetry {
        writeln!(
            w,
            "{:.6},{},{},{},{},{},{},{},{},{:.6},{:.6},{:.6},{},{},{}",
            r.t_s,
            u8::from(r.armed),
            r.faults,
            r.pulse_us[0],
            r.pulse_us[1],
            r.pulse_us[2],
            r.thrust_n[0],
            r.thrust_n[1],
            r.thrust_n[2],
            r.applied_n[0],
            r.applied_n[1],
            r.applied_n[2],
            r.loop_ticks,
            r.fw_rx_frames,
            r.fw_dropped
        )?;
    }
    w.flush()?;
    Ok(())
}

/// Arguments of `host-sim hil`.
#[derive(Debug, clap::Args)]
pub struct HilArgs {
    /// Built-in scenario name or path to a scenario file.
    pub scenario: String,
    /// Run this firmware image in QEMU (default, without --serial/--tcp/--in-process: the
    /// workspace's `qemu` image, built if needed into `<target>/hil-firmware`).
    #[arg(long, value_name = "ELF", conflicts_with_all = ["serial", "tcp", "in_process"])]
    pub qemu: Option<PathBuf>,
    /// Run the firmware library's `App` in this process (no emulator needed).
    #[arg(long, conflicts_with_all = ["serial", "tcp"])]
    pub in_process: bool,
    /// A board on a serial device (lock-step firmware).
    #[arg(long, value_name = "DEVICE", conflicts_with = "tcp")]
    pub serial: Option<PathBuf>,
    /// Baud rate of `--serial`.
    #[arg(long, default_value_t = 115_200)]
    pub baud: u32,
    /// A board or emulator at HOST:PORT (lock-step firmware).
    #[arg(long, value_name = "HOST:PORT")]
    pub tcp: Option<String>,
    /// Output folder (default out/hil-<scenario>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Simulated duration instead of the scenario's (s).
    #[arg(long)]
    pub duration: Option<f64>,
    /// Stop sending heartbeats at this simulated time (s): the link-loss failsafes.
    #[arg(long, value_name = "SECONDS")]
    pub heartbeat_stop: Option<f64>,
    /// Inject noise: probability that a frame sent is corrupted (and that garbage precedes
    /// it); received bytes are corrupted with probability NOISE / 100. A probability, in
    /// [0, 1]. Every corrupted frame costs a reply timeout and a resend, so the wall time
    /// grows fast: one simulated second of `line-3d --in-process` took 0.06 s at 0, 2.6 s at
    /// 0.1 and 30 s at 0.5 (2026-11-26, 2 shared cores); keep --duration short.
    #[arg(long, value_name = "PROB", value_parser = parse_probability)]
    pub noise: Option<f64>,
    /// Seed of the noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Apply the firmware's thrust commands instead of the thrust of its PWM pulse widths.
    #[arg(long)]
    pub apply_thrust: bool,
    /// The QEMU binary.
    #[arg(long, default_value = "qemu-system-arm")]
    pub qemu_bin: String,
    /// With --qemu: save the emulated 128 KiB SRAM to FILE at the end (stack high-water).
    #[arg(long, value_name = "FILE")]
    pub ram_dump: Option<PathBuf>,
}

/// `--noise`: a probability (clap refuses anything else, naming the reason, exit 2).
fn parse_probability(s: &str) -> std::result::Result<f64, String> {
    let p: f64 = s
        .parse()
        .map_err(|e| format!("{s:?} is not a number: {e}"))?;
    if !(0.0..=1.0).contains(&p) {
        return Err(format!("{p} is not a probability: it must be in [0, 1]"));
    }
    Ok(p)
}

/// `host-sim hil`.
/// Run `host-sim hil`; the output decides the exit code (`main.rs`: 1 when the run diverged,
/// went non-finite or missed its scenario's targets, as `run`).
pub fn main(a: HilArgs) -> Result<HilOutput> {
    let sc = Scenario::load(&a.scenario).map_err(crate::checks::refused)?;
    if sc.deployment.control == crate::topside_layout::Control::Topside {
        let o = crate::topside_layout::hil_main(&sc, a.in_process, a.out, a.duration)?;
        return Ok(HilOutput {
            run: o.run,
            report: HilReport {
                target: "in-process topside layout".into(),
                board: "topside + node (firmware library)".into(),
                onboard_estimator: true,
                ..HilReport::default()
            },
            telemetry: Vec::new(),
        });
    }
    let target = if let Some(dev) = a.serial {
        HilTarget::Board(Endpoint::Serial {
            device: dev,
            baud: a.baud,
        })
    } else if let Some(t) = a.tcp {
        HilTarget::Board(Endpoint::Tcp(t))
    } else if a.in_process {
        HilTarget::InProcess
    } else {
        let elf = match a.qemu {
            Some(elf) => elf,
            // The image of this workspace, built (or found current) from anywhere, with any
            // CARGO_TARGET_DIR.
            None => match qemu_firmware_image(&workspace_root())? {
                FirmwareImage::Ready(elf) => elf,
                FirmwareImage::Unavailable(why) => {
                    bail!("the emulated board cannot run here: {why} (or use --in-process)")
                }
            },
        };
        if !elf.is_file() {
            bail!("firmware image {} not found", elf.display());
        }
        HilTarget::Qemu { elf }
    };
    let mut o = HilOptions::new(target);
    o.duration_s = a.duration;
    o.heartbeat_stop_s = a.heartbeat_stop;
    o.noise = a.noise.map(|p| NoiseSpec {
        tx_frame_error_prob: p,
        tx_garbage_prob: p,
        rx_byte_error_prob: p / 100.0,
        seed: a.seed,
    });
    o.apply_pulses = !a.apply_thrust;
    o.qemu = a.qemu_bin;
    o.ram_dump = a.ram_dump;
    if !sc.thrusters.saturate {
        eprintln!(
            "note: scenario {} has no thruster limits, but the firmware always applies the \
             vehicle's (+20 N / -15 N): compare with a saturated software run",
            sc.name
        );
    }
    let dir = a
        .out
        .unwrap_or_else(|| PathBuf::from("out").join(format!("hil-{}", sc.name)));
    std::fs::create_dir_all(&dir)?;
    let out = run_hil(&sc, &o, Some(&dir.join("qemu-stdout.bin")))?;
    write_hil(&dir, &out)?;
    let s = &out.run.summary;
    let r = &out.report;
    println!(
        "{}: {} (RMS {:.4} m, final {:.4} m, {} steps in {:.1} s wall)",
        s.scenario,
        s.verdict,
        s.rms_position_error_m,
        s.final_position_error_m,
        r.steps,
        r.wall_time_s
    );
    println!(
        "link: host sent {} frames, received {}, dropped {}; firmware received {}, dropped {}, \
         sent {}; timeouts {}, steps resent {}; injected: {} frames corrupted, {} garbage \
         bytes, {} received bytes corrupted",
        r.host.frames_sent,
        r.host.frames_received,
        r.host.frames_dropped,
        r.firmware_rx_frames,
        r.firmware_dropped_frames,
        r.firmware_tx_frames,
        r.host.timeouts,
        r.steps_resent,
        r.host.frames_corrupted,
        r.host.garbage_bytes,
        r.host.rx_bytes_corrupted
    );
    println!(
        "board: {}; control iteration {:.0} instructions mean, {} max; disarmed steps {}, \
         failsafe steps {}",
        r.board, r.loop_ticks_mean, r.loop_ticks_max, r.steps_disarmed, r.steps_failsafe
    );
    if let Some(stop) = r.heartbeat_stop_s {
        println!(
            "heartbeats stopped at {stop} s: neutral after {}, disarmed after {}",
            r.neutral_after_s
                .map_or("never".into(), |v| format!("{v:.3} s")),
            r.disarmed_after_s
                .map_or("never".into(), |v| format!("{v:.3} s"))
        );
    }
    println!("outputs in {}", dir.display());
    Ok(out)
}
