//! The surface's end of a session with the vehicle, without I/O of its own ("sans-IO"): the
//! caller moves the bytes and tells the time, the client keeps the session.
//!
//! - **Handshake**: [`Client::open`] frames `OpenSession` with the caller's nonce (sequence
//!   number 0, envelope session 0); the vehicle's `Reply::Session` with that nonce opens the
//!   session, whose number every later frame carries.
//! - **Rising sequence numbers**: [`Client::send`] numbers commands from 1 in each session
//!   (the vehicle refuses a number not above the last one it took, `Replayed`); before they
//!   would wrap, [`Client::needs_session`] says to renew the session ([`Client::renew`]:
//!   `OpenSession` framed in the session in force, so the vehicle knows the same surface
//!   and keeps what its pilot commands; an `OpenSession` in no session is a new surface, and
//!   the pilot input of the session before stops acting).
//! - **Acks matched**: an `Ack` or `Nack` naming a number sent in the session is reported as
//!   that command's [`Answer::Command`]. Replies carry no session, so an answer to an earlier
//!   session's frame with the same number cannot be told apart; opening a session forgets the
//!   commands awaited in the previous one.
//! - **Time-outs**: a command the vehicle answers with `Ack` ([`Response::Ack`]) is awaited
//!   until its deadline; [`Client::poll`] reports the ones that passed (and an `OpenSession`
//!   not answered in time). [`Client::next_deadline`] says when to poll next.
//!
//! A caller's loop: write what [`open`](Client::open) and [`send`](Client::send) return;
//! feed what arrives to [`receive`](Client::receive) until the bytes are used up; call
//! [`poll`](Client::poll) with the time now. A refusal `NoSession` (the vehicle restarted,
//! or another surface opened a session) is the caller's to act on: the client cannot tell
//! whether it refuses a frame of this session or a late one of an earlier session.
//!
//! No allocation: a frame is a value of [`MAX_FRAME_LEN`] bytes; at most [`AWAITED`]
//! commands are awaited at once (a further one forgets the one due first, counted in
//! [`Client::forgotten`]).

use crate::decoder::{Decoded, DropCounters, DropReason, FrameDecoder};
use crate::framing::{encode, EncodeError, MAX_FRAME_LEN};
use crate::messages::{Command, NackReason, Reply, Response};

/// Commands awaited at once.
pub const AWAITED: usize = 16;

/// The sequence number of `OpenSession`; the session's commands follow from 1.
const OPEN_SEQ: u16 = 0;

/// The first sequence number not sent: a session whose next number reaches it is renewed
/// (the vehicle takes only rising numbers, so the last ones are kept in reserve).
pub const SEQ_LIMIT: u16 = u16::MAX - 1;

/// Time-outs, microseconds of the caller's clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClientConfig {
    /// How long the vehicle may take to answer `OpenSession`.
    pub open_timeout_us: u64,
    /// How long the vehicle may take to answer a command with `Ack` or `Nack`
    /// ([`Client::send`]; [`Client::send_within`] sets it per command).
    pub answer_timeout_us: u64,
}

impl ClientConfig {
    /// 2 s for the session, 1 s for an answer.
    pub const DEFAULT: Self = Self {
        open_timeout_us: 2_000_000,
        answer_timeout_us: 1_000_000,
    };
}

impl Default for ClientConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// One frame to write, both delimiters included.
#[derive(Clone, Copy)]
pub struct Frame {
    buf: [u8; MAX_FRAME_LEN],
    len: usize,
}

impl Frame {
    /// Encode `msg` in `session` with `seq`.
    fn encode(session: u32, seq: u16, cmd: &Command) -> Result<Self, EncodeError> {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let len = encode(session, seq, cmd, &mut buf)?.len();
        Ok(Self { buf, len })
    }

    /// The bytes to write.
    pub fn bytes(&self) -> &[u8] {
        self.buf.get(..self.len).unwrap_or_default()
    }
}

impl core::fmt::Debug for Frame {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_tuple("Frame").field(&self.bytes()).finish()
    }
}

