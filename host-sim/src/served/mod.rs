//! The simulator serves a vehicle (`host-sim vehicle`), as ArduPilot's SITL does: the plant,
//! the sensors and the firmware library's `App` run here in (scaled) real time, and the
//! vehicle's tether (the bytes its tether UART carries) is served on a TCP port, for a
//! surface program that cannot tell it from a real vehicle.
//!
//! - [`bridge`]: the App's one serial port shared by the surface's frames and the vehicle's
//!   own inputs (the simulated navigation computer, the on-board instruments);
//! - [`vehicle`]: the App as a board runs it, as the closed loop's controller end;
//! - [`server`]: the paced loop, the TCP port, the truth log;
//! - [`usbl_out`]: the simulated USBL at the surface, its fixes as NMEA over UDP.

pub mod bridge;
pub mod server;
pub mod usbl_out;
pub mod vehicle;
