//! `rov-topside console`: a line console on the tether (arm, disarm, modes, references, the
//! pilot's thrust, navigation by hand for a bench test) with the telemetry to a CSV and a
//! status line; commands from standard input or a `--script`. [`console`] runs on any
//! [`Link`], so a test drives it against the emulated board.

use anyhow::{anyhow, bail, Context, Result};
use protocol::{Command, NackReason, Reply, Status, Telemetry};
use std::io::Write;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use crate::link::{HostLinkStats, Link};
use crate::port::{open, Port, VehicleLink};

/// Arguments of `rov-topside console`.
#[derive(Debug, clap::Args)]
pub struct ConsoleArgs {
    /// The vehicle to talk to.
    #[command(flatten)]
    pub vehicle: VehicleLink,
    /// Telemetry CSV (default out/link/telemetry.csv).
    #[arg(long)]
    pub csv: Option<PathBuf>,
    /// Commands to run, separated by ';' (then exit), instead of reading standard input.
    /// Example: "nav 0 0 1 0 auto; ref hold 0 0 1; mode track-3d; arm; wait 2; disarm".
    #[arg(long)]
    pub script: Option<String>,
    /// Heartbeat (and `nav auto`) period, milliseconds.
    #[arg(long, default_value_t = 100)]
    pub period_ms: u64,
}

/// One console command.
#[derive(Debug, Clone, PartialEq)]
pub enum ConsoleCmd {
    /// Send a firmware command (answered by Ack/Nack, or by Telemetry for `Nav`).
    Send(Command),
    /// Send `Nav` at the given pose; with `auto`, again every period (for a bench test
    /// without an estimator, and to clock a lock-step firmware).
    Nav(controller_core::state::NavState, bool),
    /// Stop the automatic `Nav`.
    NavStop,
    /// Wait (scripts).
    Wait(Duration),
    /// Leave.
    Quit,
    /// Print the help.
    Help,
}

/// Console help text.
pub const CONSOLE_HELP: &str =
    "commands: arm | disarm | mode idle|manual|hold|track-xz|track-xy|track-3d|paper-xz|paper-xy
          | ref hold X Y Z | ref line X Y Z HEADING SPEED | ref circle CX CY CZ RADIUS SPEED
          | ref helix CX CY CZ RADIUS SPEED DEPTH_RATE | ref paper H_R T_F
          | nav X Y Z YAW [auto] | nav stop | thrust SURGE YAW HEAVE (each -1..1)
          | wait SECONDS | help | quit";

fn nums(w: &[&str], n: usize) -> Result<Vec<f32>> {
    if w.len() < n {
        bail!("expected {n} numbers");
    }
    w[..n]
        .iter()
        .map(|s| s.parse::<f32>().map_err(|_| anyhow!("not a number: {s}")))
        .collect()
}

