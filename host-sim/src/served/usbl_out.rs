//! The served vehicle's surface instrument: its simulated USBL sends each fix as a real one
//! does, a Kongsberg `$PSIMSSB` sentence (relative Cartesian, north up, the measurement's own
//! time of day, its expected accuracy) in a UDP datagram to the surface program, which
//! relays it to the vehicle's estimator as it would a real USBL's.
//!
//! The time of day is the wall clock's (UTC) at the moment the fix was valid: the fix's
//! simulated time mapped back through the speed-up from the tick that sends it. The surface
//! maps that time to the vehicle's clock from its telemetry, as it must for a real USBL.

use anyhow::{Context, Result};
use controller_core::nav::PositionFix;
use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

/// The transponder code the simulated USBL reports.
const TRANSPONDER: &str = "B01";

/// A simulated USBL's NMEA output on UDP.
#[derive(Debug)]
pub struct UsblOut {
    socket: UdpSocket,
    to: SocketAddr,
    speedup: f64,
    /// Sentences sent.
    pub sent: u64,
}

impl UsblOut {
    /// Send to `to` (`HOST:PORT`), the simulation running `speedup` times real time.
    pub fn new(to: &str, speedup: f64) -> Result<Self> {
        let to: SocketAddr = to
            .parse()
            .with_context(|| format!("--usbl-to {to}: not HOST:PORT"))?;
        let socket = UdpSocket::bind(if to.is_ipv4() { "0.0.0.0:0" } else { "[::]:0" })?;
        Ok(Self {
            socket,
            to,
            speedup,
            sent: 0,
        })
    }

    /// Send `fix` (valid at simulated `fix.t_us`, the vehicle at `depth_m` then), the
    /// simulation being at `now_us`. A datagram that cannot be sent is lost, as on a
    /// network; the vehicle's estimator sees a gap.
    pub fn send(&mut self, fix: &PositionFix, depth_m: f32, now_us: u64) {
        let behind_s = now_us.saturating_sub(fix.t_us) as f64 * 1e-6 / self.speedup;
        let valid_at = SystemTime::now()
            .checked_sub(Duration::from_secs_f64(behind_s))
            .unwrap_or(UNIX_EPOCH);
        let line = psimssb(fix, depth_m, valid_at);
        if self.socket.send_to(line.as_bytes(), self.to).is_ok() {
            self.sent += 1;
        }
    }
}

/// `fix` as a `$PSIMSSB` sentence, north up (x east, y north), valid at `at` (UTC).
pub fn psimssb(fix: &PositionFix, depth_m: f32, at: SystemTime) -> String {
    let since_midnight_ms = at
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_millis() % 86_400_000)
        .unwrap_or(0);
    let (h, rest) = (since_midnight_ms / 3_600_000, since_midnight_ms % 3_600_000);
    let (m, rest) = (rest / 60_000, rest % 60_000);
    let (s, ms) = (rest / 1000, rest % 1000);
    let body = format!(
        "PSIMSSB,{h:02}{m:02}{s:02}.{ms:03},{TRANSPONDER},A,,C,N,M,{:.3},{:.3},{:.3},{:.3},N,,",
        fix.east_m, fix.north_m, depth_m, fix.std_m
    );
    let cs = sensor_drivers::usbl::xor_checksum(body.as_bytes());
    format!("${body}*{cs:02X}\r\n")
}
