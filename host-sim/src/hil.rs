//! Hardware in the loop: the real firmware (in QEMU, or on a board over serial or TCP)
//! closes the loop around the simulated vehicle, in lock-step simulated time.
//!
//! ```text
//! host-sim hil <scenario> [--qemu ELF | --serial DEVICE --baud N | --tcp HOST:PORT]
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
//! A frame lost on the way (noise injection) is detected by a reply timeout and sent again
//! with the same sequence number. Outputs: the same `summary.json` (plus a `hil` object with
//! the link statistics), `timeseries.csv` and plots as `host-sim run`, and
//! `telemetry.csv` with what the firmware reported each step.

use crate::link::{open, tcp_port, Endpoint, HostLinkStats, Link, Noise, NoiseSpec};
use crate::output::write_run;
use crate::runner::{
    body_to_inertial, make_plant, nominal_plant_params, verdict, RunOutput, Sample, Sensor, Summary,
};
use crate::scenario::{Plane, Scenario};
use anyhow::{anyhow, bail, Context, Result};
use controller_core::alloc::PwmMap;
use controller_core::controller::ControlMode;
use controller_core::params::Vehicle;
use firmware::protocol::{
    fault, Command, Law, LinkStats, Mode, NavSample, Plane as FwPlane, Reply,
};
use serde::Serialize;
use std::io::Write;
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Stdio};
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
}

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
    /// Wall-clock time to wait for a reply before sending again.
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

/// A QEMU child that is killed when dropped.
pub struct QemuChild {
    child: Child,
    monitor_port: Option<u16>,
}

impl Drop for QemuChild {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl QemuChild {
    /// Start QEMU with `elf`, its first serial port connecting to `port` on 127.0.0.1.
    /// With `monitor`, QEMU's monitor listens on a free port of 127.0.0.1 (for
    /// [`QemuChild::dump_ram`]).
    pub fn start(
        qemu: &str,
        elf: &Path,
        port: u16,
        log: Option<&Path>,
        monitor: bool,
    ) -> Result<Self> {
        if !elf.is_file() {
            bail!("firmware image {} not found", elf.display());
        }
        let out = match log {
            Some(p) => Stdio::from(
                std::fs::File::create(p)
                    .with_context(|| format!("cannot create {}", p.display()))?,
            ),
            None => Stdio::null(),
        };
        let monitor_port = if monitor {
            // A free port now; QEMU binds it a moment later (a small race, debug use only).
            Some(TcpListener::bind("127.0.0.1:0")?.local_addr()?.port())
        } else {
            None
        };
        let monitor_arg = match monitor_port {
            Some(p) => format!("tcp:127.0.0.1:{p},server=on,wait=off"),
            None => "none".into(),
        };
        let child = std::process::Command::new(qemu)
            .args(["-M", "netduinoplus2", "-nographic", "-monitor"])
            .arg(monitor_arg)
            .args(["-semihosting-config", "enable=on,target=native"])
            .args(["-icount", "shift=0,align=off,sleep=off"])
            .arg("-serial")
            .arg(format!("tcp:127.0.0.1:{port},nodelay=on"))
            .arg("-kernel")
            .arg(elf)
            .stdin(Stdio::null())
            .stdout(out)
            .stderr(Stdio::piped())
            .spawn()
            .with_context(|| format!("cannot start {qemu}"))?;
        Ok(Self {
            child,
            monitor_port,
        })
    }

