//! `sensor-drivers`: the ROV's on-board sensors behind `embedded-hal` 1.0 traits.
//!
//! - [`ms5837`]: TE MS5837-30BA pressure sensor on I2C: PROM with its CRC-4, conversions,
//!   first- and second-order temperature compensation, depth from pressure.
//! - [`icm42688`]: TDK ICM-42688-P 6-axis IMU on SPI: identity, reset, low-noise mode,
//!   full scale and output data rate, a burst read in SI units.
//! - [`a50`]: Water Linked DVL A50 serial protocol: velocity (`wrz`) and dead-reckoning
//!   (`wrp`) reports, their CRC-8, the validity / figure-of-merit gate.
//! - [`pd6`]: the PD6 ASCII speed-log format (Teledyne RDI, Nortek, Water Linked): bottom
//!   track in instrument, ship and earth frames, distance and range to the bottom.
//! - [`usbl`]: NMEA 0183 from a USBL or underwater GPS: GGA (through the `nmea` crate) and
//!   Kongsberg's `$PSIMSSB`, checksums required; the dive's local frame.
//! - [`line`]: lines from a byte stream into a fixed buffer.
//! - [`fields`]: the comma-separated field reader the instrument parsers share.
//!
//! `no_std`, no allocation, no panics; every failure is an error value (a bus error, a wrong
//! chip, a bad PROM CRC, a reading outside what the sensor can produce) so that the firmware
//! can raise a failsafe. No crate on `embedded-hal` 1.0 covers these two parts with the
//! checks above (the MS5837 crates on crates.io are on embedded-hal 0.2 or skip the CRC and
//! the second-order compensation), so they are written here, from the datasheets; see
//! `docs/drivers.md`.
#![cfg_attr(not(test), no_std)]

pub mod a50;
pub mod fields;
pub mod icm42688;
pub mod line;
pub mod ms5837;
pub mod pd6;
pub mod usbl;
