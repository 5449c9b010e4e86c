//! A refused input: the error a user's bad scenario, option or file gets (the command line
//! exits with its own code for it). The number checks are `sim_world::checks`.

pub use topside::refusal::{is_refused, refused, Refused};
