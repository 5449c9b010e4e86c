//! The ground-station side of the topside: its MAVLink connections, who is on them, and the
//! `.tlog`. Written on the standard library's sockets (not the `mavlink` crate's
//! connections) so that no input ends the topside and every station has an identity:
//!
//! - `udpin:HOST:PORT` listens; every address that sends to it is a station of its own (at
//!   most [`MAX_UDP_PEERS`], the longest silent replaced), and each gets everything.
//! - `udpout:HOST:PORT` sends to one station (a ground station listening, QGroundControl's
//!   default); whatever arrives on its socket is that station's.
//! - `tcpin:HOST:PORT` listens without waiting: every accepted connection is a new station, a
//!   disconnected one is dropped and a reconnect accepted at any time.
//! - `tcpout:HOST:PORT` connects, and after a disconnect tries again every
//!   [`TCP_RETRY`].
//!
//! An empty datagram, garbage, a cut or corrupted frame, a message of another dialect: logged
//! (at most [`MAX_NOTES`] lines, then only counted), counted as malformed and dropped. Each
//! datagram is parsed on its own (a cut frame never glues to the next datagram); a TCP
//! stream keeps an incomplete frame for the next read.
//!
//! Frames are taken from the bytes in `frames` (with the mission messages' `mission_type`).

use super::frames::{split_text, take_all_frames, MISSION_TYPE_AT};
pub use super::frames::{take_frames, UnknownItem};
use anyhow::{anyhow, bail, Context, Result};
use mavlink::dialects::ardupilotmega::{
    MavCmd, MavMessage, MavResult, MavSeverity, COMMAND_ACK_DATA, STATUSTEXT_DATA,
};
use mavlink::MavHeader;
use std::fs::File;
use std::io::{BufWriter, ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream, ToSocketAddrs, UdpSocket};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// A ground station: a number given when it is first heard (never reused).
pub type StationId = usize;

/// Most MAVLink datagrams taken from one UDP connection in one control period (10,000 a
/// second at 50 Hz); the rest waits in the socket, where a flood's excess is dropped by the OS.
pub const POLL_LIMIT: usize = 200;
/// Most bytes read from one TCP station in one control period (about 230 frames).
pub const TCP_READ_LIMIT: usize = 64 * 1024;
/// Bytes queued to a TCP station that does not read before it is disconnected.
pub const TCP_OUTBOX_LIMIT: usize = 1024 * 1024;
/// Most stations on one `udpin` connection.
pub const MAX_UDP_PEERS: usize = 16;
/// A `tcpout` connection that failed or closed is tried again after this long.
pub const TCP_RETRY: Duration = Duration::from_secs(2);
/// Lines of notes (malformed input, connections) printed before they are only counted.
pub const MAX_NOTES: u64 = 200;

/// Counters of the MAVLink side.
#[derive(Debug, Clone, Copy, Default)]
pub struct GcsStats {
    /// Messages received and understood.
    pub handled: u64,
    /// Messages received that the topside does not act on (ignored, counted).
    pub ignored: u64,
    /// Inputs that failed to parse: empty datagrams, garbage runs, cut or corrupted frames.
    pub malformed: u64,
    /// Messages sent.
    pub sent: u64,
    /// Ground-station connections closed (TCP disconnects, write failures).
    pub disconnects: u64,
    /// Messages addressed to another system or component (ignored).
    pub not_ours: u64,
}

/// A message from a station: its header, the message and its `mission_type` (0 for
/// messages without one).
pub type Received = (StationId, MavHeader, MavMessage, u8);

struct TcpPeer {
    stream: TcpStream,
    inbox: Vec<u8>,
    outbox: Vec<u8>,
    station: StationId,
    closed: bool,
}

enum Conn {
    /// `udpin` (`fixed` none) or `udpout` (`fixed` the destination and its station).
    Udp {
        socket: UdpSocket,
        fixed: Option<(SocketAddr, StationId)>,
        peers: Vec<(SocketAddr, StationId, Instant)>,
    },
    TcpIn {
        listener: TcpListener,
        peers: Vec<TcpPeer>,
    },
    TcpOut {
        address: SocketAddr,
        peer: Option<TcpPeer>,
        next_try: Instant,
    },
}

