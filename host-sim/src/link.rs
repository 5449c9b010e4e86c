//! The host's end of the tether: a byte port (TCP or a serial device), the firmware's own
//! framing ([`firmware::protocol`]: postcard + CRC-32 + COBS), sequence numbers, link
//! statistics and optional noise injection (for the corrupted-byte tests).
//!
//! Used by `host-sim hil` (lock-step with an emulated or real board) and `host-sim link`
//! (a topside console: arm, disarm, mode, reference, telemetry to CSV).

use anyhow::{anyhow, bail, Context, Result};
use firmware::protocol::{
    encode, Command, Decoded, DropCounters, FrameDecoder, NackReason, Reply, Status, Telemetry,
    MAX_FRAME_LEN,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::collections::VecDeque;
use std::io::{ErrorKind, Write};
use std::path::PathBuf;
use std::time::{Duration, Instant};

pub use crate::port::{open, tcp_port, Endpoint, Port, POLL};

/// Noise injected on the link, both ways.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseSpec {
    /// Host -> firmware: probability that a frame gets one corrupted byte (replaced by a
    /// random value or one bit flipped).
    pub tx_frame_error_prob: f64,
    /// Host -> firmware: probability that 1-8 random bytes precede a frame.
    pub tx_garbage_prob: f64,
    /// Firmware -> host: probability that a received byte gets one bit flipped.
    pub rx_byte_error_prob: f64,
    /// Seed (runs are reproducible for a seed, up to wall-clock timeouts).
    pub seed: u64,
}

/// A [`NoiseSpec`] with its random generator.
#[derive(Debug, Clone)]
pub struct Noise {
    /// The settings.
    pub spec: NoiseSpec,
    rng: ChaCha8Rng,
}

impl Noise {
    /// Noise of a spec.
    pub fn new(spec: NoiseSpec) -> Self {
        Self {
            spec,
            rng: ChaCha8Rng::seed_from_u64(spec.seed),
        }
    }
}

/// What the host counted on the link.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct HostLinkStats {
    /// Frames sent.
    pub frames_sent: u64,
    /// Good frames received.
    pub frames_received: u64,
    /// Frames received and dropped by the host's decoder (all reasons).
    pub frames_dropped: u64,
    /// The host decoder's drops, by reason.
    #[serde(skip)]
    pub dropped_by_reason: DropCounters,
    /// Bytes sent (frames, garbage included).
    pub bytes_sent: u64,
    /// Bytes received.
    pub bytes_received: u64,
    /// Frames the host corrupted on purpose (noise injection).
    pub frames_corrupted: u64,
    /// Garbage bytes the host inserted on purpose.
    pub garbage_bytes: u64,
    /// Received bytes the host corrupted on purpose before decoding.
    pub rx_bytes_corrupted: u64,
    /// Replies that did not come in time (each followed by a resend).
    pub timeouts: u64,
    /// Commands sent again after a timeout.
    pub resends: u64,
    /// `Ack` replies.
    pub acks: u64,
    /// `Nack` replies.
    pub nacks: u64,
}

/// The host end of the tether.
pub struct Link {
    port: Box<dyn Port>,
    dec: FrameDecoder<Reply>,
    seq: u16,
    /// The vehicle's session (0: none open yet; protocol version 6).
    session: u32,
    noise: Option<Noise>,
    pending: VecDeque<(u16, Reply)>,
    /// Counters.
    pub stats: HostLinkStats,
    /// The latest `Status` received (the firmware's answer to a heartbeat: its link
    /// counters and health).
    pub last_status: Option<Status>,
}

impl Link {
    /// A link over `port`, with optional noise on what the host sends.
    pub fn new(port: Box<dyn Port>, noise: Option<Noise>) -> Self {
        Self {
            port,
            dec: FrameDecoder::new(),
            seq: 0,
            session: 0,
            noise,
            pending: VecDeque::new(),
            stats: HostLinkStats::default(),
            last_status: None,
        }
    }

    /// Change the noise settings (counters are kept).
    pub fn set_noise(&mut self, noise: Option<Noise>) {
        self.noise = noise;
    }

    /// Sequence number the next command will carry.
    pub fn next_seq(&self) -> u16 {
        self.seq
    }

    /// The session in force (0 before the first send).
    pub fn session(&self) -> u32 {
        self.session
    }

