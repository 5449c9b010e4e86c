//! The tether protocol (the `protocol` crate), under the name the firmware's modules use.

pub use ::protocol::*;