impl Conn {
    /// Send `frame` to this connection's stations that `to` selects; how many it reached.
    fn send(&mut self, frame: &[u8], to: impl Fn(StationId) -> bool) -> u64 {
        let mut sent = 0;
        match self {
            Conn::Udp {
                socket,
                fixed,
                peers,
            } => {
                let dests = fixed.iter().copied();
                let learned = peers.iter().map(|&(a, s, _)| (a, s));
                for (addr, s) in dests.chain(learned) {
                    if to(s) && socket.send_to(frame, addr).is_ok() {
                        sent += 1;
                    }
                }
            }
            Conn::TcpIn { peers, .. } => {
                for p in peers.iter_mut().filter(|p| to(p.station)) {
                    p.push(frame);
                    sent += u64::from(!p.closed);
                }
            }
            Conn::TcpOut { peer: Some(p), .. } if to(p.station) => {
                p.push(frame);
                sent += u64::from(!p.closed);
            }
            Conn::TcpOut { .. } => {}
        }
        sent
    }
}

/// The ground stations: connections, stations, the outgoing sequence number, the `.tlog`.
pub struct Gcs {
    conns: Vec<Conn>,
    /// Each station's label (`udp 127.0.0.1:14550`) and when it was last heard.
    stations: Vec<(String, Option<Instant>)>,
    system_id: u8,
    seq: u8,
    /// The `.tlog`: every message sent or received.
    pub tlog: BufWriter<File>,
    /// Counters.
    pub stats: GcsStats,
    notes: u64,
    /// The origin of the local frame on the globe, once a ground station set it.
    pub origin: Option<super::geodesy::GlobalOrigin>,
    /// Mission items received that this dialect cannot parse, to be answered.
    pub unknown_items: Vec<(StationId, MavHeader, UnknownItem)>,
}

fn unix_us() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_micros() as u64)
}

fn resolve(address: &str) -> Result<SocketAddr> {
    address
        .to_socket_addrs()
        .with_context(|| format!("MAVLink address {address:?}"))?
        .next()
        .ok_or_else(|| anyhow!("MAVLink address {address:?}: no such host"))
}

impl TcpPeer {
    fn new(stream: TcpStream, station: StationId) -> Result<Self> {
        stream.set_nonblocking(true)?;
        let _ = stream.set_nodelay(true);
        Ok(Self {
            stream,
            inbox: Vec::new(),
            outbox: Vec::new(),
            station,
            closed: false,
        })
    }

    /// Queue `frame` and write what the socket takes; closed when it fails or does not read.
    fn push(&mut self, frame: &[u8]) {
        if self.closed {
            return;
        }
        self.outbox.extend_from_slice(frame);
        while !self.outbox.is_empty() {
            match self.stream.write(&self.outbox) {
                Ok(0) => {
                    self.closed = true;
                    return;
                }
                Ok(n) => {
                    self.outbox.drain(..n);
                }
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                Err(_) => {
                    self.closed = true;
                    return;
                }
            }
        }
        if self.outbox.len() > TCP_OUTBOX_LIMIT {
            self.closed = true;
        }
    }

    /// What arrived, up to [`TCP_READ_LIMIT`] bytes; marks the peer closed at end of stream.
    fn read(&mut self) {
        let mut buf = [0u8; 4096];
        let mut total = 0;
        while total < TCP_READ_LIMIT && !self.closed {
            match self.stream.read(&mut buf) {
                Ok(0) => self.closed = true,
                Ok(n) => {
                    self.inbox.extend_from_slice(&buf[..n]);
                    total += n;
                }
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                Err(_) => self.closed = true,
            }
        }
    }
}

