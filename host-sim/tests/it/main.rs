//! host-sim's integration tests in one binary: each module was a test binary of its own,
//! and linking ~40 binaries against the simulator cost more than running them. One binary
//! also lets the harness run the long tests of different modules side by side.
//!
//! `cargo test -p host-sim --test it MODULE::` runs one module (e.g. `nav_hil::`). Kept
//! apart, as binaries of their own: `qemu_skip.rs` (it sets process-wide environment
//! variables), `hil_link.rs` (a console session on the emulated board in wall-clock time: it
//! needs the emulator to itself, and failed beside the other emulated runs of this binary),
//! `identification.rs`, and the tests that fly the surface program against a served vehicle
//! (`surface/`: they wait on real time, and run side by side in their own binary).

// Shared with the surface program's tests (`topside_layout.rs`).
#[path = "../common/mod.rs"]
mod common;
mod long_emulated;
mod nav_twins;
mod tracking_common;

mod cli_limits;
mod closed_loop;
mod current_sweep;
mod currents;
mod deployment;
mod deployment_qemu;
mod emulated_instruments;
mod exit_codes;
mod health;
mod hil_qemu;
mod in_process;
mod instruments;
mod library;
mod lost_control;
mod modcycles;
mod monte_carlo;
mod nav_compass_bias;
mod nav_compass_cal;
mod nav_compass_cal_flown;
mod nav_floor;
mod nav_hil;
mod nav_hil_errors;
mod nav_monte_carlo;
mod nav_outliers;
mod nav_sensors;
mod nav_start;
mod nav_water;
mod navigation;
mod outlier_count;
mod plants;
mod scenarios;
mod tracking_3d;
mod tracking_disturbance;
mod tracking_paper;
mod tracking_plant;
mod vehicle_file;
mod verdicts;