    /// Open a new session with the vehicle (protocol version 6): `OpenSession` with a random
    /// nonce, answered by `Reply::Session`; sent up to 3 times, 2 s each. The sequence
    /// numbers start again. Other replies that arrive meanwhile are kept for `recv`.
    pub fn open_session(&mut self) -> Result<u32> {
        let nonce: u32 = rand::random();
        let mut kept = Vec::new();
        let mut got = None;
        for _ in 0..3 {
            self.seq = 1;
            self.session = 0;
            self.send_with_seq(0, &Command::OpenSession { nonce })?;
            let deadline = Instant::now() + Duration::from_secs(2);
            while got.is_none() {
                let left = deadline.saturating_duration_since(Instant::now());
                let Some((seq, r)) = self.recv(left)? else {
                    break;
                };
                match r {
                    Reply::Session { nonce: n, session } if n == nonce => got = Some(session),
                    r => kept.push((seq, r)),
                }
            }
            if got.is_some() {
                break;
            }
            self.stats.timeouts += 1;
        }
        for r in kept.into_iter().rev() {
            self.pending.push_front(r);
        }
        let session = got.ok_or_else(|| anyhow!("the vehicle did not open a session"))?;
        self.session = session;
        Ok(session)
    }

    /// Send `cmd`; returns its sequence number. Opens a session first when none is open, and
    /// a new one before the sequence numbers would wrap (the vehicle takes only rising ones).
    pub fn send(&mut self, cmd: &Command) -> Result<u16> {
        if self.session == 0 || self.seq >= u16::MAX - 1 {
            self.open_session()?;
        }
        let seq = self.seq;
        self.seq = self.seq.wrapping_add(1);
        self.send_with_seq(seq, cmd)?;
        Ok(seq)
    }

    /// Send `cmd` with a given sequence number in the session in force (the vehicle refuses
    /// a number not above the last one it took: `Replayed`).
    pub fn send_with_seq(&mut self, seq: u16, cmd: &Command) -> Result<()> {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = encode(self.session, seq, cmd, &mut buf).map_err(|e| anyhow!("encode: {e}"))?;
        let mut bytes = Vec::with_capacity(frame.len() + 10);
        if let Some(n) = self.noise.as_mut() {
            if n.rng.random::<f64>() < n.spec.tx_garbage_prob {
                let k = n.rng.random_range(1..=8usize);
                for _ in 0..k {
                    bytes.push(n.rng.random::<u8>());
                }
                self.stats.garbage_bytes += k as u64;
            }
        }
        // A leading delimiter ends whatever garbage came before, so the frame itself is
        // decoded intact (the decoder ignores the empty frame it makes on a clean line).
        bytes.push(0);
        let start = bytes.len();
        bytes.extend_from_slice(frame);
        if let Some(n) = self.noise.as_mut() {
            if n.rng.random::<f64>() < n.spec.tx_frame_error_prob && frame.len() > 1 {
                // Any byte but the delimiter.
                let i = start + n.rng.random_range(0..frame.len() - 1);
                let old = bytes[i];
                let new = if n.rng.random::<bool>() {
                    old ^ (1u8 << n.rng.random_range(0..8u32))
                } else {
                    n.rng.random::<u8>()
                };
                bytes[i] = if new == old { old ^ 0x5A } else { new };
                self.stats.frames_corrupted += 1;
            }
        }
        self.port.write_all(&bytes).context("link write")?;
        self.port.flush().ok();
        self.stats.frames_sent += 1;
        self.stats.bytes_sent += bytes.len() as u64;
        Ok(())
    }

