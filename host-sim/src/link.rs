//! The host's end of the tether: a byte port (TCP or a serial device), the firmware's own
//! framing ([`firmware::protocol`]: postcard + CRC-32 + COBS), sequence numbers, link
//! statistics and optional noise injection (for the corrupted-byte tests).
//!
//! Used by `host-sim hil` (lock-step with an emulated or real board) and `host-sim link`
//! (a topside console: arm, disarm, mode, reference, telemetry to CSV).

use anyhow::{anyhow, bail, Context, Result};
use firmware::protocol::{
    encode, Command, Decoded, DropCounters, FrameDecoder, NackReason, Reply, MAX_FRAME_LEN,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::collections::VecDeque;
use std::io::{ErrorKind, Read, Write};
use std::net::TcpStream;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Where the other end of the tether is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Endpoint {
    /// A TCP socket (`HOST:PORT`), e.g. a serial-to-TCP bridge or QEMU's `-serial tcp:`.
    Tcp(String),
    /// A serial device (`/dev/ttyUSB0`) at a baud rate, set up raw with `stty`.
    Serial {
        /// Device path.
        device: PathBuf,
        /// Baud rate.
        baud: u32,
    },
}

/// A byte port with a short read timeout (reads return `Ok(0)` or `WouldBlock`/`TimedOut`
/// when nothing arrived).
pub trait Port: Read + Write + Send {}
impl<T: Read + Write + Send> Port for T {}

/// Read timeout of the ports: short, so a waiting loop can check its own deadline.
pub const POLL: Duration = Duration::from_millis(20);

/// Open an endpoint.
pub fn open(ep: &Endpoint) -> Result<Box<dyn Port>> {
    match ep {
        Endpoint::Tcp(addr) => {
            let s =
                TcpStream::connect(addr).with_context(|| format!("cannot connect to {addr}"))?;
            Ok(Box::new(tcp_port(s)?))
        }
        Endpoint::Serial { device, baud } => {
            // Raw mode, no echo, reads return after 0.1 s without data (VMIN 0, VTIME 1).
            let st = std::process::Command::new("stty")
                .arg("-F")
                .arg(device)
                .args([
                    &baud.to_string(),
                    "raw",
                    "-echo",
                    "-echoe",
                    "-echok",
                    "-ixon",
                ])
                .args([
                    "-ixoff", "-crtscts", "cs8", "-parenb", "-cstopb", "min", "0",
                ])
                .args(["time", "1"])
                .status()
                .context("cannot run stty")?;
            if !st.success() {
                bail!("stty could not set up {} at {baud} baud", device.display());
            }
            let f = std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .open(device)
                .with_context(|| format!("cannot open {}", device.display()))?;
            Ok(Box::new(f))
        }
    }
}

/// Configure an accepted or connected TCP stream as a port.
pub fn tcp_port(s: TcpStream) -> Result<TcpStream> {
    s.set_nodelay(true)?;
    s.set_read_timeout(Some(POLL))?;
    Ok(s)
}

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
    noise: Option<Noise>,
    pending: VecDeque<(u16, Reply)>,
    /// Counters.
    pub stats: HostLinkStats,
}

impl Link {
    /// A link over `port`, with optional noise on what the host sends.
    pub fn new(port: Box<dyn Port>, noise: Option<Noise>) -> Self {
        Self {
            port,
            dec: FrameDecoder::new(),
            seq: 0,
            noise,
            pending: VecDeque::new(),
            stats: HostLinkStats::default(),
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

    /// Send `cmd`; returns its sequence number.
    pub fn send(&mut self, cmd: &Command) -> Result<u16> {
        let seq = self.seq;
        self.seq = self.seq.wrapping_add(1);
        self.send_with_seq(seq, cmd)?;
        Ok(seq)
    }

    /// Send `cmd` with a given sequence number (a resend keeps its number).
    pub fn send_with_seq(&mut self, seq: u16, cmd: &Command) -> Result<()> {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = encode(seq, cmd, &mut buf).map_err(|e| anyhow!("encode: {e}"))?;
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
                            Some(Decoded::Frame { seq, msg }) => {
                                self.stats.frames_received += 1;
                                match msg {
                                    Reply::Ack { .. } => self.stats.acks += 1,
                                    Reply::Nack { .. } => self.stats.nacks += 1,
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
    /// (same sequence number) up to `tries` times on timeout. `Ok(Err(reason))` is a `Nack`.
    pub fn command(
        &mut self,
        cmd: &Command,
        timeout: Duration,
        tries: u32,
        mut other: impl FnMut(&Reply),
    ) -> Result<std::result::Result<(), NackReason>> {
        let seq = self.send(cmd)?;
        for attempt in 0..tries.max(1) {
            if attempt > 0 {
                self.stats.resends += 1;
                self.send_with_seq(seq, cmd)?;
            }
            let got = self.wait_for(
                timeout,
                |r| match r {
                    Reply::Ack { seq: s } if *s == seq => Some(Ok(())),
                    Reply::Nack { seq: s, reason } if *s == seq => Some(Err(*reason)),
                    _ => None,
                },
                &mut other,
            )?;
            if let Some(r) = got {
                return Ok(r);
            }
            self.stats.timeouts += 1;
        }
        bail!("no answer to {cmd:?} after {} tries", tries.max(1))
    }
}