impl Gcs {
    /// Open every `--mavlink` address (none waits for a ground station); `tlog` is the open
    /// `.tlog`.
    pub fn open(addresses: &[String], system_id: u8, tlog: File) -> Result<Self> {
        let mut g = Self {
            conns: Vec::new(),
            stations: Vec::new(),
            system_id,
            seq: 0,
            tlog: BufWriter::new(tlog),
            stats: GcsStats::default(),
            notes: 0,
            origin: None,
            unknown_items: Vec::new(),
        };
        for address in addresses {
            let (kind, host) = address.split_once(':').ok_or_else(|| {
                anyhow!("MAVLink address {address:?}: udpin:, udpout:, tcpin: or tcpout:HOST:PORT")
            })?;
            let conn = match kind {
                "udpin" | "udp" => {
                    let socket = UdpSocket::bind(resolve(host)?)
                        .with_context(|| format!("MAVLink address {address:?}"))?;
                    socket.set_nonblocking(true)?;
                    Conn::Udp {
                        socket,
                        fixed: None,
                        peers: Vec::new(),
                    }
                }
                "udpout" => {
                    let dest = resolve(host)?;
                    let any: SocketAddr = if dest.is_ipv4() {
                        ([0, 0, 0, 0], 0).into()
                    } else {
                        ([0u16; 8], 0).into()
                    };
                    let socket = UdpSocket::bind(any)?;
                    socket.set_nonblocking(true)?;
                    let station = g.new_station(format!("udp {dest}"));
                    Conn::Udp {
                        socket,
                        fixed: Some((dest, station)),
                        peers: Vec::new(),
                    }
                }
                "tcpin" => {
                    let listener = TcpListener::bind(resolve(host)?)
                        .with_context(|| format!("MAVLink address {address:?}"))?;
                    listener.set_nonblocking(true)?;
                    Conn::TcpIn {
                        listener,
                        peers: Vec::new(),
                    }
                }
                "tcpout" => Conn::TcpOut {
                    address: resolve(host)?,
                    peer: None,
                    next_try: Instant::now(),
                },
                other => bail!(
                    "MAVLink address {address:?}: {other:?} is not udpin, udpout, tcpin or tcpout"
                ),
            };
            g.conns.push(conn);
        }
        Ok(g)
    }

    fn new_station(&mut self, label: String) -> StationId {
        self.stations.push((label, None));
        self.stations.len() - 1
    }

    /// A station's label, as notes and status texts name it.
    pub fn label(&self, station: StationId) -> String {
        self.stations
            .get(station)
            .map_or_else(|| format!("station {station}"), |s| s.0.clone())
    }

    /// How long since `station` was last heard (`None`: never).
    pub fn silent_for(&self, station: StationId) -> Option<Duration> {
        self.stations
            .get(station)
            .and_then(|s| s.1)
            .map(|t| t.elapsed())
    }

    /// Our MAVLink system id.
    pub fn system_id(&self) -> u8 {
        self.system_id
    }

    /// A line on stderr, the first [`MAX_NOTES`] of them.
    pub fn note(&mut self, text: &str) {
        self.notes += 1;
        if self.notes <= MAX_NOTES {
            eprintln!("topside: {text}");
        } else if self.notes == MAX_NOTES + 1 {
            eprintln!("topside: further notes only counted (see the summary at the end)");
        }
    }

    fn log(&mut self, header: MavHeader, msg: &MavMessage) -> Result<()> {
        let mut frame = Vec::with_capacity(300);
        mavlink::write_v2_msg(&mut frame, header, msg).map_err(|e| anyhow!("tlog: {e:?}"))?;
        self.tlog.write_all(&unix_us().to_be_bytes())?;
        self.tlog.write_all(&frame)?;
        Ok(())
    }

    /// `msg` as a MAVLink 2 frame with the next sequence number, logged.
    fn frame(&mut self, msg: &MavMessage) -> Result<Vec<u8>> {
        let header = MavHeader {
            system_id: u32::from(self.system_id),
            component_id: 1,
            sequence: self.seq,
        };
        self.seq = self.seq.wrapping_add(1);
        self.log(header, msg)?;
        let mut frame = Vec::with_capacity(300);
        mavlink::write_v2_msg(&mut frame, header, msg).map_err(|e| anyhow!("MAVLink: {e:?}"))?;
        Ok(frame)
    }

    /// To every station. A station that is not there (udpout before it listens) is not an
    /// error; a TCP station whose socket fails is disconnected.
    pub fn send(&mut self, msg: MavMessage) -> Result<()> {
        self.send_where(msg, None)
    }