    /// The next good frame, waiting up to `timeout`; `None` on timeout.
    pub fn recv(&mut self, timeout: Duration) -> Result<Option<(u16, Reply)>> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(f) = self.pending.pop_front() {
                return Ok(Some(f));
            }
            let mut buf = [0u8; 512];
            match self.port.read(&mut buf) {
                Ok(0) => {
                    // A TCP peer that closed reads 0 at once; a tty with VTIME reads 0 on
                    // timeout. Either way, wait out the deadline without spinning hard.
                    std::thread::sleep(Duration::from_millis(1));
                }
                Ok(n) => {
                    self.stats.bytes_received += n as u64;
                    if let Some(nz) = self.noise.as_mut() {
                        if nz.spec.rx_byte_error_prob > 0.0 {
                            for b in &mut buf[..n] {
                                if nz.rng.random::<f64>() < nz.spec.rx_byte_error_prob {
                                    *b ^= 1u8 << nz.rng.random_range(0..8u32);
                                    self.stats.rx_bytes_corrupted += 1;
                                }
                            }
                        }
                    }
                    for &b in &buf[..n] {
                        match self.dec.push(b) {
                            Some(Decoded::Frame { seq, msg, .. }) => {
                                self.stats.frames_received += 1;
                                match msg {
                                    Reply::Ack { .. } => self.stats.acks += 1,
                                    Reply::Nack { .. } => self.stats.nacks += 1,
                                    Reply::Status(st) => self.last_status = Some(st),
                                    _ => {}
                                }
                                self.pending.push_back((seq, msg));
                            }
                            Some(Decoded::Dropped { .. }) => {
                                self.stats.frames_dropped += 1;
                                self.stats.dropped_by_reason = self.dec.dropped;
                            }
                            None => {}
                        }
                    }
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted
                    ) => {}
                Err(e) => return Err(e).context("link read"),
            }
            if Instant::now() >= deadline {
                return Ok(None);
            }
        }
    }

    /// Wait up to `timeout` for a reply that `pick` accepts; other replies are passed to
    /// `other` (e.g. periodic telemetry for a CSV).
    pub fn wait_for<T>(
        &mut self,
        timeout: Duration,
        mut pick: impl FnMut(&Reply) -> Option<T>,
        mut other: impl FnMut(&Reply),
    ) -> Result<Option<T>> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let Some((_, r)) = self.recv(left)? else {
                return Ok(None);
            };
            if let Some(t) = pick(&r) {
                return Ok(Some(t));
            }
            other(&r);
            if Instant::now() >= deadline {
                return Ok(None);
            }
        }
    }

    /// Send a command that is answered by `Ack`/`Nack` and wait for the answer, resending
    /// up to `tries` times on timeout (each send a new sequence number: the vehicle refuses
    /// a repeated one as a replay; the answer to any of them counts). A `NoSession` refusal
    /// (the vehicle restarted, or another surface opened a session) opens a new session and
    /// sends again. `Ok(Err(reason))` is a `Nack`.
    pub fn command(
        &mut self,
        cmd: &Command,
        timeout: Duration,
        tries: u32,
        mut other: impl FnMut(&Reply),
    ) -> Result<std::result::Result<(), NackReason>> {
        let mut sent = vec![self.send(cmd)?];
        let mut reopened = false;
        for attempt in 0..tries.max(1) {
            if attempt > 0 {
                self.stats.resends += 1;
                sent.push(self.send(cmd)?);
            }
            let got = self.wait_for(
                timeout,
                |r| match r {
                    Reply::Ack { seq: s } if sent.contains(s) => Some(Ok(())),
                    Reply::Nack { seq: s, reason } if sent.contains(s) => Some(Err(*reason)),
                    _ => None,
                },
                &mut other,
            )?;
            if got == Some(Err(NackReason::NoSession)) && !reopened {
                reopened = true;
                self.open_session()?;
                sent.push(self.send(cmd)?);
                continue;
            }
            if let Some(r) = got {
                return Ok(r);
            }
            self.stats.timeouts += 1;
        }
        bail!("no answer to {cmd:?} after {} tries", tries.max(1))
    }
}

// ---- `host-sim link`: a topside console -------------------------------------------------

/// Arguments of `host-sim link`.
#[derive(Debug, clap::Args)]
pub struct LinkArgs {
    /// A board on a serial device.
    #[arg(long, value_name = "DEVICE", conflicts_with_all = ["tcp", "qemu"])]
    pub serial: Option<PathBuf>,
    /// Baud rate of `--serial`.
    #[arg(long, default_value_t = 115_200)]
    pub baud: u32,
    /// A board or bridge at HOST:PORT.
    #[arg(long, value_name = "HOST:PORT", conflicts_with = "qemu")]
    pub tcp: Option<String>,
    /// Start the firmware's QEMU image and talk to it (a dry run of the console).
    #[arg(long, value_name = "ELF")]
    pub qemu: Option<PathBuf>,
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
          | ref helix CX CY CZ RADIUS SPEED DEPTH_RATE | ref paper H_R T_F | ref scenario NAME
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
    use firmware::protocol::{ManualThrust, Mode};
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
                "scenario" => {
                    let name = a.first().ok_or_else(|| anyhow!("ref scenario NAME"))?;
                    crate::scenario::Scenario::load(name)?.reference.to_core()
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
                link.send(&Command::Nav(firmware::protocol::NavSample {
                    t_us,
                    state: n,
                }))?;
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
                        link.send(&Command::Nav(firmware::protocol::NavSample {
                            t_us,
                            state: n,
                        }))?;
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

/// `host-sim link`.
pub fn main(a: LinkArgs) -> Result<()> {
    let mut _qemu = None;
    let port: Box<dyn Port> = if let Some(elf) = &a.qemu {
        let (q, p) = crate::qemu::start_qemu_link("qemu-system-arm", elf, None, false)?;
        _qemu = Some(q);
        p
    } else if let Some(dev) = &a.serial {
        open(&Endpoint::Serial {
            device: dev.clone(),
            baud: a.baud,
        })?
    } else if let Some(t) = &a.tcp {
        open(&Endpoint::Tcp(t.clone()))?
    } else {
        bail!("give --serial DEVICE, --tcp HOST:PORT or --qemu ELF");
    };
    let mut link = Link::new(port, None);
    if a.qemu.is_some() {
        // The emulated USART drops bytes sent before it is enabled: wait for the Hello.
        let hello = link.wait_for(
            Duration::from_secs(30),
            |r| matches!(r, Reply::Hello { .. }).then_some(()),
            |_| {},
        )?;
        if hello.is_none() {
            bail!("no Hello from the emulated firmware within 30 s");
        }
        eprintln!("hello from the emulated firmware");
    }
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
