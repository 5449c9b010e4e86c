//! host-sim library: plants, scenarios, the closed-loop runner, outputs.
pub mod plant;
