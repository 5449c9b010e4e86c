//! The surface program of the ROV (`rov-topside`): one side speaks the tether to the vehicle,
//! the other MAVLink 2 to ground stations (QGroundControl, MAVProxy, pymavlink) with
//! ArduSub's conventions. It reaches a vehicle only through a byte stream (`--serial DEV`: a
//! real vehicle or the paper's topside MCU; `--tcp HOST:PORT`: a simulated one served by
//! `host-sim vehicle`), so a simulated dive takes the path of a real one.
//!
//! - [`port`]: the byte ports (serial, TCP) and [`tether_log`], the raw log of every byte.
//! - [`link`]: the protocol crate's session `Client` on a port, with blocking waits.
//! - [`vehicle_file`]: vehicle descriptions (`vehicles/observer.toml`'s format).
//! - [`surface`]: the MAVLink surface program.
//! - [`console`]: a line console on the tether (arm, modes, references, telemetry to CSV).
//! - [`clock`]: time stamps on the tether; [`refusal`]: the mark of a refused input.

pub mod clock;
pub mod console;
pub mod link;
pub mod port;
pub mod refusal;
pub mod surface;
pub mod tether_log;
pub mod vehicle_file;

/// A command-line argument or a file the user gave is refused: exit status 2 (the
/// workspace's convention: 0 ran as expected, 2 input refused, 3 could not complete).
pub const EXIT_REFUSED: u8 = 2;
/// The program could not do its work (a port, a file, the vehicle): exit status 3.
pub const EXIT_FAILED: u8 = 3;
