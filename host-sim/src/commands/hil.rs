//! `host-sim hil`: hardware in the loop. The firmware (QEMU, a board, or the library in
//! process) closes the loop through [`TetherEndpoint`], lock-step, and the run is written as a
//! software run's plus the telemetry and the link's figures.

use crate::closed_loop::{run_closed_loop, RunOptions};
use crate::output::write_run;
use crate::tether::board_wires::BoardWires;
pub use crate::tether::endpoint::{
    HilOptions, HilOutput, HilReport, HilTarget, TelemetryRow, TetherEndpoint,
    DEFAULT_NAV_READY_LIMIT_S, MAX_REPLY_WAIT,
};
use crate::tether::in_process::InProcessFirmware;
use crate::tether::link::{open, Link, NoiseSpec, Port};
use crate::tether::qemu::{
    qemu_firmware_image, qemu_layout_images, start_qemu_board, workspace_root, FirmwareImage,
    LayoutImages, QemuClock,
};
use crate::tether::topside_layout;
use anyhow::{anyhow, bail, Result};
use sim_scenario::deployment::Control;
use sim_scenario::setup::RunSetup;
use sim_scenario::Scenario;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Run a scenario with the firmware in the loop. `qemu_log`: where QEMU's standard output
/// (semihosting, defmt frames) goes.
pub fn run_hil(sc: &RunSetup, opts: &HilOptions, qemu_log: Option<&Path>) -> Result<HilOutput> {
    let mut qemu_guard = None;
    let mut dvl_wire = None;
    let mut board_wires = None;
    let (port, target_name, hello_wait, hello_required): (Box<dyn Port>, _, _, _) =
        match &opts.target {
            HilTarget::Qemu { elf } => {
                let clock = if opts.count_instructions {
                    QemuClock::Instructions
                } else {
                    QemuClock::Host
                };
                let (q, p, dvl, health) =
                    start_qemu_board(&opts.qemu, elf, qemu_log, opts.ram_dump.is_some(), clock)?;
                qemu_guard = Some(q);
                board_wires = Some(BoardWires::new(sc, dvl, health)?);
                (
                    p,
                    "qemu netduinoplus2".to_string(),
                    Duration::from_secs(30),
                    true,
                )
            }
            HilTarget::InProcess => {
                let fw = InProcessFirmware::for_scenario(sc)?;
                dvl_wire = opts.dvl_on_uart.then(|| fw.dvl_wire());
                (
                    Box::new(fw),
                    "in-process firmware library".to_string(),
                    Duration::from_secs(1),
                    true,
                )
            }
            HilTarget::Board(ep) => (open(ep)?, format!("{ep:?}"), Duration::from_secs(2), false),
        };
    let port: Box<dyn Port> = match &opts.tether_log {
        Some(path) => Box::new(topside::tether_log::LoggedPort::new(port, path)?),
        None => port,
    };
    let link = Link::new(port, None);
    let mut endpoint =
        TetherEndpoint::connect(link, sc, opts, target_name, hello_wait, hello_required)?;
    if let Some(wire) = dvl_wire {
        endpoint.set_dvl_wire(wire);
    }
    if let Some(wires) = board_wires {
        endpoint.set_board_wires(wires, opts.dvl_on_uart);
    }
    let mut nav = crate::closed_loop::estimator_nav::navigation_for_vehicle(sc);
    let run_opts = RunOptions {
        record: opts.record,
        duration_s: opts.duration_s,
        ..RunOptions::default()
    };
    let run = run_closed_loop(sc, &run_opts, nav.as_mut(), &mut endpoint)?;
    if let (Some(q), Some(p)) = (qemu_guard.as_mut(), opts.ram_dump.as_deref()) {
        q.dump_ram(p)?;
    }
    let (report, telemetry) = endpoint.finish(run.summary.simulated_s)?;
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
    /// The firmware in the loop (default, without one: the workspace's image in QEMU).
    #[command(flatten)]
    pub firmware: crate::commands::FirmwareArgs,
    /// Run the firmware library's `App` in this process (no emulator needed).
    #[arg(long, conflicts_with_all = ["serial", "tcp", "qemu"])]
    pub in_process: bool,
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
    /// On QEMU: count instructions (`-icount shift=0`), so that the control iteration is
    /// reported in instructions. Without it the board runs on the host's clock, faster, and
    /// the iteration is not reported.
    #[arg(long)]
    pub count_instructions: bool,
    /// With --qemu: save the emulated 128 KiB SRAM to FILE at the end (stack high-water).
    #[arg(long, value_name = "FILE")]
    pub ram_dump: Option<PathBuf>,
    /// With the estimator on board and a position mode: the longest simulated time to wait,
    /// armed and neutral, for the vehicle's estimate to be ready before the mode is set
    /// (an unknown start); past it the run fails with the reason (s).
    #[arg(long, value_name = "SECONDS", default_value_t = DEFAULT_NAV_READY_LIMIT_S)]
    pub nav_ready_limit: f64,
    /// Give up after this much wall-clock time (s): a guard against a hung emulator. The
    /// 23-minute survey on QEMU takes about an hour on a loaded 2-core machine.
    #[arg(long, value_name = "SECONDS", default_value_t = 600, value_parser = clap::value_parser!(u64).range(1..))]
    pub wall_limit: u64,
    /// Write the raw tether log here (`rov-topside`'s format: what `host-sim identify`
    /// reads as a dive's log).
    #[arg(long, value_name = "FILE")]
    pub tether_log: Option<PathBuf>,
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

/// `host-sim hil` of a scenario with `[deployment] control = "topside"`: without a target,
/// the two emulated images (`topside-emu`, `node-emu`, built from the workspace) each in
/// QEMU; `--in-process`, the firmware library's roles. A board (`--serial`, `--tcp`) or
/// one image (`--qemu ELF`) is refused with the reason: the layout is two images.
fn topside_hil(sc: &Scenario, a: HilArgs) -> Result<HilOutput> {
    let target = if a.in_process {
        topside_layout::LayoutTarget::InProcess
    } else if a.firmware.board().is_some() || a.firmware.qemu.is_some() {
        return Err(crate::checks::refused(anyhow!(
            "deployment.control = \"topside\": hil flies the topside layout's two emulated \
             images (the default: topside-emu and node-emu built from the workspace, each in \
             QEMU) or --in-process; --serial, --tcp and --qemu ELF name one board"
        )));
    } else {
        match qemu_layout_images(&workspace_root())? {
            LayoutImages::Ready(elfs) => topside_layout::LayoutTarget::Emulated {
                elfs,
                qemu: a.qemu_bin.clone(),
            },
            LayoutImages::Unavailable(why) => {
                bail!("the emulated boards cannot run here: {why} (or use --in-process)")
            }
        }
    };
    let o = topside_layout::hil_main(sc, &target, a.out, a.duration)?;
    let (name, board) = match target {
        topside_layout::LayoutTarget::InProcess => (
            "in-process topside layout",
            "topside + node (firmware library)",
        ),
        topside_layout::LayoutTarget::Emulated { .. } => (
            "emulated topside layout",
            "topside-emu + node-emu (qemu netduinoplus2 x 2)",
        ),
    };
    Ok(HilOutput {
        run: o.run,
        report: HilReport {
            target: name.into(),
            board: board.into(),
            onboard_estimator: true,
            ..HilReport::default()
        },
        telemetry: Vec::new(),
    })
}

/// `host-sim hil`.
/// Run `host-sim hil`; the output decides the exit code (`main.rs`: 1 when the run diverged,
/// went non-finite or missed its scenario's targets, as `run`).
pub fn main(a: HilArgs) -> Result<HilOutput> {
    let sc = Scenario::load_setup(&a.scenario).map_err(crate::checks::refused)?;
    if sc.deployment.control == Control::Topside {
        return topside_hil(&sc, a);
    }
    let target = if let Some(board) = a.firmware.board() {
        HilTarget::Board(board)
    } else if a.in_process {
        HilTarget::InProcess
    } else {
        let elf = match a.firmware.qemu {
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
    o.count_instructions = a.count_instructions;
    o.ram_dump = a.ram_dump;
    o.nav_ready_limit_s = a.nav_ready_limit;
    o.tether_log = a.tether_log;
    o.wall_limit = std::time::Duration::from_secs(a.wall_limit);
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
        s.wall_time_s
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
    let iteration = if matches!(o.target, HilTarget::Qemu { .. }) && !o.count_instructions {
        "not counted (--count-instructions counts it)".to_string()
    } else {
        format!(
            "{:.0} instructions mean, {} max",
            r.loop_ticks_mean, r.loop_ticks_max
        )
    };
    println!(
        "board: {}; control iteration {iteration}; disarmed steps {}, failsafe steps {}",
        r.board, r.steps_disarmed, r.steps_failsafe
    );
    if let (Some(o), Some(t)) = (r.compass_swing, r.calibration_end_s) {
        println!("compass calibration turn, ended at {t:.2} s: {o:?}");
    }
    if let Some(t) = r.mode_set_at_s.filter(|t| *t > 0.0) {
        println!("the vehicle's estimate was ready at {t:.2} s: armed and neutral until then");
    }
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