    /// Save the emulated STM32F405's 128 KiB of SRAM (0x2000_0000) to `path`, through the
    /// monitor (`pmemsave`). QEMU starts with RAM zeroed, so the stack below its deepest
    /// point is still zero: `scripts/mcu-cost.sh` reads the firmware's stack high-water
    /// from this dump.
    pub fn dump_ram(&mut self, path: &Path) -> Result<()> {
        use std::io::Read;
        let port = self
            .monitor_port
            .ok_or_else(|| anyhow!("QEMU was started without a monitor"))?;
        let abs = std::path::absolute(path)?;
        let _ = std::fs::remove_file(&abs);
        let mut m = std::net::TcpStream::connect(("127.0.0.1", port))
            .context("cannot connect to the QEMU monitor")?;
        m.set_read_timeout(Some(Duration::from_millis(200)))?;
        let read_until_prompt = |m: &mut std::net::TcpStream| {
            let deadline = Instant::now() + Duration::from_secs(5);
            let mut got = Vec::new();
            let mut buf = [0u8; 512];
            while Instant::now() < deadline && !got.ends_with(b"(qemu) ") {
                if let Ok(n) = m.read(&mut buf) {
                    got.extend_from_slice(&buf[..n]);
                }
            }
        };
        read_until_prompt(&mut m);
        writeln!(m, "pmemsave 0x20000000 0x20000 \"{}\"", abs.display())?;
        read_until_prompt(&mut m);
        let deadline = Instant::now() + Duration::from_secs(5);
        while std::fs::metadata(&abs).map(|md| md.len()).unwrap_or(0) < 0x20000 {
            if Instant::now() > deadline {
                bail!("QEMU did not write {}", abs.display());
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        Ok(())
    }

    fn exited(&mut self) -> Option<String> {
        match self.child.try_wait() {
            Ok(Some(st)) => {
                let mut err = String::new();
                if let Some(mut e) = self.child.stderr.take() {
                    use std::io::Read;
                    let _ = e.read_to_string(&mut err);
                }
                Some(format!("QEMU exited ({st}): {}", err.trim()))
            }
            _ => None,
        }
    }
}

/// The firmware's `qemu` image for the emulated-board tests: `Ok(None)` when
/// `qemu-system-arm` is not installed (the caller skips), else the image named by
/// `HIL_FIRMWARE_ELF`, else the image built from the workspace at `root` into
/// `<target>/hil-firmware` (`target` = `CARGO_TARGET_DIR` or `root/target`), so that a test
/// never runs a stale image. Cargo rebuilds only what changed.
pub fn qemu_firmware_image(root: &Path) -> Result<Option<PathBuf>> {
    let qemu_ok = std::process::Command::new("qemu-system-arm")
        .arg("--version")
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false);
    if !qemu_ok {
        return Ok(None);
    }
    if let Some(p) = std::env::var_os("HIL_FIRMWARE_ELF") {
        return Ok(Some(PathBuf::from(p)));
    }
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("target"));
    let dir = if target.is_absolute() {
        target.join("hil-firmware")
    } else {
        root.join(target).join("hil-firmware")
    };
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let st = std::process::Command::new(cargo)
        .current_dir(root)
        .args([
            "build",
            "-q",
            "-p",
            "firmware",
            "--release",
            "--bin",
            "qemu",
        ])
        .args(["--target", "thumbv7em-none-eabihf", "--target-dir"])
        .arg(&dir)
        .status()
        .context("running cargo build for the firmware's qemu image")?;
    if !st.success() {
        bail!("building the firmware's qemu image failed ({st})");
    }
    Ok(Some(dir.join("thumbv7em-none-eabihf/release/qemu")))
}

/// Start QEMU with the firmware image `elf` and accept its serial connection on a port of
/// 127.0.0.1 bound here first (no race). The child is killed when the guard is dropped.
pub fn start_qemu_link(
    qemu: &str,
    elf: &Path,
    log: Option<&Path>,
    monitor: bool,
) -> Result<(QemuChild, Box<dyn crate::link::Port>)> {
    let listener = TcpListener::bind("127.0.0.1:0").context("cannot bind 127.0.0.1:0")?;
    let port = listener.local_addr()?.port();
    let mut q = QemuChild::start(qemu, elf, port, log, monitor)?;
    listener.set_nonblocking(true)?;
    let deadline = Instant::now() + Duration::from_secs(30);
    let stream = loop {
        match listener.accept() {
            Ok((s, _)) => break s,
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                if let Some(why) = q.exited() {
                    bail!("{why}");
                }
                if Instant::now() > deadline {
                    bail!("QEMU did not connect to 127.0.0.1:{port} within 30 s");
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            Err(e) => return Err(e).context("accept"),
        }
    };
    stream.set_nonblocking(false)?;
    Ok((q, Box::new(tcp_port(stream)?)))
}

/// The firmware's mode for a scenario's control mode.
pub fn firmware_mode(m: ControlMode) -> Mode {
    let (plane, law) = match m {
        ControlMode::PaperXz => (FwPlane::Xz, Law::Paper),
        ControlMode::PaperXy => (FwPlane::Xy, Law::Paper),
        ControlMode::TrackingXz => (FwPlane::Xz, Law::Tracking),
        ControlMode::TrackingXy => (FwPlane::Xy, Law::Tracking),
        ControlMode::Tracking3d => (FwPlane::ThreeD, Law::Tracking),
    };
    Mode::Track { plane, law }
}

fn us(t_s: f64) -> u64 {
    (t_s * 1e6).round().max(0.0) as u64
}

/// Run a scenario with the firmware in the loop. `qemu_log`: where QEMU's standard output
/// (semihosting, defmt frames) goes.
pub fn run_hil(sc: &Scenario, opts: &HilOptions, qemu_log: Option<&Path>) -> Result<HilOutput> {
    sc.validate()?;
    let wall = Instant::now();
    let mode = firmware_mode(sc.control_mode()?);

    // Bring up the link.
    let mut qemu_guard = None;
    let (port, target_name) = match &opts.target {
        HilTarget::Qemu { elf } => {
            let (q, p) = start_qemu_link(&opts.qemu, elf, qemu_log, opts.ram_dump.is_some())?;
            qemu_guard = Some(q);
            (p, "qemu netduinoplus2".to_string())
        }
        HilTarget::Board(ep) => (open(ep)?, format!("{ep:?}")),
    };
    let noise = opts.noise.map(Noise::new);
    let mut link = Link::new(port, None);

    // Hello (the emulator sends it at boot; a board may have sent it long ago).
    let hello_wait = match opts.target {
        HilTarget::Qemu { .. } => Duration::from_secs(30),
        HilTarget::Board(_) => Duration::from_secs(2),
    };
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
            "the firmware on {b:?} runs fixed-rate; hardware in the loop needs the lock-step \
             firmware (Config::lockstep)"
        ),
        None if matches!(opts.target, HilTarget::Qemu { .. }) => {
            bail!(
                "no Hello from the firmware within {} s",
                hello_wait.as_secs()
            )
        }
        None => "unknown (no Hello)".into(),
    };