/// Parse one console line.
pub fn parse_console(line: &str) -> Result<Option<ConsoleCmd>> {
    use controller_core::controller::ControlMode;
    use controller_core::reference::{PaperPolynomial, Reference};
    use protocol::{ManualThrust, Mode};
    let w: Vec<&str> = line.split_whitespace().collect();
    let Some((&head, rest)) = w.split_first() else {
        return Ok(None);
    };
    let cmd = match head {
        "arm" => ConsoleCmd::Send(Command::Arm),
        "disarm" => ConsoleCmd::Send(Command::Disarm),
        "quit" | "exit" => ConsoleCmd::Quit,
        "help" | "?" => ConsoleCmd::Help,
        "wait" => ConsoleCmd::Wait(Duration::from_secs_f32(nums(rest, 1)?[0].max(0.0))),
        "mode" => {
            let m = match rest.first().copied().unwrap_or("") {
                "idle" => Mode::Idle,
                "manual" => Mode::Manual,
                "hold" => Mode::Hold,
                "track-xz" => Mode::from(ControlMode::TrackingXz),
                "track-xy" => Mode::from(ControlMode::TrackingXy),
                "track-3d" => Mode::from(ControlMode::Tracking3d),
                "paper-xz" => Mode::from(ControlMode::PaperXz),
                "paper-xy" => Mode::from(ControlMode::PaperXy),
                m => bail!("unknown mode {m:?}"),
            };
            ConsoleCmd::Send(Command::SetMode(m))
        }
        "ref" => {
            let kind = rest.first().copied().unwrap_or("");
            let a = rest.get(1..).unwrap_or(&[]);
            let reference = match kind {
                "hold" => {
                    let v = nums(a, 3)?;
                    Reference::Hold {
                        pos_m: [v[0], v[1], v[2]],
                    }
                }
                "line" => {
                    let v = nums(a, 5)?;
                    Reference::Line {
                        start_m: [v[0], v[1], v[2]],
                        heading_rad: v[3],
                        speed_m_s: v[4],
                    }
                }
                "circle" => {
                    let v = nums(a, 5)?;
                    Reference::Circle {
                        center_m: [v[0], v[1], v[2]],
                        radius_m: v[3],
                        speed_m_s: v[4],
                    }
                }
                "helix" => {
                    let v = nums(a, 6)?;
                    Reference::Helix {
                        center_m: [v[0], v[1], v[2]],
                        radius_m: v[3],
                        speed_m_s: v[4],
                        depth_rate_m_s: v[5],
                    }
                }
                "paper" => {
                    let v = nums(a, 2)?;
                    Reference::Paper(PaperPolynomial {
                        h_r_m: v[0],
                        t_f_s: v[1],
                    })
                }
                k => bail!("unknown reference kind {k:?}"),
            };
            ConsoleCmd::Send(Command::SetReference {
                reference,
                start_us: None,
            })
        }
        "nav" => {
            if rest.first() == Some(&"stop") {
                ConsoleCmd::NavStop
            } else {
                let v = nums(rest, 4)?;
                let auto = rest.get(4) == Some(&"auto");
                ConsoleCmd::Nav(
                    controller_core::state::NavState {
                        x_m: v[0],
                        y_m: v[1],
                        z_m: v[2],
                        yaw_rad: v[3],
                        ..Default::default()
                    },
                    auto,
                )
            }
        }
        "thrust" => {
            let v = nums(rest, 3)?;
            ConsoleCmd::Send(Command::ManualThrust(ManualThrust {
                surge: v[0],
                yaw: v[1],
                heave: v[2],
            }))
        }
        h => bail!("unknown command {h:?} ({CONSOLE_HELP})"),
    };
    Ok(Some(cmd))
}

/// Telemetry CSV header of the console. The last six columns are from the latest `Status`
/// (the answer to the console's heartbeats), empty before the first.
pub const CONSOLE_CSV_HEADER: &str = "host_s,t_us,mode,armed,faults,ex_m,ey_m,ez_m,e_pitch_rad,\
e_yaw_rad,tau1_req_n,tau2_req_n_m,tau3_req_n,f1x_n,f2x_n,f3z_n,pwm1_us,pwm2_us,pwm3_us,\
steps,loop_ticks,rx_frames,dropped,tx_frames,nacks";

fn csv_row(host_s: f64, t: &Telemetry, st: Option<&Status>) -> String {
    let e = &t.errors;
    let counters = st.map_or_else(
        || ",,,,".to_string(),
        |st| {
            format!(
                "{},{},{},{}",
                st.link.rx_frames,
                st.link.dropped.total(),
                st.link.tx_frames,
                st.link.nacks
            )
        },
    );
    format!(
        "{host_s:.3},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{counters}",
        t.t_us,
        format!("{:?}", t.mode).replace([',', ' '], ""),
        u8::from(t.armed),
        t.faults,
        e.x_m,
        e.y_m,
        e.z_m,
        e.pitch_rad,
        e.yaw_rad,
        t.requested.surge_n,
        t.requested.yaw_n_m,
        t.requested.heave_n,
        t.thrust_n[0],
        t.thrust_n[1],
        t.thrust_n[2],
        t.pulse_us[0],
        t.pulse_us[1],
        t.pulse_us[2],
        st.map_or(String::new(), |st| st.steps.to_string()),
        t.loop_ticks,
    )
}

