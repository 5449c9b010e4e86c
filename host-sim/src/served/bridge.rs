//! The vehicle's side of the served tether: the surface's frames pass to the App's serial
//! port with the App's own session gate in force, and the vehicle's own inputs (the
//! simulated navigation computer's `Nav`, the on-board instruments' fixes) reach the same
//! App without a second serial port.
//!
//! The App has one serial port and one session in force, so the vehicle-side inputs travel
//! in the same session as the surface's frames. The bridge gives every frame the App takes
//! a sequence number of its own (rising, in the App's session) and the App's answers are
//! given back the surface's numbers: `Ack` and `Nack` (`seq`), `Status` (`heartbeat_seq`).
//! Everything else passes byte for byte, in both directions. The App decides every frame:
//! a surface frame in a session that is not the one in force reaches the App in that
//! session (refused `NoSession`); a surface number not above the last one taken reaches it
//! with number 0 (refused `Replayed`); a frame that does not decode passes unchanged (the
//! App counts it; a refusal of it, under a number the bridge did not give, is not sent back:
//! the surface's own time-out handles it). Answers to the vehicle's own inputs are not sent
//! to the surface. The bridge opens a session of its own at boot (before a surface opens
//! one) and renews the App's session before the numbers would wrap (framed in it, as the
//! surface in force renews: the pilot's input keeps acting); the surface keeps the session
//! number it was given. A surface's renewal (its `OpenSession` framed in its session in
//! force) reaches the App framed in the App's session; any other surface `OpenSession` is a
//! new surface's to the App too.
//!
//! Before a lock-step image (the firmware in QEMU, whose clock is the time stamps it is
//! given) the bridge also stands in for a board's own clock: a surface `Heartbeat` reaches
//! it stamped with the vehicle's time ([`TetherBridge::set_vehicle_time`]; a fixed-rate board
//! ignores the stamp and reads its clock), and the image's `Telemetry`, which answers every
//! control step there, reaches the surface at a board's telemetry period
//! ([`TetherBridge::set_telemetry_period`]).

use anyhow::{anyhow, Result};
use controller_core::state::NavState;
use firmware::protocol::{
    decode_frame, encode, Command, Decoded, NackReason, Reply, MAX_FRAME_LEN,
};
use std::collections::{BTreeMap, VecDeque};

/// The bridge opens a new App session when its numbers reach this (the App takes only
/// rising ones).
const RENEW_AT: u16 = 0xFF00;

/// Answers the bridge waits for at most (older ones are forgotten: a lost answer).
const MAX_PENDING: usize = 4096;

/// Vehicle inputs held at most while the bridge's session opens.
const MAX_HELD: usize = 64;

/// A frame being read from a byte stream, split at the delimiters.
#[derive(Debug, Default)]
struct Splitter {
    chunk: Vec<u8>,
}

impl Splitter {
    /// The complete chunks in `bytes` (each without its closing delimiter; empty for a lone
    /// delimiter).
    fn push(&mut self, bytes: &[u8]) -> Vec<Vec<u8>> {
        let mut out = Vec::new();
        for &b in bytes {
            if b == 0 {
                out.push(std::mem::take(&mut self.chunk));
            } else if self.chunk.len() <= 2 * MAX_FRAME_LEN {
                self.chunk.push(b);
            }
        }
        out
    }
}

/// The frame `msg` in `session` with `seq`, its leading delimiter left out (the chunk it
/// replaces was already closed by one).
fn frame<M: serde::Serialize>(session: u32, seq: u16, msg: &M) -> Result<Vec<u8>> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let f = encode(session, seq, msg, &mut buf).map_err(|e| anyhow!("encode: {e}"))?;
    Ok(f.get(1..).unwrap_or_default().to_vec())
}

/// The two directions of the served tether around the App's serial port.
#[derive(Debug, Default)]
pub struct TetherBridge {
    from_surface: Splitter,
    from_app: Splitter,
    /// The session in force on the App (0: none yet), and the surface's number for it.
    app_session: u32,
    surface_session: u32,
    /// The App's number of the next frame the bridge sends: rising through the sessions,
    /// back to 1 only when the bridge opens a session for that.
    next_seq: u16,
    /// The last surface number taken in the surface's session.
    surface_last: Option<u16>,
    /// App numbers of the surface's frames -> the surface's numbers.
    to_surface: BTreeMap<u16, u16>,
    /// Surface numbers sent with number 0 (a replay), in order.
    replays: VecDeque<u16>,
    /// The nonce of a session the bridge asked for.
    opening: Option<u32>,
    /// A surface's `OpenSession` not answered yet: the App's number, the surface's.
    surface_opening: Option<(u16, u16)>,
    /// Vehicle inputs waiting for the bridge's session to open.
    held: Vec<Command>,
    /// Vehicle inputs refused by the App.
    pub own_refused: u64,
    /// Why the App refused the latest vehicle input it refused.
    pub own_refused_why: Option<NackReason>,
    /// The vehicle's time (us) a surface `Heartbeat` is stamped with (`None`: as sent).
    vehicle_time_us: Option<u64>,
    /// `Telemetry` to the surface at most once a this long (us; `None`: all of it), and the
    /// time stamp of the latest one passed.
    telemetry_period_us: Option<u64>,
    last_telemetry_us: Option<u64>,
    /// The latest `Telemetry` passed to the surface: its time stamp (us) and the navigation
    /// state it carried (what a ground station shows of it).
    shown: Option<(u64, NavState)>,
}

