//! host-sim library: `f64` plants, scenarios, the closed-loop runner around the `f32`
//! controller core, the tether to the firmware, the topside, outputs (summary, CSV, PNG
//! figures) and the command line's commands. Each layer uses only the ones listed before it
//! (docs/host-sim.md, "Where things are"):
//!
//! - the world (crate `sim-world`): the plants (rigid body, thrusters, water), frames, sensors
//!   and noise, the battery, the tether's wires, the number checks and simulated time.
//! - [`checks`]: a refused input (the error a bad scenario, option or file gets).
//! - the scenarios (crate `sim-scenario`): what to run: TOML scenarios (built-ins embedded
//!   from `scenarios/`), the reference, vehicle files.
//! - [`closed_loop`]: the one closed loop (plant, navigation stage, a controller endpoint,
//!   metrics), the navigation stages, the core in process, a software run.
//! - [`output`]: what a run writes (summary, CSV, plots).
//! - [`tether`]: the port, the framed link, the firmware as an endpoint (in process, in
//!   QEMU, a board), the tether log.
//! - [`served`]: the simulator serves a vehicle (SITL): the plant, the sensors and the
//!   firmware library's `App` in real time, its tether on a TCP port (`host-sim vehicle`).
//! - [`commands`]: one file per command of the command line.

pub mod checks;
pub mod closed_loop;
pub mod commands;
pub mod output;
pub mod served;
pub mod tether;
