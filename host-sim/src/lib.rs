//! host-sim library: `f64` plants, scenarios, the closed-loop runner around the `f32`
//! controller core, outputs (summary, CSV, PNG figures) and Monte Carlo.
//!
//! - [`plant`]: the planar plants ([`plant::xz`], [`plant::xy`]) and the 6-DOF plant.
//! - [`scenario`]: TOML scenarios, built-ins embedded from `scenarios/`.
//! - [`runner`]: one closed-loop run.
//! - [`output`], [`plots`]: what a run writes.
//! - [`monte_carlo`]: perturbed-parameter runs in parallel.

pub mod hil;
pub mod link;
pub mod monte_carlo;
pub mod output;
pub mod plant;
pub mod plots;
pub mod runner;
pub mod scenario;
