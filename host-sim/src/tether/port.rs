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
    match ep {
        Endpoint::Tcp(addr) => {
            let s =
                TcpStream::connect(addr).with_context(|| format!("cannot connect to {addr}"))?;
            Ok(Box::new(tcp_port(s)?))
        }
        Endpoint::Serial { device, baud } => serial_port(device, *baud),
    }
}

/// Open a serial device (a USB-serial adapter, a UART, a pseudo-terminal) raw at `baud`, 8N1,
/// no flow control, through the `serialport` crate, with the short read timeout of the ports.
pub fn serial_port(device: &std::path::Path, baud: u32) -> Result<Box<dyn Port>> {
    let path = device.to_string_lossy();
    let port = serialport::new(path.as_ref(), baud)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(serialport::FlowControl::None)
        .timeout(POLL)
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