/// A command framed by [`Client::send`].
#[derive(Debug, Clone, Copy)]
pub struct Sent {
    /// Its sequence number (what the vehicle's answer names).
    pub seq: u16,
    /// The bytes to write.
    pub frame: Frame,
}

/// Why a command was not framed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum SendError {
    /// No session is open: [`Client::open`] first.
    NoSession,
    /// The session's sequence numbers are used up: open a new session.
    SeqExhausted,
    /// `OpenSession` goes through [`Client::open`].
    OpenSession,
    /// The message does not fit a frame.
    Encode(EncodeError),
}

impl core::fmt::Display for SendError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SendError::NoSession => write!(f, "no session open with the vehicle"),
            SendError::SeqExhausted => write!(f, "the session's sequence numbers are used up"),
            SendError::OpenSession => write!(f, "OpenSession is sent by Client::open"),
            SendError::Encode(e) => write!(f, "encode: {e}"),
        }
    }
}

impl core::error::Error for SendError {}

impl From<EncodeError> for SendError {
    fn from(e: EncodeError) -> Self {
        SendError::Encode(e)
    }
}

/// What a reply meant to the session.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Answer {
    /// The vehicle opened the session asked for: its number.
    Session {
        /// The session's number, in every later frame.
        session: u32,
    },
    /// The vehicle refused the `OpenSession` asked for (e.g. `UnsupportedVersion`).
    SessionRefused(NackReason),
    /// The vehicle took (`Ack`) or refused (`Nack`) command `seq` of this session.
    Command {
        /// The command's sequence number.
        seq: u16,
        /// `Err` with the reason of a `Nack`.
        result: Result<(), NackReason>,
    },
}

/// What [`Client::receive`] and [`Client::poll`] report.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event {
    /// A good frame from the vehicle, and what it answered if it answered the session.
    Reply {
        /// The vehicle's sequence number of the frame.
        seq: u16,
        /// The frame's message.
        reply: Reply,
        /// The session opened or refused, or a command of this session answered.
        answer: Option<Answer>,
    },
    /// A frame the decoder dropped (counted in [`Client::dropped`]).
    Dropped {
        /// Why.
        reason: DropReason,
        /// Its sequence number, when readable.
        seq: Option<u16>,
    },
    /// Command `seq`, awaited, was not answered by its deadline (a late answer is still
    /// reported as an [`Answer::Command`]).
    TimedOut {
        /// The command's sequence number.
        seq: u16,
    },
    /// The `OpenSession` with `nonce` was not answered in time; no session is open.
    OpenTimedOut {
        /// Its nonce.
        nonce: u32,
    },
}

/// A command awaiting its answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Awaited {
    seq: u16,
    deadline_us: u64,
}

/// The surface's end of a session: see the [module](self).
#[derive(Debug)]
pub struct Client {
    config: ClientConfig,
    /// The session in force (0: none).
    session: u32,
    /// The `OpenSession` awaiting its answer: nonce and deadline.
    opening: Option<(u32, u64)>,
    /// The sequence number that `OpenSession` was framed with (a refusal names it).
    opening_seq: u16,
    /// A renewal not answered yet: the session it renews and the number a retry is framed
    /// with.
    renewing: Option<(u32, u16)>,
    next_seq: u16,
    awaited: [Option<Awaited>; AWAITED],
    forgotten: u32,
    decoder: FrameDecoder<Reply>,
}

impl Default for Client {
    fn default() -> Self {
        Self::new(ClientConfig::DEFAULT)
    }
}

impl Client {
    /// A client with no session.
    pub fn new(config: ClientConfig) -> Self {
        Self {
            config,
            session: 0,
            opening: None,
            opening_seq: OPEN_SEQ,
            renewing: None,
            next_seq: OPEN_SEQ + 1,
            awaited: [None; AWAITED],
            forgotten: 0,
            decoder: FrameDecoder::new(),
        }
    }

    /// The time-outs.
    pub fn config(&self) -> ClientConfig {
        self.config
    }