    /// To the stations `to` takes (the streams, each station at its own rate).
    pub fn send_filtered(&mut self, msg: MavMessage, to: impl Fn(StationId) -> bool) -> Result<()> {
        let frame = self.frame(&msg)?;
        let sent: u64 = self.conns.iter_mut().map(|c| c.send(&frame, &to)).sum();
        self.stats.sent += sent;
        Ok(())
    }

    /// To one station only (the answers of a protocol exchange: acknowledgements, mission
    /// requests, refusals of its commands).
    pub fn send_to(&mut self, station: StationId, msg: MavMessage) -> Result<()> {
        self.send_where(msg, Some(station))
    }

    /// To one station, a mission message with its `mission_type` (`MISSION_ACK`,
    /// `MISSION_COUNT`, `MISSION_REQUEST_INT`): the extension byte appended to the payload
    /// and the frame's length and checksum made again (the crate's CRC).
    pub fn send_typed(
        &mut self,
        station: StationId,
        msg: MavMessage,
        mission_type: u8,
    ) -> Result<()> {
        use mavlink::Message;
        let id = msg.message_id();
        let Some(&(_, at)) = MISSION_TYPE_AT.iter().find(|(m, _)| *m == id) else {
            return self.send_to(station, msg);
        };
        if mission_type == 0 {
            return self.send_to(station, msg);
        }
        let frame = self.frame(&msg)?;
        // MAVLink 2: magic, 9 header bytes (len at 1), payload, 2 CRC.
        let len = usize::from(*frame.get(1).ok_or_else(|| anyhow!("empty frame"))?);
        let mut payload = frame.get(10..10 + len).unwrap_or_default().to_vec();
        payload.resize(at, 0);
        payload.push(mission_type);
        let mut out = frame.get(..10).unwrap_or_default().to_vec();
        if let Some(l) = out.get_mut(1) {
            *l = payload.len() as u8;
        }
        out.extend_from_slice(&payload);
        let crc =
            mavlink::calculate_crc(out.get(1..).unwrap_or_default(), MavMessage::extra_crc(id));
        out.extend_from_slice(&crc.to_le_bytes());
        let to = |s: StationId| s == station;
        let sent: u64 = self.conns.iter_mut().map(|c| c.send(&out, to)).sum();
        self.stats.sent += sent;
        Ok(())
    }

    fn send_where(&mut self, msg: MavMessage, only: Option<StationId>) -> Result<()> {
        let frame = self.frame(&msg)?;
        let to = |s: StationId| only.is_none_or(|o| o == s);
        let sent: u64 = self.conns.iter_mut().map(|c| c.send(&frame, to)).sum();
        self.stats.sent += sent;
        Ok(())
    }

    /// A `STATUSTEXT` to every station; a text longer than the message's 50 characters goes
    /// as several, split between words (this dialect's `STATUSTEXT` has no chunk fields).
    pub fn text(&mut self, severity: MavSeverity, text: &str) -> Result<()> {
        self.text_where(None, severity, text)
    }

    /// A `STATUSTEXT` to one station.
    pub fn text_to(&mut self, station: StationId, severity: MavSeverity, text: &str) -> Result<()> {
        self.text_where(Some(station), severity, text)
    }

    fn text_where(
        &mut self,
        only: Option<StationId>,
        severity: MavSeverity,
        text: &str,
    ) -> Result<()> {
        for line in split_text(text, 50) {
            let msg = MavMessage::STATUSTEXT(STATUSTEXT_DATA {
                severity,
                text: line.as_str().into(),
            });
            self.send_where(msg, only)?;
        }
        Ok(())
    }

    /// A `COMMAND_ACK` to the station that sent the command.
    pub fn ack(&mut self, station: StationId, command: MavCmd, result: MavResult) -> Result<()> {
        self.send_to(
            station,
            MavMessage::COMMAND_ACK(COMMAND_ACK_DATA { command, result }),
        )
    }

