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
//! App counts and answers it). Answers to the vehicle's own inputs are not sent to the
//! surface. The bridge opens a session of its own at boot (before a surface opens one) and
//! a new one under the surface's before its own numbers would wrap; the surface keeps the
//! session number it was given.

use anyhow::{anyhow, Result};
use firmware::protocol::{
    decode_frame, encode, Command, Decoded, NackReason, Reply, MAX_FRAME_LEN,
};
use std::collections::{HashMap, HashSet, VecDeque};

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
    /// The App's number of the next frame the bridge sends.
    next_seq: u16,
    /// The last surface number taken in the surface's session.
    surface_last: Option<u16>,
    /// App numbers of the surface's frames -> the surface's numbers.
    to_surface: HashMap<u16, u16>,
    /// Surface numbers sent with number 0 (a replay), in order.
    replays: VecDeque<u16>,
    /// App numbers of the vehicle's own inputs (their answers stay here).
    own: HashSet<u16>,
    /// The nonce of a session the bridge asked for.
    opening: Option<u32>,
    /// Vehicle inputs waiting for the bridge's session to open.
    held: Vec<Command>,
    /// Vehicle inputs refused by the App.
    pub own_refused: u64,
    /// Why the App refused the latest vehicle input it refused.
    pub own_refused_why: Option<NackReason>,
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

    /// One good frame of the surface, renumbered for the App.
    fn surface_frame(&mut self, seq: u16, session: u32, msg: &Command) -> Result<Vec<u8>> {
        if let Command::OpenSession { .. } = msg {
            // The App opens a new session numbered from this frame's.
            self.surface_last = Some(seq);
            self.opening = None;
            self.next_seq = 2;
            self.remember(1, seq);
            return frame(0, 1, msg);
        }
        let in_force = session != 0 && session == self.surface_session;
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
        self.remember(n, seq);
        frame(app_session, n, msg)
    }

    fn remember(&mut self, app_seq: u16, surface_seq: u16) {
        if self.to_surface.len() >= MAX_PENDING {
            self.to_surface.clear();
        }
        self.to_surface.insert(app_seq, surface_seq);
    }

    fn take_seq(&mut self) -> u16 {
        let n = self.next_seq.max(1);
        self.next_seq = n.wrapping_add(1);
        n
    }

    /// A vehicle input for the App; opens the bridge's own session first when none is in
    /// force or its numbers are near their end. While a session the bridge asked for is being
    /// opened, inputs are held and sent once it is open.
    pub fn own_input(&mut self, cmd: &Command) -> Result<Vec<u8>> {
        let mut out = Vec::new();
        let renew = self.next_seq >= RENEW_AT;
        if (self.app_session == 0 || renew) && self.opening.is_none() {
            let nonce: u32 = rand::random();
            self.opening = Some(nonce);
            self.next_seq = 2;
            out.push(0);
            out.extend(frame(0, 1, &Command::OpenSession { nonce })?);
        }
        if self.opening.is_some() {
            if self.held.len() < MAX_HELD {
                self.held.push(*cmd);
            }
            return Ok(out);
        }
        for c in std::mem::take(&mut self.held).iter().chain([cmd]) {
            let n = self.take_seq();
            if self.own.len() >= MAX_PENDING {
                self.own.clear();
            }
            self.own.insert(n);
            out.push(0);
            out.extend(frame(self.app_session, n, c)?);
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

    fn app_reply(&mut self, msg: Reply) -> Answer {
        let back = |b: &mut Self, s: u16| -> Option<u16> {
            if s == 0 {
                return b.replays.pop_front();
            }
            b.to_surface.remove(&s)
        };
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
                Answer::Pass
            }
            Reply::Ack { seq } | Reply::Nack { seq, .. } if self.own.remove(&seq) => {
                if let Reply::Nack { reason, .. } = msg {
                    self.own_refused += 1;
                    self.own_refused_why = Some(reason);
                }
                Answer::Drop
            }
            Reply::Ack { seq } => match back(self, seq) {
                Some(s) => Answer::Renumbered(Reply::Ack { seq: s }),
                None => Answer::Pass,
            },
            Reply::Nack { seq, reason } => match back(self, seq) {
                Some(s) => Answer::Renumbered(Reply::Nack { seq: s, reason }),
                None => Answer::Pass,
            },
            Reply::Status(mut st) => match back(self, st.heartbeat_seq) {
                Some(s) => {
                    st.heartbeat_seq = s;
                    Answer::Renumbered(Reply::Status(st))
                }
                None => Answer::Pass,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tether::in_process::InProcessFirmware;
    use firmware::protocol::{Board, NavSample};
    use firmware::Config;

    /// The surface's end: its frames and what it decodes.
    struct Surface {
        session: u32,
        seq: u16,
    }

    impl Surface {
        fn frame(&mut self, cmd: &Command) -> (u16, Vec<u8>) {
            let seq = self.seq;
            self.seq += 1;
            let mut buf = [0u8; MAX_FRAME_LEN];
            let f = encode(self.session, seq, cmd, &mut buf).unwrap().to_vec();
            (seq, f)
        }
    }

    fn replies(bytes: &[u8]) -> Vec<(u16, Reply)> {
        let mut dec = firmware::protocol::FrameDecoder::<Reply>::new();
        bytes
            .iter()
            .filter_map(|&b| match dec.push(b) {
                Some(Decoded::Frame { seq, msg, .. }) => Some((seq, msg)),
                _ => None,
            })
            .collect()
    }

    /// The App, the bridge, one exchange: the surface's bytes and the vehicle's inputs in,
    /// what the surface receives out.
    fn exchange(
        app: &mut InProcessFirmware,
        b: &mut TetherBridge,
        surface: &[u8],
        own: &[Command],
    ) -> Vec<(u16, Reply)> {
        let mut rx = Vec::new();
        for c in own {
            rx.extend(b.own_input(c).unwrap());
        }
        rx.extend(b.from_surface(surface).unwrap());
        let tx = app.pass(&rx);
        replies(&b.from_app(&tx).unwrap())
    }

    fn nav(t_us: u64) -> Command {
        Command::Nav(NavSample {
            t_us,
            state: Default::default(),
        })
    }

    #[test]
    fn the_surface_keeps_its_numbers_and_the_apps_gate() {
        let mut app = InProcessFirmware::with_config(Config::fixed_rate(Board::Host)).unwrap();
        let mut b = TetherBridge::new();
        // The boot's Hello passes; the vehicle's own session opens before any surface.
        let r = exchange(&mut app, &mut b, &[], &[nav(0)]);
        assert!(matches!(r.first(), Some((_, Reply::Hello { .. }))), "{r:?}");
        let r = exchange(&mut app, &mut b, &[], &[nav(1_000)]);
        assert!(r.is_empty(), "the vehicle's own answers stay inside: {r:?}");
        // The surface opens its session and is answered with its nonce.
        let mut s = Surface { session: 0, seq: 0 };
        let (_, open) = s.frame(&Command::OpenSession { nonce: 77 });
        let r = exchange(&mut app, &mut b, &open, &[nav(2_000)]);
        let Some(&(_, Reply::Session { nonce: 77, session })) = r.first() else {
            panic!("no session: {r:?}");
        };
        s.session = session;
        // Heartbeat and a command, with vehicle inputs between: the surface's numbers back.
        for k in 0..20u64 {
            let (hb, f1) = s.frame(&Command::Heartbeat { t_us: k });
            let (arm, f2) = s.frame(&Command::SetMode(firmware::protocol::Mode::Idle));
            let bytes = [f1, f2].concat();
            let t = 10_000 * (k + 1);
            let r = exchange(&mut app, &mut b, &bytes, &[nav(t), nav(t + 5_000)]);
            assert!(
                r.iter()
                    .any(|(_, m)| matches!(m, Reply::Status(st) if st.heartbeat_seq == hb)),
                "{r:?}"
            );
            assert!(r.contains(&(r[1].0, Reply::Ack { seq: arm })), "{r:?}");
        }
        // A replay is refused by the App, under the surface's number.
        let (old, f) = {
            let seq = s.seq - 1;
            let mut buf = [0u8; MAX_FRAME_LEN];
            let f = encode(s.session, seq, &Command::Disarm, &mut buf)
                .unwrap()
                .to_vec();
            (seq, f)
        };
        let r = exchange(&mut app, &mut b, &f, &[]);
        assert_eq!(
            r.iter().map(|(_, m)| *m).collect::<Vec<_>>(),
            vec![Reply::Nack {
                seq: old,
                reason: NackReason::Replayed
            }]
        );
        // Another session's frame: refused NoSession.
        let mut stranger = Surface {
            session: session ^ 1,
            seq: 500,
        };
        let (n, f) = stranger.frame(&Command::Arm);
        let r = exchange(&mut app, &mut b, &f, &[]);
        assert_eq!(
            r.iter().map(|(_, m)| *m).collect::<Vec<_>>(),
            vec![Reply::Nack {
                seq: n,
                reason: NackReason::NoSession
            }]
        );
        assert_eq!((b.own_refused, b.own_refused_why), (0, None));
    }

    #[test]
    fn a_renewed_session_is_not_seen_by_the_surface() {
        let mut app = InProcessFirmware::with_config(Config::fixed_rate(Board::Host)).unwrap();
        let mut b = TetherBridge::new();
        let mut s = Surface { session: 0, seq: 0 };
        let (_, open) = s.frame(&Command::OpenSession { nonce: 5 });
        let r = exchange(&mut app, &mut b, &open, &[]);
        let Some(&(_, Reply::Session { session, .. })) =
            r.iter().find(|(_, m)| matches!(m, Reply::Session { .. }))
        else {
            panic!("no session: {r:?}");
        };
        s.session = session;
        // Far more vehicle inputs than one session's numbers.
        for k in 0..70_000u64 {
            exchange(&mut app, &mut b, &[], &[nav(k * 10)]);
        }
        let (hb, f) = s.frame(&Command::Heartbeat { t_us: 1 });
        let r = exchange(&mut app, &mut b, &f, &[]);
        assert!(
            r.iter()
                .any(|(_, m)| matches!(m, Reply::Status(st) if st.heartbeat_seq == hb)),
            "{r:?}"
        );
        assert_eq!((b.own_refused, b.own_refused_why), (0, None));
    }
}
