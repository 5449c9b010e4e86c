//! One file per command of the command line (`host-sim <command>`); `main.rs` parses the
//! arguments and calls these.

pub mod current_sweep;
pub mod hil;
pub mod link;
pub mod monte_carlo;
pub mod replay;