    // Plant and measurement path, as in `runner::run`.
    let saturate = sc.thrusters.saturate;
    let nominal = Vehicle::observer();
    let pwm = PwmMap::for_vehicle(&nominal);
    let (lim_fwd, lim_rev) = (
        f64::from(nominal.params().thrust_max_forward_n),
        f64::from(nominal.params().thrust_max_reverse_n),
    );
    let plant_params = nominal_plant_params(sc);
    let env = crate::plant::Environment {
        current_m_s: sc.disturbance.current_m_s,
    };
    let initial = sc.initial.to_plant();
    let mut plant = make_plant(sc.plane, &plant_params, env, saturate, initial)?;
    let reference = sc.reference.to_core();
    let axes = sc.plane.axes();
    let n_sub = sc.plant_steps_per_control().max(1);
    let dt = sc.plant_dt_s;
    let tc = dt * n_sub as f64;
    let duration = opts.duration_s.unwrap_or(sc.duration_s);
    let n_ctrl = (duration / tc).round() as u64;
    let dist = &sc.disturbance;
    let mut sensor = Sensor::new(
        initial,
        (dist.delay_s / dt).round() as usize,
        dist.noise.then_some(dist.noise_std),
        dist.noise_seed,
    );

    // Set-up in lock-step time 0: heartbeat and a NavState (arming needs both), the
    // reference starting at 0, the mode, arm. Commands are sent without noise.
    let tmo = Duration::from_millis(500);
    link.send(&Command::Heartbeat { t_us: 0 })?;
    let nav0 = sensor.measure();
    let s0 = link.send(&Command::Nav(NavSample {
        t_us: 0,
        state: nav0,
    }))?;
    link.wait_for(
        Duration::from_secs(5),
        |r| match r {
            Reply::Telemetry(t) if t.nav_seq == s0 => Some(()),
            _ => None,
        },
        |_| {},
    )?
    .ok_or_else(|| anyhow!("no Telemetry for the first NavState"))?;
    let setup = [
        Command::SetReference {
            reference,
            start_us: Some(0),
        },
        Command::SetMode(mode),
        Command::Arm,
    ];
    for cmd in &setup {
        if let Err(reason) = link.command(cmd, tmo, 5, |_| {})? {
            bail!("the firmware refused {cmd:?}: {reason:?}");
        }
    }
    // Noise from here on (the set-up above is the operator's, on a clean link).
    link.set_noise(noise);

