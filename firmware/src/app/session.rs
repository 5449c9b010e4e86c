//! The session gate and the clock gate: which frames belong to the session in force, and
//! which surface time stamps may move the vehicle's idea of time.

use super::stamp::Stamp;
use super::{App, Monotonic};
use crate::protocol::{Command, NackReason, Reply};
use crate::sensors::Sensors;
use embedded_hal::pwm::SetDutyCycle;
use embedded_io::{Read, ReadReady, Write, WriteReady};

/// Session numbers are 14 bits (1..=16383).
pub(super) const SESSION_MASK: u32 = 0x3FFF;

impl<P, S, C, N> App<P, S, C, N>
where
    P: SetDutyCycle,
    S: Read + ReadReady + Write + WriteReady,
    C: Monotonic,
    N: Sensors,
{
    /// The session's gate: `OpenSession` opens a new one at any time; any other
    /// frame must carry the session in force and a sequence number above the last one
    /// taken in it (the surface opens a new session before its numbers wrap), or it is
    /// refused and counted, and changes nothing.
    ///
    /// An `OpenSession` framed in the session in force with a number above the last one
    /// taken renews that session: only the surface in force can frame it, so what its pilot
    /// commands keeps acting. Any other `OpenSession` is a new surface (or a restarted one):
    /// nothing its predecessor's pilot commanded acts in the new session
    /// ([`Autopilot::new_session`](crate::autopilot::Autopilot::new_session)).
    pub(super) fn on_frame(&mut self, seq: u16, session: u32, cmd: &Command) {
        if let Command::OpenSession { nonce } = *cmd {
            let renewal = session != 0 && session == self.session && seq > self.last_seq;
            return self.open_session(seq, nonce, renewal);
        }
        if session == 0 || session != self.session {
            self.link.no_session = self.link.no_session.wrapping_add(1);
            return self.nack(seq, NackReason::NoSession);
        }
        if seq <= self.last_seq {
            self.link.replayed = self.link.replayed.wrapping_add(1);
            return self.nack(seq, NackReason::Replayed);
        }
        self.last_seq = seq;
        self.on_command(seq, cmd);
    }

    /// Open a session: a number never 0 and not the previous one's, mixed from the surface's
    /// nonce and a count of the sessions (so a recording of an earlier session does not
    /// match a later one); the `OpenSession`'s own number starts the sequence of a new
    /// surface's session, a renewal's numbers start again from 1.
    pub(super) fn open_session(&mut self, seq: u16, nonce: u32, renewal: bool) {
        self.sessions_opened = self.sessions_opened.wrapping_add(1);
        // 14 bits: a two-byte varint in every envelope (a full u32 is five, and each byte
        // costs every frame's decoding).
        let mut id = (nonce ^ self.sessions_opened.wrapping_mul(0x9E37_79B9)) & SESSION_MASK;
        if id == 0 || id == self.session {
            id = (id.wrapping_add(0x2F1B) & SESSION_MASK) | 1;
        }
        self.session = id;
        self.last_seq = if renewal { 0 } else { seq };
        self.stamps = [Stamp::default(); 3];
        if renewal {
            self.autopilot.session_renewed();
        } else {
            self.autopilot.new_session();
        }
        self.send(&Reply::Session { nonce, session: id });
    }

    /// The surface stamp of a command and which [`Stamp`] slot checks it in fixed-rate mode.
    pub(super) fn stamp_of(cmd: &Command) -> Option<(u64, Option<usize>)> {
        match cmd {
            Command::Heartbeat { t_us } | Command::Step { t_us } => Some((*t_us, None)),
            Command::Nav(n) => Some((n.t_us, Some(0))),
            Command::Imu(s) => Some((s.t_us, Some(1))),
            Command::Pressure { t_us, .. } => Some((*t_us, Some(2))),
            _ => None,
        }
    }
}
