//! The tether to the vehicle: a byte [`port`], the framed [`link`], the firmware as the
//! loop's controller end ([`endpoint`]), the firmware library in process ([`in_process`]) and
//! the firmware image in QEMU ([`qemu`]), and the raw tether log ([`tether_log`]).

pub mod endpoint;
pub mod in_process;
pub mod link;
pub mod port;
pub mod qemu;
pub mod report;
pub mod tether_log;
pub mod topside_layout;
