//! The tests that serve a vehicle and fly it through the surface program (`rov-topside`), as a
//! real dive is flown: `host-sim vehicle` serves the vehicle's tether on TCP, `rov-topside
//! --tcp` speaks to it, and a ground station (pymavlink, MAVProxy, MAVSDK or the `mavlink`
//! crate) drives the surface. One binary, so that the harness runs these tests side by side
//! (they wait on real time more than they compute) and the simulator is linked once.
//!
//! `cargo test -p host-sim --test surface MODULE::` runs one module (e.g. `topside_safety::`).
//! The README's command runs the quick ones: each kind of session (safety, pymavlink, MAVProxy,
//! missions, the buttons, the motor test, parameters and failsafes, the compass turn, the
//! identification manoeuvre's start and stop, both layouts, a serial line); the longer flights
//! (GUIDED go-tos, the global-frame and MAVProxy missions, MAVSDK, the emulated board behind
//! the surface, the mission on the vehicle's own estimate, the restart in GUIDED) run where
//! `ROV_LONG` is set, as in CI, and print a `SKIPPED` line with their command elsewhere.

// Shared with `it`: this binary uses its scratch folders only.
#[allow(dead_code)]
#[path = "../common/mod.rs"]
mod common;
mod gcs;
#[path = "../it/long_emulated/mod.rs"]
mod long_emulated;

mod served_layouts;
mod served_navigation;
mod served_vehicle;
mod topside_clients;
mod topside_compass_cal;
mod topside_gcs;
mod topside_gcs_buttons;
mod topside_gcs_ident;
mod topside_gcs_mavsdk;
mod topside_gcs_motor;
mod topside_gcs_params;
mod topside_guided;
mod topside_layout;
mod topside_layout_serial;
mod topside_safety;
mod topside_serial;

/// Whether the long test `path` (`module::name`, about `wall_s` of wall time on 2 cores) runs
/// here: where `ROV_LONG` is set (CI); elsewhere it prints its `SKIPPED` line with the command.
fn long_test(path: &str, wall_s: u32) -> bool {
    long_emulated::long_test_of("surface", path, wall_s)
}
