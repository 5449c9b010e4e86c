//! The tether to the vehicle: a byte [`port`], the framed [`link`], the firmware as the
//! loop's controller end ([`endpoint`]) and the commands that carry the sensors' measurements
//! to it ([`measurement`]), the firmware library in process ([`in_process`]) and the firmware
//! image in QEMU ([`qemu`]) with its DVL and health wires ([`board_wires`]), and the raw
//! tether log ([`tether_log`]).

pub mod board_wires;
pub mod endpoint;
pub mod in_process;
pub mod measurement;
pub mod options;
pub mod qemu;
pub mod report;
pub mod topside_layout;

// The surface end of the tether lives in the surface program's crate; the simulator drives
// the firmware through the same code.
pub use topside::{link, port, tether_log};