fn status_line(t: &Telemetry, st: Option<&Status>, host: &HostLinkStats) -> String {
    let e = &t.errors;
    let err = (e.x_m * e.x_m + e.y_m * e.y_m + e.z_m * e.z_m).sqrt();
    let (rx, drop) = st.map_or((0, 0), |st| (st.link.rx_frames, st.link.dropped.total()));
    format!(
        "t={:>9.2}s {:<28} {} err={:.3}m pwm={}/{}/{} faults={:#06x} fw rx={} drop={} | host tx={} rx={} drop={}",
        t.t_us as f64 * 1e-6,
        format!("{:?}", t.mode),
        if t.armed { "ARMED   " } else { "disarmed" },
        err,
        t.pulse_us[0],
        t.pulse_us[1],
        t.pulse_us[2],
        t.faults,
        rx,
        drop,
        host.frames_sent,
        host.frames_received,
        host.frames_dropped
    )
}

/// What a console session saw.
#[derive(Debug, Clone, Default)]
pub struct ConsoleReport {
    /// Telemetry frames written to the CSV.
    pub telemetry_rows: u64,
    /// Rows in which the vehicle was armed.
    pub armed_rows: u64,
    /// Commands acknowledged.
    pub acks: u64,
    /// Commands refused, with the reason.
    pub nacks: Vec<(String, NackReason)>,
    /// Host link counters.
    pub host: HostLinkStats,
}

/// Run the console over `link`: heartbeats every `period`, commands from `commands` (a
/// script, or lines arriving on the channel), every telemetry frame to `csv`, a live status
/// line on standard error.
pub fn console(
    link: &mut Link,
    period: Duration,
    commands: std::sync::mpsc::Receiver<String>,
    csv: &mut dyn Write,
    live: bool,
) -> Result<ConsoleReport> {
    use std::sync::mpsc::TryRecvError;
    let start = Instant::now();
    let mut rep = ConsoleReport::default();
    let mut auto_nav: Option<controller_core::state::NavState> = None;
    let mut wait_until: Option<Instant> = None;
    let mut next_beat = Instant::now();
    let mut pending: Vec<(u16, String)> = Vec::new();
    let mut input_closed = false;
    let mut closed_at: Option<Instant> = None;
    writeln!(csv, "{CONSOLE_CSV_HEADER}")?;
    loop {
        let now = Instant::now();
        let t_us = start.elapsed().as_micros() as u64;
        if now >= next_beat {
            next_beat = now + period;
            link.send(&Command::Heartbeat { t_us })?;
            if let Some(n) = auto_nav {
                link.send(&Command::Nav(protocol::NavSample { t_us, state: n }))?;
            }
        }
        // Next command, unless a `wait` is running.
        if wait_until.is_none_or(|w| now >= w) {
            wait_until = None;
            match commands.try_recv() {
                Ok(line) => match parse_console(&line) {
                    Ok(None) => {}
                    Ok(Some(ConsoleCmd::Quit)) => break,
                    Ok(Some(ConsoleCmd::Help)) => eprintln!("\n{CONSOLE_HELP}"),
                    Ok(Some(ConsoleCmd::Wait(d))) => wait_until = Some(now + d),
                    Ok(Some(ConsoleCmd::NavStop)) => auto_nav = None,
                    Ok(Some(ConsoleCmd::Nav(n, auto))) => {
                        link.send(&Command::Nav(protocol::NavSample { t_us, state: n }))?;
                        auto_nav = auto.then_some(n);
                    }
                    Ok(Some(ConsoleCmd::Send(c))) => {
                        let seq = link.send(&c)?;
                        pending.push((seq, line.trim().to_string()));
                    }
                    Err(e) => eprintln!("\n{e:#}"),
                },
                Err(TryRecvError::Empty) => {}
                Err(TryRecvError::Disconnected) => {
                    input_closed = true;
                    closed_at.get_or_insert(now);
                }
            }
        }
        if input_closed && wait_until.is_none() && pending.is_empty() {
            break;
        }
        // Replies until the next heartbeat is due.
        let left = next_beat.saturating_duration_since(Instant::now());
        if let Some((_, r)) = link.recv(left.min(Duration::from_millis(20)))? {
            match r {
                Reply::Telemetry(t) => {
                    rep.telemetry_rows += 1;
                    if t.armed {
                        rep.armed_rows += 1;
                    }
                    writeln!(
                        csv,
                        "{}",
                        csv_row(start.elapsed().as_secs_f64(), &t, link.last_status.as_ref())
                    )?;
                    if live {
                        eprint!(
                            "\r{}",
                            status_line(&t, link.last_status.as_ref(), &link.stats)
                        );
                    }
                }
                Reply::Ack { seq } => {
                    if let Some(i) = pending.iter().position(|(s, _)| *s == seq) {
                        let (_, what) = pending.remove(i);
                        rep.acks += 1;
                        eprintln!("\nok: {what}");
                    }
                }
                Reply::Nack { seq, reason } => {
                    if let Some(i) = pending.iter().position(|(s, _)| *s == seq) {
                        let (_, what) = pending.remove(i);
                        eprintln!("\nrefused: {what}: {reason:?}");
                        rep.nacks.push((what, reason));
                    }
                }
                Reply::Hello { board, .. } => eprintln!("\nhello from {board:?}"),
                // Kept by the link (`last_status`) for the CSV and the status line; a session
                // is the link's own.
                Reply::Status(_) | Reply::Session { .. } => {}
            }
        }
        // Answers still missing 2 s after the last command: give up on them.
        if closed_at.is_some_and(|c| c.elapsed() > Duration::from_secs(2)) {
            break;
        }
    }
    csv.flush()?;
    if live {
        eprintln!();
    }
    rep.host = link.stats;
    Ok(rep)
}