    /// Take what `bytes` holds from `station`: its messages logged and returned, malformed
    /// input noted and counted.
    fn take(
        &mut self,
        station: StationId,
        bytes: &mut Vec<u8>,
        stream: bool,
        out: &mut Vec<Received>,
    ) -> Result<()> {
        if let Some(s) = self.stations.get_mut(station) {
            s.1 = Some(Instant::now());
        }
        if bytes.is_empty() && !stream {
            self.stats.malformed += 1;
            let what = format!("{}: empty datagram (dropped)", self.label(station));
            self.note(&what);
            return Ok(());
        }
        let (msgs, items, bad) = take_all_frames(bytes, stream);
        if bad > 0 {
            self.stats.malformed += bad;
            let what = format!(
                "{}: {bad} malformed input(s) dropped (garbage, a cut or corrupted frame, an unknown message)",
                self.label(station)
            );
            self.note(&what);
        }
        for (header, msg, mission_type) in msgs {
            self.log(header, &msg)?;
            out.push((station, header, msg, mission_type));
        }
        self.unknown_items
            .extend(items.into_iter().map(|(h, item)| (station, h, item)));
        Ok(())
    }

    /// What has arrived from every station, without waiting: at most [`POLL_LIMIT`]
    /// datagrams of a UDP connection and [`TCP_READ_LIMIT`] bytes of a TCP station each
    /// control period, so that one station flooding (a `MANUAL_CONTROL` storm) neither stalls
    /// the tether loop nor crowds out another. No input is an error: what cannot be read is
    /// noted, counted and dropped; a closed TCP station is dropped and a new one accepted.
    pub fn poll(&mut self) -> Result<Vec<Received>> {
        let mut out = Vec::new();
        let mut conns = std::mem::take(&mut self.conns);
        for conn in &mut conns {
            match conn {
                Conn::Udp {
                    socket,
                    fixed,
                    peers,
                } => {
                    let mut buf = vec![0u8; 65_536];
                    for _ in 0..POLL_LIMIT {
                        let (n, from) = match socket.recv_from(&mut buf) {
                            Ok(r) => r,
                            Err(e) => {
                                if !matches!(
                                    e.kind(),
                                    ErrorKind::WouldBlock
                                        | ErrorKind::TimedOut
                                        | ErrorKind::Interrupted
                                        // udpout to a port nobody listens on yet.
                                        | ErrorKind::ConnectionRefused
                                ) {
                                    self.note(&format!("UDP receive: {e} (continuing)"));
                                }
                                break;
                            }
                        };
                        let station = match fixed {
                            Some((_, s)) => *s,
                            None => match peers.iter_mut().find(|p| p.0 == from) {
                                Some(p) => {
                                    p.2 = Instant::now();
                                    p.1
                                }
                                None => {
                                    let s = self.new_station(format!("udp {from}"));
                                    if peers.len() >= MAX_UDP_PEERS {
                                        peers.sort_by_key(|p| std::cmp::Reverse(p.2));
                                        peers.truncate(MAX_UDP_PEERS - 1);
                                    }
                                    peers.push((from, s, Instant::now()));
                                    self.note(&format!("station {s}: udp {from}"));
                                    s
                                }
                            },
                        };
                        let mut bytes = buf[..n].to_vec();
                        self.take(station, &mut bytes, false, &mut out)?;
                    }
                }
                Conn::TcpIn { listener, peers } => {
                    // A few new connections a period; more wait in the backlog.
                    for _ in 0..4 {
                        match listener.accept() {
                            Ok((stream, from)) => {
                                let s = self.new_station(format!("tcp {from}"));
                                match TcpPeer::new(stream, s) {
                                    Ok(p) => {
                                        peers.push(p);
                                        self.note(&format!("station {s}: tcp {from} connected"));
                                    }
                                    Err(e) => self.note(&format!("tcp {from}: {e} (dropped)")),
                                }
                            }
                            Err(e) => {
                                if e.kind() != ErrorKind::WouldBlock {
                                    self.note(&format!("TCP accept: {e} (continuing)"));
                                }
                                break;
                            }
                        }
                    }
                    for p in peers.iter_mut() {
                        p.read();
                        let mut inbox = std::mem::take(&mut p.inbox);
                        self.take(p.station, &mut inbox, true, &mut out)?;
                        p.inbox = inbox;
                    }
                }
                Conn::TcpOut {
                    address,
                    peer,
                    next_try,
                } => {
                    if peer.is_none() && Instant::now() >= *next_try {
                        *next_try = Instant::now() + TCP_RETRY;
                        match TcpStream::connect_timeout(address, Duration::from_millis(100)) {
                            Ok(stream) => {
                                let s = self.new_station(format!("tcp {address}"));
                                match TcpPeer::new(stream, s) {
                                    Ok(p) => {
                                        *peer = Some(p);
                                        self.note(&format!("station {s}: tcp {address} connected"));
                                    }
                                    Err(e) => self.note(&format!("tcp {address}: {e}")),
                                }
                            }
                            Err(e) => self.note(&format!(
                                "tcp {address}: {e} (trying again in {} s)",
                                TCP_RETRY.as_secs()
                            )),
                        }
                    }
                    if let Some(p) = peer.as_mut() {
                        p.read();
                        let mut inbox = std::mem::take(&mut p.inbox);
                        self.take(p.station, &mut inbox, true, &mut out)?;
                        p.inbox = inbox;
                    }
                }
            }
        }
        self.conns = conns;
        self.drop_closed();
        Ok(out)
    }

