//! The simulator serves a vehicle (`host-sim vehicle`), as ArduPilot's SITL does: the plant,
//! the sensors and the firmware (the library's `App` in process, the image in QEMU, or the
//! topside layout's two MCUs) run here in (scaled) real time, and the vehicle's tether (the
//! bytes its tether UART carries; in the topside layout the topside MCU's PC tether) is
//! served on a TCP port, for a surface program that cannot tell it from a real vehicle.
//!
//! - [`bridge`]: the App's one serial port shared by the surface's frames and the vehicle's
//!   own inputs (the simulated navigation computer, the on-board instruments);
//! - [`endpoint`]: what the served loop needs of a served vehicle;
//! - [`vehicle`]: the App as a board runs it, as the closed loop's controller end;
//! - [`image`]: the firmware's image in QEMU, stepped on the simulated clock;
//! - [`layout`]: the topside layout (the topside MCU's App, its node behind the node link),
//!   its PC tether served;
//! - [`server`]: the paced loop, the TCP port, the truth log;
//! - [`usbl_out`]: the simulated USBL at the surface, its fixes as NMEA over UDP.

pub mod bridge;
pub mod endpoint;
pub mod image;
pub mod layout;
pub mod server;
pub mod usbl_out;
pub mod vehicle;
