//! The raw tether log: every byte that crossed the tether, both ways, time-stamped, so a dive
//! can be examined at the frame level (what the vehicle was sent, what it answered, what was
//! corrupted) next to the `.tlog` of the MAVLink side.
//!
//! Format: the line `ROV-TETHER-LOG 1\n`, then records of an 8-byte big-endian UNIX time in
//! microseconds, one direction byte (`>` to the vehicle, `<` from it), a 2-byte big-endian
//! length and the bytes as they were written or read (COBS frames, possibly split between
//! records). [`read`] gives the records back and [`decode`] the frames in them.

use crate::port::Port;
use anyhow::{bail, Context, Result};
use protocol::{Command, Decoded, FrameDecoder, Reply};
use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::path::Path;
use std::time::{SystemTime, UNIX_EPOCH};

/// The first line of a tether log.
pub const MAGIC: &[u8] = b"ROV-TETHER-LOG 1\n";

/// Which way bytes went.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// Surface to vehicle.
    ToVehicle,
    /// Vehicle to surface.
    FromVehicle,
}

/// A port that copies everything written to and read from it into a tether log.
pub struct LoggedPort {
    inner: Box<dyn Port>,
    log: BufWriter<File>,
}

impl LoggedPort {
    /// Log `inner`'s traffic to a new file at `path`.
    pub fn new(inner: Box<dyn Port>, path: &Path) -> Result<Self> {
        if let Some(dir) = path.parent() {
            if !dir.as_os_str().is_empty() {
                std::fs::create_dir_all(dir)?;
            }
        }
        let mut log = BufWriter::new(
            File::create(path).with_context(|| format!("create {}", path.display()))?,
        );
        log.write_all(MAGIC)?;
        Ok(Self { inner, log })
    }

    fn record(&mut self, dir: Direction, bytes: &[u8]) -> std::io::Result<()> {
        let t_us = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.as_micros() as u64);
        for chunk in bytes.chunks(usize::from(u16::MAX)) {
            self.log.write_all(&t_us.to_be_bytes())?;
            self.log.write_all(&[match dir {
                Direction::ToVehicle => b'>',
                Direction::FromVehicle => b'<',
            }])?;
            self.log.write_all(&(chunk.len() as u16).to_be_bytes())?;
            self.log.write_all(chunk)?;
        }
        Ok(())
    }
}

impl Read for LoggedPort {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        if n > 0 {
            self.record(Direction::FromVehicle, &buf[..n])?;
        }
        Ok(n)
    }
}

impl Write for LoggedPort {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.record(Direction::ToVehicle, &buf[..n])?;
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.log.flush()?;
        self.inner.flush()
    }
}

impl Drop for LoggedPort {
    fn drop(&mut self) {
        // Nothing to report to at this point; the log is flushed at every `flush` too.
        let _ = self.log.flush();
    }
}

/// One record: when, which way, the bytes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Record {
    /// UNIX time, microseconds.
    pub t_us: u64,
    /// Which way.
    pub direction: Direction,
    /// The bytes.
    pub bytes: Vec<u8>,
}

/// The records of a tether log (a log cut short ends at its last whole record).
pub fn read(path: &Path) -> Result<Vec<Record>> {
    let data = std::fs::read(path).with_context(|| format!("read {}", path.display()))?;
    let Some(mut rest) = data.strip_prefix(MAGIC) else {
        bail!("{} is not a tether log", path.display());
    };
    let mut out = Vec::new();
    while rest.len() >= 11 {
        let t_us = u64::from_be_bytes(rest[..8].try_into()?);
        let direction = match rest[8] {
            b'>' => Direction::ToVehicle,
            b'<' => Direction::FromVehicle,
            other => bail!("{}: bad direction byte {other:#x}", path.display()),
        };
        let len = usize::from(u16::from_be_bytes([rest[9], rest[10]]));
        let Some(bytes) = rest.get(11..11 + len) else {
            break;
        };
        out.push(Record {
            t_us,
            direction,
            bytes: bytes.to_vec(),
        });
        rest = &rest[11 + len..];
    }
    Ok(out)
}

/// The frames of a tether log, decoded as the two ends did.
#[derive(Debug, Default)]
pub struct Frames {
    /// Commands to the vehicle: time, sequence number, command.
    pub commands: Vec<(u64, u16, Command)>,
    /// Replies from the vehicle: time, sequence number, reply.
    pub replies: Vec<(u64, u16, Reply)>,
    /// Frames that did not decode (either way).
    pub dropped: usize,
}

/// Decode every frame of `records`.
pub fn decode(records: &[Record]) -> Frames {
    let mut to_vehicle = FrameDecoder::<Command>::new();
    let mut from_vehicle = FrameDecoder::<Reply>::new();
    let mut f = Frames::default();
    for r in records {
        for &b in &r.bytes {
            match r.direction {
                Direction::ToVehicle => match to_vehicle.push(b) {
                    Some(Decoded::Frame { seq, msg, .. }) => f.commands.push((r.t_us, seq, msg)),
                    Some(Decoded::Dropped { .. }) => f.dropped += 1,
                    None => {}
                },
                Direction::FromVehicle => match from_vehicle.push(b) {
                    Some(Decoded::Frame { seq, msg, .. }) => f.replies.push((r.t_us, seq, msg)),
                    Some(Decoded::Dropped { .. }) => f.dropped += 1,
                    None => {}
                },
            }
        }
    }
    f
}