impl TetherBridge {
    /// A bridge with nothing in force yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// The surface's bytes: what to write to the App's serial port.
    pub fn from_surface(&mut self, bytes: &[u8]) -> Result<Vec<u8>> {
        let mut out = Vec::with_capacity(bytes.len() + 8);
        for chunk in self.from_surface.push(bytes) {
            let decoded = (!chunk.is_empty())
                .then(|| decode_frame::<Command>(&chunk))
                .flatten();
            match decoded {
                Some(Decoded::Frame { seq, session, msg }) => {
                    out.extend(self.surface_frame(seq, session, &msg)?);
                }
                _ => {
                    out.extend_from_slice(&chunk);
                    out.push(0);
                }
            }
        }
        Ok(out)
    }

    /// Stamp the surface's heartbeats with the vehicle's time `t_us` (a lock-step image:
    /// its clock is the time stamps it takes).
    pub fn set_vehicle_time(&mut self, t_us: u64) {
        self.vehicle_time_us = Some(t_us);
    }

    /// Pass the App's `Telemetry` to the surface at most once every `period_us` of its time
    /// stamps (a lock-step image answers every control step with one).
    pub fn set_telemetry_period(&mut self, period_us: u64) {
        self.telemetry_period_us = Some(period_us);
    }

    /// The latest `Telemetry` passed to the surface: its time stamp (us) and the navigation
    /// state it carried.
    pub fn shown(&self) -> Option<(u64, NavState)> {
        self.shown
    }

    /// Whether the bridge's own session is being opened (its answer not read yet).
    pub fn opening(&self) -> bool {
        self.opening.is_some()
    }

    /// The App's number of a surface's `OpenSession` whose answer has not been read: until
    /// it is, a vehicle input framed now would go in the session it replaces.
    pub fn surface_opening(&self) -> Option<u16> {
        self.surface_opening.map(|(n, _)| n)
    }

    /// One vehicle input framed in the bridge's session, and its number there (its answer,
    /// as every answer to a vehicle input, is not sent to the surface); `None` while no
    /// session is in force or one is being opened ([`own_inputs`](Self::own_inputs) holds
    /// inputs meanwhile).
    pub fn own_frame(&mut self, cmd: &Command) -> Result<Option<(u16, Vec<u8>)>> {
        if self.opening.is_some() || self.app_session == 0 {
            return Ok(None);
        }
        let n = self.take_seq();
        let mut out = vec![0];
        out.extend(frame(self.app_session, n, cmd)?);
        Ok(Some((n, out)))
    }

    /// One good frame of the surface, renumbered for the App.
    fn surface_frame(&mut self, seq: u16, session: u32, msg: &Command) -> Result<Vec<u8>> {
        let restamped;
        let msg = match (msg, self.vehicle_time_us) {
            (Command::Heartbeat { .. }, Some(t_us)) => {
                restamped = Command::Heartbeat { t_us };
                &restamped
            }
            _ => msg,
        };
        let in_force = session != 0 && session == self.surface_session;
        if let Command::OpenSession { .. } = msg {
            // The surface in force renewing its session frames it in that session with a
            // rising number: a renewal of the App's session too (the pilot's input stays).
            // Any other is a new surface's, passed in the session it names.
            let renewal = in_force && self.surface_last.is_none_or(|l| seq > l);
            // The App numbers the new session from this frame's number on.
            self.surface_last = Some(seq);
            self.opening = None;
            let n = self.take_seq();
            self.surface_opening = Some((n, seq));
            return frame(if renewal { self.app_session } else { session }, n, msg);
        }
        if in_force && self.surface_last.is_some_and(|l| seq <= l) {
            self.replays.push_back(seq);
            if self.replays.len() > MAX_PENDING {
                self.replays.pop_front();
            }
            return frame(self.app_session, 0, msg);
        }
        let app_session = if in_force {
            self.surface_last = Some(seq);
            self.app_session
        } else {
            session
        };
        let n = self.take_seq();
        self.to_surface.insert(n, seq);
        // Answers come within the pass: the oldest entries are of unanswered frames.
        while self.to_surface.len() > MAX_PENDING {
            self.to_surface.pop_first();
        }
        frame(app_session, n, msg)
    }

    fn take_seq(&mut self) -> u16 {
        let n = self.next_seq.max(1);
        self.next_seq = n.saturating_add(1);
        n
    }