    let mut log = Vec::with_capacity(if opts.record { n_ctrl as usize + 1 } else { 0 });
    let mut tele = Vec::with_capacity(n_ctrl as usize + 1);
    let mut rep = HilReport {
        target: target_name,
        board,
        heartbeat_stop_s: opts.heartbeat_stop_s,
        ..HilReport::default()
    };
    let mut s = Summary {
        scenario: sc.name.clone(),
        plane: sc.plane.as_str().into(),
        controller: sc.controller.as_str().into(),
        reference: sc.reference.kind().into(),
        saturate,
        duration_s: duration,
        stop_reason: "completed".into(),
        ..Summary::default()
    };
    let (mut sum_sq, mut n_all, mut sum_sq_tail, mut n_tail, mut sum_sq_80, mut n_80) =
        (0.0, 0u64, 0.0, 0u64, 0.0, 0u64);
    let mut n_sat = 0u64;
    let mut ticks_sum = 0u64;
    let mut last = Sample::default();
    let t_tail = 0.8 * duration;
    let t_80 = 0.2 * duration;

    for k in 0..=n_ctrl {
        if wall.elapsed() > opts.wall_limit {
            bail!(
                "wall-clock limit of {} s reached at step {k}",
                opts.wall_limit.as_secs()
            );
        }
        let t = k as f64 * tc;
        let t_us = us(t);
        let truth = plant.state();
        let nav = sensor.measure();
        let heartbeats = opts.heartbeat_stop_s.is_none_or(|stop| t < stop);

        // One lock-step exchange, sent again (same sequence numbers) until answered.
        let nav_cmd = Command::Nav(NavSample { t_us, state: nav });
        let hb_cmd = Command::Heartbeat { t_us };
        let hb_seq = link.next_seq();
        if heartbeats {
            link.send(&hb_cmd)?;
        }
        let nav_seq = link.send(&nav_cmd)?;
        let mut tries = 1;
        let tel = loop {
            let got = link.wait_for(
                opts.reply_timeout,
                |r| match r {
                    Reply::Telemetry(tl) if tl.nav_seq == nav_seq => Some(Ok(*tl)),
                    Reply::Nack { seq, reason } if *seq == nav_seq => Some(Err(*reason)),
                    _ => None,
                },
                |_| {},
            )?;
            match got {
                Some(Ok(tl)) => break tl,
                Some(Err(reason)) => {
                    bail!("the firmware refused the NavState at t = {t:.3} s: {reason:?}")
                }
                None => {
                    link.stats.timeouts += 1;
                    if tries >= opts.max_tries {
                        bail!("control lost: no Telemetry for the NavState at t = {t:.3} s after {tries} sends");
                    }
                    tries += 1;
                    link.stats.resends += 1;
                    if heartbeats {
                        link.send_with_seq(hb_seq, &hb_cmd)?;
                    }
                    link.send_with_seq(nav_seq, &nav_cmd)?;
                }
            }
        };
        if tries > 1 {
            rep.steps_resent += 1;
        }
        rep.steps += 1;

        // Thrust the plant gets: from the pulse widths the ESCs see, or the commands.
        let applied = if opts.apply_pulses {
            tel.pulse_us.map(|p| f64::from(pwm.thrust_n(f32::from(p))))
        } else {
            tel.thrust_n.map(f64::from)
        };
        ticks_sum += u64::from(tel.loop_ticks);
        rep.loop_ticks_max = rep.loop_ticks_max.max(tel.loop_ticks);
        if !tel.armed {
            rep.steps_disarmed += 1;
        }
        if tel.faults & (fault::HEARTBEAT_LOST | fault::LINK_DISARMED | fault::NAV_STALE) != 0 {
            rep.steps_failsafe += 1;
        }
        if let Some(stop) = opts.heartbeat_stop_s {
            if t >= stop {
                // Neutral because of the link failsafe (not merely a zero command).
                let neutral = tel.pulse_us.iter().all(|&p| f32::from(p) == pwm.neutral_us)
                    && tel.faults & (fault::HEARTBEAT_LOST | fault::LINK_DISARMED) != 0;
                if neutral && rep.neutral_after_s.is_none() {
                    rep.neutral_after_s = Some(t - stop);
                }
                if !tel.armed && rep.disarmed_after_s.is_none() {
                    rep.disarmed_after_s = Some(t - stop);
                }
            }
        }
        tele.push(TelemetryRow {
            t_s: t,
            armed: tel.armed,
            faults: tel.faults,
            pulse_us: tel.pulse_us,
            thrust_n: tel.thrust_n,
            applied_n: applied,
            loop_ticks: tel.loop_ticks,
            // From the answer to this step's heartbeat (it comes before the telemetry).
            fw_rx_frames: link.last_status.map_or(0, |st| st.link.rx_frames),
            fw_dropped: link.last_status.map_or(0, |st| st.link.dropped.total()),
        });

        // Metrics on the true state (as `runner::run`).
        let r = reference.sample(t as f32);
        let ref_pos = r.pos_m.map(f64::from);
        let ref_vel = r.vel_m_s.map(f64::from);
        let vel = body_to_inertial(&truth.eta, [truth.nu[0], truth.nu[1], truth.nu[2]]);
        let mut pe = [0.0; 3];
        let mut ve = [0.0; 3];
        for i in 0..3 {
            if axes[i] {
                pe[i] = truth.eta[i] - ref_pos[i];
                ve[i] = vel[i] - ref_vel[i];
            }
        }
        let pen = (pe[0] * pe[0] + pe[1] * pe[1] + pe[2] * pe[2]).sqrt();
        let angle_err = f64::from(match sc.plane {
            Plane::Xz => tel.errors.pitch_rad,
            _ => tel.errors.yaw_rad,
        });
        let requested = [
            f64::from(tel.requested.surge_n),
            f64::from(tel.requested.yaw_n_m),
            f64::from(tel.requested.heave_n),
        ];
        let cmd = tel.thrust_n.map(f64::from);
        let exceeds = cmd
            .iter()
            .any(|&f| f > lim_fwd + 1e-6 || f < -lim_rev - 1e-6);
        let saturated = tel.faults & fault::SATURATED != 0 || exceeds;
        let sample = Sample {
            t_s: t,
            state: truth,
            ref_pos_m: ref_pos,
            ref_vel_m_s: ref_vel,
            pos_err_m: pe,
            pos_err_norm_m: pen,
            vel_err_m_s: ve,
            angle_err_rad: angle_err,
            law_errors: tel.errors,
            requested,
            achieved: [
                f64::from(tel.achieved.surge_n),
                f64::from(tel.achieved.yaw_n_m),
                f64::from(tel.achieved.heave_n),
            ],
            thrust_cmd_n: cmd,
            thrust_n: plant.thrust_n(),
            pulse_us: tel.pulse_us.map(f64::from),
            saturated,
        };
        if !truth.is_finite() || !pen.is_finite() {
            s.nan_detected = true;
            s.stop_reason = format!("non-finite state at t = {t:.3} s");
            last = sample;
            if opts.record {
                log.push(sample);
            }
            break;
        }
        sum_sq += pen * pen;
        n_all += 1;
        if t >= t_tail {
            sum_sq_tail += pen * pen;
            n_tail += 1;
        }
        if t >= t_80 {
            sum_sq_80 += pen * pen;
            n_80 += 1;
        }
        s.max_position_error_m = s.max_position_error_m.max(pen);
        if t >= 10.0 {
            s.max_position_error_after_10s_m = s.max_position_error_after_10s_m.max(pen);
            s.max_angle_error_after_10s_rad = s.max_angle_error_after_10s_rad.max(angle_err.abs());
        }
        for i in 0..3 {
            s.max_abs_requested_force[i] = s.max_abs_requested_force[i].max(requested[i].abs());
            s.max_abs_thruster_force_n = s.max_abs_thruster_force_n.max(cmd[i].abs());
        }
        if saturated {
            n_sat += 1;
        }
        s.control_steps += 1;
        s.simulated_s = t;
        last = sample;
        if opts.record {
            log.push(sample);
        }
        if pen > 1.0e3 || truth.eta[..3].iter().any(|v| v.abs() > 1.0e4) {
            s.diverged = true;
            s.stop_reason = format!("diverged at t = {t:.3} s");
            break;
        }
        if k == n_ctrl {
            break;
        }
        for _ in 0..n_sub {
            plant.step(applied, dt);
            s.sim_steps += 1;
            sensor.push(plant.state());
        }
    }