    /// The session in force (0: none).
    pub fn session(&self) -> u32 {
        self.session
    }

    /// True while an `OpenSession` awaits its answer.
    pub fn is_opening(&self) -> bool {
        self.opening.is_some()
    }

    /// True when [`send`](Self::send) needs a new session first: none is open, or its
    /// sequence numbers are used up.
    pub fn needs_session(&self) -> bool {
        self.session == 0 || self.next_seq >= SEQ_LIMIT
    }

    /// The sequence number the next command will carry.
    pub fn next_seq(&self) -> u16 {
        self.next_seq
    }

    /// Good frames received.
    pub fn frames_received(&self) -> u32 {
        self.decoder.frames
    }

    /// Frames dropped by the decoder, by reason.
    pub fn dropped(&self) -> DropCounters {
        self.decoder.dropped
    }

    /// Awaited commands forgotten because [`AWAITED`] were awaited already.
    pub fn forgotten(&self) -> u32 {
        self.forgotten
    }

    /// Open a session as a new surface (ending the one in force): the `OpenSession` frame
    /// with `nonce`, in no session, to write; awaited until `now_us` plus the open time-out.
    /// Sequence numbers start again. To the vehicle this is a new surface: the pilot input
    /// of the session before stops acting ([`renew`](Self::renew) continues a session).
    pub fn open(&mut self, nonce: u32, now_us: u64) -> Result<Frame, EncodeError> {
        self.renewing = None;
        self.open_framed(0, OPEN_SEQ, nonce, now_us)
    }

    /// Renew the session in force (its numbers near their end): `OpenSession` framed in it
    /// with the next number, which only this surface can frame, so the vehicle takes it as
    /// the same surface and its pilot's input keeps acting. A retry of a renewal not
    /// answered is framed in the session it renews with a number above the last one; with
    /// no session to renew this is [`open`](Self::open).
    pub fn renew(&mut self, nonce: u32, now_us: u64) -> Result<Frame, EncodeError> {
        let renewed = match (self.session, self.renewing) {
            (0, Some(r)) => Some(r),
            (0, None) => None,
            (session, _) => Some((session, self.next_seq)),
        };
        match renewed {
            Some((session, seq)) if seq < u16::MAX => {
                self.renewing = Some((session, seq + 1));
                self.open_framed(session, seq, nonce, now_us)
            }
            _ => self.open(nonce, now_us),
        }
    }

    fn open_framed(
        &mut self,
        session: u32,
        seq: u16,
        nonce: u32,
        now_us: u64,
    ) -> Result<Frame, EncodeError> {
        let frame = Frame::encode(session, seq, &Command::OpenSession { nonce })?;
        self.session = 0;
        self.next_seq = OPEN_SEQ + 1;
        self.awaited = [None; AWAITED];
        let deadline = now_us.saturating_add(self.config.open_timeout_us);
        self.opening = Some((nonce, deadline));
        self.opening_seq = seq;
        Ok(frame)
    }

    /// Frame `cmd` in the session with the next sequence number; a command answered by
    /// `Ack` is awaited until `now_us` plus the answer time-out.
    pub fn send(&mut self, cmd: &Command, now_us: u64) -> Result<Sent, SendError> {
        self.send_within(cmd, now_us, self.config.answer_timeout_us)
    }

    /// [`send`](Self::send) with the command's own answer time-out.
    pub fn send_within(
        &mut self,
        cmd: &Command,
        now_us: u64,
        timeout_us: u64,
    ) -> Result<Sent, SendError> {
        if matches!(cmd, Command::OpenSession { .. }) {
            return Err(SendError::OpenSession);
        }
        if self.session == 0 {
            return Err(SendError::NoSession);
        }
        if self.next_seq >= SEQ_LIMIT {
            return Err(SendError::SeqExhausted);
        }
        let seq = self.next_seq;
        let frame = Frame::encode(self.session, seq, cmd)?;
        self.next_seq = seq.wrapping_add(1);
        if cmd.response() == Response::Ack {
            self.await_answer(seq, now_us.saturating_add(timeout_us));
        }
        Ok(Sent { seq, frame })
    }