/// `rov-topside console`.
pub fn main(a: ConsoleArgs) -> Result<()> {
    let port: Box<dyn Port> = open(&a.vehicle.endpoint()?)?;
    let mut link = Link::new(port, None);
    let csv_path = a
        .csv
        .unwrap_or_else(|| PathBuf::from("out/link/telemetry.csv"));
    if let Some(d) = csv_path.parent() {
        std::fs::create_dir_all(d)?;
    }
    let mut csv = std::io::BufWriter::new(
        std::fs::File::create(&csv_path)
            .with_context(|| format!("cannot create {}", csv_path.display()))?,
    );
    let (tx, rx) = std::sync::mpsc::channel();
    if let Some(s) = a.script {
        for c in s.split(';') {
            let _ = tx.send(c.to_string());
        }
        drop(tx);
    } else {
        eprintln!("{CONSOLE_HELP}");
        std::thread::spawn(move || {
            let stdin = std::io::stdin();
            let mut line = String::new();
            while stdin.read_line(&mut line).map(|n| n > 0).unwrap_or(false) {
                if tx.send(std::mem::take(&mut line)).is_err() {
                    break;
                }
            }
        });
    }
    let rep = console(
        &mut link,
        Duration::from_millis(a.period_ms.max(10)),
        rx,
        &mut csv,
        true,
    )?;
    println!(
        "{} telemetry rows ({} armed) in {}; {} commands acknowledged, {} refused; host sent {} \
         frames, received {}, dropped {}",
        rep.telemetry_rows,
        rep.armed_rows,
        csv_path.display(),
        rep.acks,
        rep.nacks.len(),
        rep.host.frames_sent,
        rep.host.frames_received,
        rep.host.frames_dropped
    );
    Ok(())
}