    let rms = |sq: f64, n: u64| {
        if n > 0 {
            (sq / n as f64).sqrt()
        } else {
            f64::NAN
        }
    };
    s.rms_position_error_m = rms(sum_sq, n_all);
    s.rms_position_error_tail_m = rms(sum_sq_tail, n_tail);
    s.rms_position_error_last80_m = rms(sum_sq_80, n_80);
    s.final_position_error_m = last.pos_err_norm_m;
    s.final_position_error_xyz_m = last.pos_err_m;
    s.final_angle_error_rad = last.angle_err_rad;
    s.saturated_fraction = if s.control_steps > 0 {
        n_sat as f64 / s.control_steps as f64
    } else {
        0.0
    };
    s.verdict = verdict(&s);
    let fs = last.state;
    s.final_state = fs.eta.iter().chain(fs.nu.iter()).copied().collect();
    s.wall_time_s = wall.elapsed().as_secs_f64();

    if let (Some(q), Some(p)) = (qemu_guard.as_mut(), opts.ram_dump.as_deref()) {
        q.dump_ram(p)?;
    }
    // The firmware's counters at the end: the answer to one more heartbeat (or, if that
    // is lost on a noisy link, the latest answer).
    let hb = link.send(&Command::Heartbeat {
        t_us: us(n_ctrl as f64 * tc),
    })?;
    let end_status = link.wait_for(
        Duration::from_millis(500),
        |r| match r {
            Reply::Status(st) if st.heartbeat_seq == hb => Some(*st),
            _ => None,
        },
        |_| {},
    )?;
    let fw: LinkStats = end_status
        .or(link.last_status)
        .map(|st| st.link)
        .unwrap_or_default();
    rep.firmware_rx_frames = fw.rx_frames;
    rep.firmware_dropped_frames = fw.dropped.total();
    rep.firmware_tx_frames = fw.tx_frames;
    rep.firmware_nacks = fw.nacks;
    rep.loop_ticks_mean = if rep.steps > 0 {
        ticks_sum as f64 / rep.steps as f64
    } else {
        0.0
    };
    rep.host = link.stats;
    rep.wall_time_s = s.wall_time_s;
    Ok(HilOutput {
        run: RunOutput { summary: s, log },
        report: rep,
        telemetry: tele,
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
    /// Run the firmware's QEMU image (default: target/thumbv7em-none-eabihf/release/qemu,
    /// built by `cargo build -p firmware --release --target thumbv7em-none-eabihf`).
    #[arg(long, value_name = "ELF", conflicts_with_all = ["serial", "tcp"])]
    pub qemu: Option<PathBuf>,
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
    /// it); received bytes are corrupted with probability NOISE / 100.
    #[arg(long, value_name = "PROB")]
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

/// `host-sim hil`.
pub fn main(a: HilArgs) -> Result<()> {
    let sc = Scenario::load(&a.scenario)?;
    let target = if let Some(dev) = a.serial {
        HilTarget::Board(Endpoint::Serial {
            device: dev,
            baud: a.baud,
        })
    } else if let Some(t) = a.tcp {
        HilTarget::Board(Endpoint::Tcp(t))
    } else {
        let elf = a
            .qemu
            .unwrap_or_else(|| PathBuf::from("target/thumbv7em-none-eabihf/release/qemu"));
        if !elf.is_file() {
            bail!(
                "{} not found: build it with `cargo build -p firmware --release --target \
                 thumbv7em-none-eabihf` or give --qemu ELF",
                elf.display()
            );
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
    Ok(())
}