    /// Keep `seq` awaited; when all slots are taken, the one due first is forgotten.
    fn await_answer(&mut self, seq: u16, deadline_us: u64) {
        let entry = Some(Awaited { seq, deadline_us });
        if let Some(free) = self.awaited.iter_mut().find(|a| a.is_none()) {
            *free = entry;
            return;
        }
        let first = self
            .awaited
            .iter_mut()
            .min_by_key(|a| a.map_or(0, |a| a.deadline_us));
        if let Some(slot) = first {
            *slot = entry;
            self.forgotten = self.forgotten.wrapping_add(1);
        }
    }

    /// True while command `seq` awaits its answer.
    pub fn is_awaited(&self, seq: u16) -> bool {
        self.awaited.iter().flatten().any(|a| a.seq == seq)
    }

    /// Feed received bytes up to the first one that ends a frame, advance `bytes` past
    /// them and report it (`None` when `bytes` ran out first). Call again while `bytes` is
    /// not empty.
    pub fn receive(&mut self, bytes: &mut &[u8]) -> Option<Event> {
        match self.decoder.push_slice(bytes)? {
            Decoded::Frame { seq, msg, .. } => {
                let answer = self.answer_of(&msg);
                Some(Event::Reply {
                    seq,
                    reply: msg,
                    answer,
                })
            }
            Decoded::Dropped { reason, seq } => Some(Event::Dropped { reason, seq }),
        }
    }

    /// What `reply` means to the session, and the session's state after it.
    fn answer_of(&mut self, reply: &Reply) -> Option<Answer> {
        match *reply {
            Reply::Session { nonce, session } => match self.opening {
                Some((n, _)) if n == nonce && session != 0 => {
                    self.opening = None;
                    self.renewing = None;
                    self.session = session;
                    Some(Answer::Session { session })
                }
                _ => None,
            },
            Reply::Nack { seq, reason } if self.opening.is_some() && seq == self.opening_seq => {
                self.opening = None;
                Some(Answer::SessionRefused(reason))
            }
            Reply::Ack { seq } => self.command_answered(seq, Ok(())),
            Reply::Nack { seq, reason } => self.command_answered(seq, Err(reason)),
            _ => None,
        }
    }

    /// An answer to `seq`, if the session sent it.
    fn command_answered(&mut self, seq: u16, result: Result<(), NackReason>) -> Option<Answer> {
        let sent = self.session != 0 && seq > OPEN_SEQ && seq < self.next_seq;
        if !sent {
            return None;
        }
        for slot in &mut self.awaited {
            if slot.is_some_and(|a| a.seq == seq) {
                *slot = None;
            }
        }
        Some(Answer::Command { seq, result })
    }

    /// The next time-out due at `now_us`, if any: an `OpenSession` first, then the awaited
    /// command due first. Call again until `None`.
    pub fn poll(&mut self, now_us: u64) -> Option<Event> {
        if let Some((nonce, deadline)) = self.opening {
            if now_us >= deadline {
                self.opening = None;
                return Some(Event::OpenTimedOut { nonce });
            }
        }
        let due = self
            .awaited
            .iter_mut()
            .filter(|a| a.is_some_and(|a| a.deadline_us <= now_us))
            .min_by_key(|a| a.map_or(0, |a| a.deadline_us))?;
        let seq = due.take()?.seq;
        Some(Event::TimedOut { seq })
    }

    /// When [`poll`](Self::poll) has something to report next (the caller's clock), if
    /// anything is awaited.
    pub fn next_deadline(&self) -> Option<u64> {
        let awaited = self.awaited.iter().flatten().map(|a| a.deadline_us).min();
        let opening = self.opening.map(|(_, d)| d);
        match (awaited, opening) {
            (Some(a), Some(o)) => Some(a.min(o)),
            (a, o) => a.or(o),
        }
    }
}

#[cfg(test)]
mod tests;
