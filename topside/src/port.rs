//! Byte ports to the vehicle: a TCP socket (QEMU's `-serial tcp:`, a serial-to-TCP bridge)
//! or a serial device, read with a short timeout so a waiting loop can check its deadline.

use anyhow::{Context, Result};
use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::PathBuf;
use std::time::Duration;

/// Where the other end of the tether is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Endpoint {
    /// A TCP socket (`HOST:PORT`), e.g. a serial-to-TCP bridge or QEMU's `-serial tcp:`.
    Tcp(String),
    /// A serial device (`/dev/ttyUSB0`) at a baud rate, opened raw by the `serialport` crate.
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
    open_with_poll(ep, POLL)
}

/// Open an endpoint whose reads wait at most `poll` for a byte: a loop that drains what
/// has arrived and goes on (the surface program's) wants a short one.
pub fn open_with_poll(ep: &Endpoint, poll: Duration) -> Result<Box<dyn Port>> {
    match ep {
        Endpoint::Tcp(addr) => {
            let s =
                TcpStream::connect(addr).with_context(|| format!("cannot connect to {addr}"))?;
            let s = tcp_port(s)?;
            s.set_read_timeout(Some(poll))?;
            Ok(Box::new(s))
        }
        Endpoint::Serial { device, baud } => serial_port_with_poll(device, *baud, poll),
    }
}

/// Open a serial device (a USB-serial adapter, a UART, a pseudo-terminal) raw at `baud`, 8N1,
/// no flow control, through the `serialport` crate, with the short read timeout of the ports.
pub fn serial_port(device: &std::path::Path, baud: u32) -> Result<Box<dyn Port>> {
    serial_port_with_poll(device, baud, POLL)
}

/// [`serial_port`] with reads that wait at most `poll`.
pub fn serial_port_with_poll(
    device: &std::path::Path,
    baud: u32,
    poll: Duration,
) -> Result<Box<dyn Port>> {
    let path = device.to_string_lossy();
    let port = serialport::new(path.as_ref(), baud)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(serialport::FlowControl::None)
        .timeout(poll)
        .open_native()
        .with_context(|| format!("cannot open serial port {path} at {baud} baud"))?;
    Ok(Box::new(port))
}

/// Configure an accepted or connected TCP stream as a port.
pub fn tcp_port(s: TcpStream) -> Result<TcpStream> {
    s.set_nodelay(true)?;
    s.set_read_timeout(Some(POLL))?;
    Ok(s)
}

/// How the surface reaches the vehicle: a serial device or a TCP stream, exactly one.
#[derive(Debug, Clone, clap::Args)]
pub struct VehicleLink {
    /// A vehicle (or the paper's topside MCU) on a serial device: `/dev/ttyUSB0` or
    /// `/dev/ttyUSB0:57600` (the baud rate after a colon; default `--baud`).
    #[arg(long, value_name = "DEV[:BAUD]")]
    pub serial: Option<String>,
    /// A vehicle at HOST:PORT: a simulated one (`host-sim vehicle --listen tcp:HOST:PORT`) or
    /// a serial-to-TCP bridge; the same byte stream as --serial.
    #[arg(long, value_name = "HOST:PORT")]
    pub tcp: Option<String>,
    /// The baud rate of --serial when the device does not name one.
    #[arg(long, default_value_t = 115_200)]
    pub baud: u32,
}

impl VehicleLink {
    /// The endpoint these arguments name; a baud rate that is not a number is refused.
    pub fn endpoint(&self) -> Result<Endpoint> {
        if self.tcp.is_some() && self.serial.is_some() {
            return Err(crate::refusal::refused(anyhow::anyhow!(
                "give --serial or --tcp, not both"
            )));
        }
        if let Some(addr) = &self.tcp {
            return Ok(Endpoint::Tcp(addr.clone()));
        }
        let Some(dev) = &self.serial else {
            return Err(crate::refusal::refused(anyhow::anyhow!(
                "give --serial DEV[:BAUD] or --tcp HOST:PORT"
            )));
        };
        let (device, baud) = split_baud(dev, self.baud)?;
        Ok(Endpoint::Serial { device, baud })
    }
}

/// `DEV` or `DEV:BAUD` into the device and its baud rate (`default` without one).
fn split_baud(dev: &str, default: u32) -> Result<(PathBuf, u32)> {
    match dev.rsplit_once(':') {
        Some((d, b)) if !d.is_empty() => {
            let baud: u32 = b.parse().map_err(|_| {
                crate::refusal::refused(anyhow::anyhow!(
                    "--serial {dev}: the baud rate after ':' must be a whole number (got {b:?})"
                ))
            })?;
            if !(300..=4_000_000).contains(&baud) {
                return Err(crate::refusal::refused(anyhow::anyhow!(
                    "--serial {dev}: baud rate {baud} outside 300-4,000,000"
                )));
            }
            Ok((PathBuf::from(d), baud))
        }
        _ => Ok((PathBuf::from(dev), default)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_serial_device_may_carry_its_baud_rate() {
        let (d, b) = split_baud("/dev/ttyUSB0:57600", 115_200).unwrap();
        assert_eq!((d, b), (PathBuf::from("/dev/ttyUSB0"), 57_600));
        let (d, b) = split_baud("/dev/ttyUSB0", 115_200).unwrap();
        assert_eq!((d, b), (PathBuf::from("/dev/ttyUSB0"), 115_200));
        assert!(split_baud("/dev/ttyUSB0:fast", 115_200).is_err());
        assert!(split_baud("/dev/ttyUSB0:12", 115_200).is_err());
    }
}
