//! host-sim library: `f64` plants, scenarios, the closed-loop runner around the `f32`
//! controller core, outputs (summary, CSV, PNG figures) and Monte Carlo.
//!
//! - [`plant`]: the planar plants ([`plant::xz`], [`plant::xy`]) and the 6-DOF plant.
//! - [`scenario`]: TOML scenarios, built-ins embedded from `scenarios/`.
//! - [`sim_loop`]: the one closed loop (plant, navigation, a controller endpoint, metrics).
//! - [`runner`]: a software run (the core in process); [`hil`]: the firmware over the
//!   tether; [`qemu`]: the emulated board.
//! - [`sensors`]: simulated IMU, depth, compass, DVL and USBL; [`estimator_nav`]: the core's
//!   estimator on them as the navigation stage.
//! - [`topside`]: the surface side: MAVLink 2 to ground stations, the tether to the vehicle.
//! - [`tether_log`]: the raw tether log of the topside.
//! - [`deployment`]: `host-sim deployment`, the topside layout's measurements.
//! - [`deployment_spec`]: the `[deployment]` keys.
//! - [`topside_layout`]: the paper's layout (topside MCU + node) as the loop's controller.
//! - [`tether_wire`]: the byte-level wire between the topside MCU and the node (issue 25).
//! - [`vehicle`]: vehicle files (the Observer's is the default).
//! - [`output`], [`plots`]: what a run writes.
//! - [`monte_carlo`]: perturbed-parameter runs in parallel.
//! - [`current_sweep`]: currents from every direction, as heat maps (issue 14).

pub mod checks;
pub mod clock;
pub mod current_sweep;
pub mod deployment;
pub mod deployment_spec;
pub mod estimator_nav;
pub mod hil;
pub mod in_process;
pub mod link;
pub mod monte_carlo;
pub mod output;
pub mod params;
pub mod plant;
pub mod plots;
pub mod port;
pub mod qemu;
pub mod replay;
pub mod runner;
pub mod scenario;
pub mod sensors;
pub mod sim_loop;
pub mod tether_log;
pub mod tether_wire;
pub mod topside;
pub mod topside_layout;
pub mod vehicle;