    /// Forget the TCP stations whose connection closed (noted and counted).
    fn drop_closed(&mut self) {
        let mut gone = Vec::new();
        for conn in &mut self.conns {
            match conn {
                Conn::TcpIn { peers, .. } => {
                    gone.extend(peers.iter().filter(|p| p.closed).map(|p| p.station));
                    peers.retain(|p| !p.closed);
                }
                Conn::TcpOut { peer, .. } => {
                    if let Some(p) = peer.as_ref().filter(|p| p.closed) {
                        gone.push(p.station);
                        *peer = None;
                    }
                }
                Conn::Udp { .. } => {}
            }
        }
        for s in gone {
            self.stats.disconnects += 1;
            let what = format!("station {s}: {} disconnected", self.label(s));
            self.note(&what);
        }
    }

    /// Write the `.tlog` out; the TCP stations' queued bytes too.
    pub fn flush(&mut self) -> Result<()> {
        self.tlog.flush().context("tlog")?;
        for conn in &mut self.conns {
            match conn {
                Conn::TcpIn { peers, .. } => peers.iter_mut().for_each(|p| p.push(&[])),
                Conn::TcpOut { peer: Some(p), .. } => p.push(&[]),
                _ => {}
            }
        }
        self.drop_closed();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::dialects::ardupilotmega::HEARTBEAT_DATA;

    fn frame(seq: u8) -> Vec<u8> {
        let mut f = Vec::new();
        let h = MavHeader {
            system_id: 255,
            component_id: 190,
            sequence: seq,
        };
        mavlink::write_v2_msg(&mut f, h, &MavMessage::HEARTBEAT(HEARTBEAT_DATA::default()))
            .unwrap();
        f
    }

    #[test]
    fn frames_are_taken_around_garbage_and_cut_frames() {
        let mut bytes = vec![1, 2, 3];
        bytes.extend(frame(1));
        let cut = frame(2);
        bytes.extend(&cut[..5]);
        bytes.extend(frame(3));
        let (msgs, bad) = take_frames(&mut bytes.clone(), false);
        assert_eq!(msgs.len(), 2);
        assert!(bad >= 2, "{bad}");
        // A stream keeps an incomplete frame at the end for the next read.
        let mut stream = frame(4);
        stream.extend(&cut[..7]);
        let (msgs, _) = take_frames(&mut stream, true);
        assert_eq!(msgs.len(), 1);
        assert_eq!(stream, cut[..7]);
        stream.extend(&cut[7..]);
        let (msgs, bad) = take_frames(&mut stream, true);
        assert_eq!((msgs.len(), bad, stream.len()), (1, 0, 0));
        // A corrupted frame is dropped, not taken.
        let mut bad_crc = frame(5);
        let n = bad_crc.len();
        bad_crc[n - 1] ^= 0xFF;
        let (msgs, bad) = take_frames(&mut bad_crc, false);
        assert_eq!((msgs.len(), bad > 0), (0, true));
        let (msgs, bad) = take_frames(&mut Vec::new(), false);
        assert_eq!((msgs.len(), bad), (0, 0));
    }
}
