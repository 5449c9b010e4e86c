//! The host's end of the tether: the protocol's session [`Client`] on a byte port (TCP or a
//! serial device), with blocking waits on the wall clock, link statistics and optional noise
//! injection (for the corrupted-byte tests). The session itself (handshake, sequence numbers,
//! answers matched, time-outs) is the client's; this file moves its bytes and tells it the
//! time.

pub use crate::port::{open, tcp_port, Endpoint, Port, POLL};
use anyhow::{anyhow, bail, Context, Result};
use protocol::{
    Answer, Client, ClientConfig, Command, DropCounters, Event, NackReason, Reply, Status,
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

/// How long the vehicle may take to answer `OpenSession` (s); [`Link::open_session`] asks
/// up to [`OPEN_TRIES`] times.
const OPEN_TIMEOUT: Duration = Duration::from_secs(2);
/// `OpenSession`s sent before [`Link::open_session`] gives up.
const OPEN_TRIES: u32 = 3;

/// The host end of the tether.
pub struct Link {
    port: Box<dyn Port>,
    client: Client,
    /// The client's clock starts here.
    epoch: Instant,
    noise: Option<Noise>,
    /// What the client reported and no caller took yet.
    pending: VecDeque<Event>,
    /// Counters.
    pub stats: HostLinkStats,
    /// The latest `Status` received (the firmware's answer to a heartbeat: its link
    /// counters and health).
    pub last_status: Option<Status>,
}

impl Link {
    /// A link over `port`, with optional noise on what the host sends.
    pub fn new(port: Box<dyn Port>, noise: Option<Noise>) -> Self {
        let config = ClientConfig {
            open_timeout_us: OPEN_TIMEOUT.as_micros() as u64,
            ..ClientConfig::DEFAULT
        };
        Self {
            port,
            client: Client::new(config),
            epoch: Instant::now(),
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
        self.client.next_seq()
    }

    /// The session in force (0 before the first send).
    pub fn session(&self) -> u32 {
        self.client.session()
    }

    /// The client's clock: microseconds since the link was made.
    fn now_us(&self) -> u64 {
        self.epoch.elapsed().as_micros() as u64
    }

    /// Open a new session with the vehicle (protocol version 6): `OpenSession` with a random
    /// nonce, answered by `Reply::Session`; sent up to 3 times, 2 s each. The sequence
    /// numbers start again. Other replies that arrive meanwhile are kept for `recv`. With a
    /// session in force (its numbers used up, or the vehicle refusing it) the `OpenSession`
    /// is framed in it ([`Client::renew`]): a vehicle that still holds that session keeps
    /// what this surface's pilot commands; to any other it is a new surface.
    pub fn open_session(&mut self) -> Result<u32> {
        let nonce: u32 = rand::random();
        let mut kept = Vec::new();
        let mut got = None;
        for _ in 0..OPEN_TRIES {
            let frame = self
                .client
                .renew(nonce, self.now_us())
                .map_err(|e| anyhow!("encode: {e}"))?;
            self.write_frame(frame.bytes())?;
            // The client's time-out ends the wait; the deadline is a backstop.
            let deadline = Instant::now() + OPEN_TIMEOUT + POLL;
            while let Some(e) = self.next_event(deadline)? {
                match e {
                    Event::Reply {
                        answer: Some(Answer::Session { session }),
                        ..
                    } => got = Some(session),
                    Event::Reply {
                        answer: Some(Answer::SessionRefused(why)),
                        ..
                    } => bail!("the vehicle refused to open a session: {why:?}"),
                    Event::OpenTimedOut { .. } => break,
                    e => kept.push(e),
                }
                if got.is_some() {
                    break;
                }
            }
            if got.is_some() {
                break;
            }
            self.stats.timeouts += 1;
        }
        for e in kept.into_iter().rev() {
            self.pending.push_front(e);
        }
        got.ok_or_else(|| anyhow!("the vehicle did not open a session"))
    }

    /// Send `cmd`; returns its sequence number. Opens a session first when none is open, and
    /// a new one before the sequence numbers would wrap (the vehicle takes only rising ones).
    pub fn send(&mut self, cmd: &Command) -> Result<u16> {
        let timeout_us = self.client.config().answer_timeout_us;
        self.send_within(cmd, timeout_us)
    }

    /// [`send`](Self::send), a command answered by `Ack` awaited for `timeout_us`.
    fn send_within(&mut self, cmd: &Command, timeout_us: u64) -> Result<u16> {
        if self.client.needs_session() {
            self.open_session()?;
        }
        let sent = self
            .client
            .send_within(cmd, self.now_us(), timeout_us)
            .map_err(|e| anyhow!("{cmd:?}: {e}"))?;
        self.write_frame(sent.frame.bytes())?;
        Ok(sent.seq)
    }

    /// Write one frame, with the noise asked for.
    fn write_frame(&mut self, frame: &[u8]) -> Result<()> {
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

    /// Received bytes to the client; what it reports is counted and kept.
    fn feed(&mut self, bytes: &[u8]) {
        let mut rest = bytes;
        while let Some(e) = self.client.receive(&mut rest) {
            match &e {
                Event::Reply { reply, .. } => {
                    self.stats.frames_received += 1;
                    match reply {
                        Reply::Ack { .. } => self.stats.acks += 1,
                        Reply::Nack { .. } => self.stats.nacks += 1,
                        Reply::Status(st) => self.last_status = Some(*st),
                        _ => {}
                    }
                }
                Event::Dropped { .. } => {
                    self.stats.frames_dropped += 1;
                    self.stats.dropped_by_reason = self.client.dropped();
                }
                Event::TimedOut { .. } | Event::OpenTimedOut { .. } => {}
            }
            self.pending.push_back(e);
        }
    }

    /// The next thing the client reports (a reply, a dropped frame, a time-out), reading the
    /// port until `deadline`; `None` after it.
    fn next_event(&mut self, deadline: Instant) -> Result<Option<Event>> {
        loop {
            if let Some(e) = self.pending.pop_front() {
                return Ok(Some(e));
            }
            if let Some(e) = self.client.poll(self.now_us()) {
                return Ok(Some(e));
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
                    self.feed(&buf[..n]);
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted
                    ) => {}
                Err(e) => return Err(e).context("link read"),
            }
            if self.pending.is_empty() && Instant::now() >= deadline {
                return Ok(None);
            }
        }
    }

    /// The next good frame, waiting up to `timeout`; `None` on timeout.
    pub fn recv(&mut self, timeout: Duration) -> Result<Option<(u16, Reply)>> {
        let deadline = Instant::now() + timeout;
        while let Some(e) = self.next_event(deadline)? {
            if let Event::Reply { seq, reply, .. } = e {
                return Ok(Some((seq, reply)));
            }
        }
        Ok(None)
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

    /// Wait for the client's answer to one of the commands `sent` until the latest one times
    /// out (or `timeout` passed); other replies are passed to `other`.
    fn await_answer(
        &mut self,
        sent: &[u16],
        timeout: Duration,
        other: &mut impl FnMut(&Reply),
    ) -> Result<Option<std::result::Result<(), NackReason>>> {
        let latest = sent.last().copied();
        // The client's time-out ends the wait; the deadline is a backstop.
        let deadline = Instant::now() + timeout + POLL;
        while let Some(e) = self.next_event(deadline)? {
            match e {
                Event::Reply {
                    answer: Some(Answer::Command { seq, result }),
                    ..
                } if sent.contains(&seq) => return Ok(Some(result)),
                Event::Reply { reply, .. } => other(&reply),
                Event::TimedOut { seq } if Some(seq) == latest => return Ok(None),
                _ => {}
            }
        }
        Ok(None)
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
        let timeout_us = timeout.as_micros() as u64;
        let mut sent = vec![self.send_within(cmd, timeout_us)?];
        let mut reopened = false;
        for attempt in 0..tries.max(1) {
            if attempt > 0 {
                self.stats.resends += 1;
                sent.push(self.send_within(cmd, timeout_us)?);
            }
            let got = self.await_answer(&sent, timeout, &mut other)?;
            if got == Some(Err(NackReason::NoSession)) && !reopened {
                reopened = true;
                self.open_session()?;
                // The earlier session's numbers mean nothing in the new one.
                sent = vec![self.send_within(cmd, timeout_us)?];
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
