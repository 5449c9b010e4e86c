//! Byte ports to the vehicle: a TCP socket (QEMU's `-serial tcp:`, a serial-to-TCP bridge)
//! or a serial device, read with a short timeout so a waiting loop can check its deadline.

use anyhow::{bail, Context, Result};
use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::PathBuf;
use std::time::Duration;

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
