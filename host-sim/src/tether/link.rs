//! The host's end of the tether: a byte port (TCP or a serial device), the firmware's own
//! framing ([`firmware::protocol`]: postcard + CRC-32 + COBS), sequence numbers, link
//! statistics and optional noise injection (for the corrupted-byte tests).

pub use crate::tether::port::{open, tcp_port, Endpoint, Port, POLL};
use anyhow::{anyhow, bail, Context, Result};
use firmware::protocol::{
    encode, Command, Decoded, DropCounters, FrameDecoder, NackReason, Reply, Status, MAX_FRAME_LEN,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::collections::VecDeque;
use std::io::{ErrorKind, Write};
use std::time::{Duration, Instant};

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