    /// The vehicle's inputs for the App. Opens the bridge's own session first when none is
    /// in force or the numbers are near their end; until its answer has been read
    /// ([`from_app`](Self::from_app)) the inputs are held, and [`held`](Self::held) sends
    /// them.
    pub fn own_inputs(&mut self, cmds: &[Command]) -> Result<Vec<u8>> {
        let mut out = Vec::new();
        let renew = self.next_seq >= RENEW_AT;
        let none = self.app_session == 0 && !cmds.is_empty();
        if (renew || none) && self.opening.is_none() {
            let nonce: u32 = rand::random();
            self.opening = Some(nonce);
            // A renewal is framed in the App's session with a rising number, so the App
            // keeps the surface's pilot input; the new session's numbers start from 1.
            let n = self.take_seq();
            out.push(0);
            out.extend(frame(self.app_session, n, &Command::OpenSession { nonce })?);
            if renew {
                self.next_seq = 1;
                self.to_surface.clear();
                self.replays.clear();
            }
        }
        self.held.extend_from_slice(cmds);
        if self.held.len() > MAX_HELD {
            let extra = self.held.len() - MAX_HELD;
            self.held.drain(..extra);
        }
        out.extend(self.held()?);
        Ok(out)
    }

    /// The inputs held while the bridge's session opened, once it is open.
    pub fn held(&mut self) -> Result<Vec<u8>> {
        let mut out = Vec::new();
        if self.opening.is_some() || self.app_session == 0 {
            return Ok(out);
        }
        for c in std::mem::take(&mut self.held) {
            let n = self.take_seq();
            out.push(0);
            out.extend(frame(self.app_session, n, &c)?);
        }
        Ok(out)
    }

    /// The App's bytes: what to send the surface.
    pub fn from_app(&mut self, bytes: &[u8]) -> Result<Vec<u8>> {
        let mut out = Vec::with_capacity(bytes.len());
        for chunk in self.from_app.push(bytes) {
            let decoded = (!chunk.is_empty())
                .then(|| decode_frame::<Reply>(&chunk))
                .flatten();
            let Some(Decoded::Frame { seq, session, msg }) = decoded else {
                out.extend_from_slice(&chunk);
                out.push(0);
                continue;
            };
            match self.app_reply(msg) {
                Answer::Pass => {
                    out.extend_from_slice(&chunk);
                    out.push(0);
                }
                Answer::Drop => {}
                Answer::Renumbered(r) => out.extend(frame(session, seq, &r)?),
            }
        }
        Ok(out)
    }

    /// The surface's number of an answer to the App's number `s` (0: a replay); `None` for
    /// an answer to the vehicle's own input.
    fn surface_seq(&mut self, s: u16) -> Option<u16> {
        if s == 0 {
            return self.replays.pop_front();
        }
        self.to_surface.remove(&s)
    }

    fn app_reply(&mut self, msg: Reply) -> Answer {
        match msg {
            Reply::Session { nonce, session } => {
                if self.opening == Some(nonce) {
                    // The bridge's own: the surface keeps its number for the session.
                    self.opening = None;
                    self.app_session = session;
                    return Answer::Drop;
                }
                self.app_session = session;
                self.surface_session = session;
                self.surface_opening = None;
                Answer::Pass
            }
            Reply::Ack { seq } => match self.surface_seq(seq) {
                Some(s) => Answer::Renumbered(Reply::Ack { seq: s }),
                None => Answer::Drop,
            },
            Reply::Nack { seq, reason } if self.surface_opening().is_some_and(|n| n == seq) => {
                // The surface's session refused, under the surface's number.
                let surface = self.surface_opening.map_or(0, |(_, s)| s);
                self.surface_opening = None;
                Answer::Renumbered(Reply::Nack {
                    seq: surface,
                    reason,
                })
            }
            Reply::Nack { seq, reason } => match self.surface_seq(seq) {
                Some(s) => Answer::Renumbered(Reply::Nack { seq: s, reason }),
                None => {
                    self.own_refused += 1;
                    self.own_refused_why = Some(reason);
                    Answer::Drop
                }
            },
            Reply::Status(mut st) => match self.surface_seq(st.heartbeat_seq) {
                Some(s) => {
                    st.heartbeat_seq = s;
                    Answer::Renumbered(Reply::Status(st))
                }
                None => Answer::Drop,
            },
            Reply::Telemetry(t) => match self.telemetry_period_us {
                Some(p) if self.last_telemetry_us.is_some_and(|l| t.t_us < l + p) => Answer::Drop,
                _ => {
                    self.last_telemetry_us = Some(t.t_us);
                    self.shown = Some((t.t_us, t.nav));
                    Answer::Pass
                }
            },
            _ => Answer::Pass,
        }
    }
}

/// What the bridge does with one of the App's frames.
enum Answer {
    Pass,
    Drop,
    Renumbered(Reply),
}
