//! The tests that serve a vehicle and fly it through the surface program (`rov-topside`), as a
//! real dive is flown: `host-sim vehicle` serves the vehicle's tether on TCP, `rov-topside
//! --tcp` speaks to it, and a ground station (pymavlink, MAVProxy, MAVSDK or the `mavlink`
//! crate) drives the surface. One binary, so that the simulator is linked once.
//!
//! The tests wait on real time (sessions, time-outs, flights at the vehicle's pace) far more
//! than they compute, so two at a time (libtest's default on two cores) left the machine
//! mostly idle (docs/testing.md has the figures). This binary has its own harness
//! (`libtest-mimic`, the same command line and output as libtest's) that runs six at a time
//! unless `--test-threads` or `RUST_TEST_THREADS` says otherwise. A test is a function here
//! and is listed in [`TESTS`]; one that is not listed is dead code, which the lints refuse.
//!
//! `cargo test -p host-sim --test surface MODULE::` runs one module (e.g. `topside_safety::`).
//! The README's command runs the quick ones: each kind of session (safety, pymavlink, MAVProxy,
//! missions, the buttons, the motor test, parameters and failsafes, the compass turn, the
//! identification manoeuvre's start and stop, both layouts, a serial line); the longer flights
//! (GUIDED go-tos, the global-frame and MAVProxy missions, MAVSDK, the emulated board behind
//! the surface, the mission on the vehicle's own estimate, the restart in GUIDED) run where
//! `ROV_LONG` is set, as in CI, and print a `SKIPPED` line with their command elsewhere.

use libtest_mimic::{Arguments, Trial};

/// `(path, function, ignored)` for each test function listed by its path (`module::name`);
/// `#[ignore]` before a path marks it as libtest's attribute does.
macro_rules! tests {
    (@ignored ignore) => {
        true
    };
    (@ignored) => {
        false
    };
    ($($(#[$attr:ident])? $first:ident $(:: $rest:ident)*),+ $(,)?) => {
        [$((
            concat!(stringify!($first) $(, "::", stringify!($rest))*),
            $first $(:: $rest)* as fn(),
            tests!(@ignored $($attr)?),
        )),+]
    };
}

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

/// Every test of this binary, by its path (`module::name`, as libtest names them and as the
/// filters and `long_test` use them), and whether it is left out unless asked for
/// (`--ignored`, libtest's `#[ignore]`). The harness starts them in this order: the longest
/// first (their wall times on 2 cores, quick and `ROV_LONG` runs: docs/testing.md), so that
/// the last ones end together rather than one long flight after the rest.
const TESTS: &[(&str, fn(), bool)] = &tests![
    topside_gcs::mavproxy_flies_local_and_global_missions_and_its_guided_and_position_commands,
    topside_layout::a_ground_station_flies_the_topside_layout_to_a_guided_target,
    served_navigation::the_lawnmower_survey_with_the_dvl_and_usbl_on_their_wires_matches_software,
    topside_clients::pymavlink_flies_the_emulated_board,
    topside_gcs::a_ground_station_gets_what_it_asks_at_connection_goes_to_points_and_reads_refusals_in_words,
    topside_gcs_buttons::the_joystick_buttons_act_once_per_press_and_the_gain_scales_the_sticks,
    topside_clients::estimator::pymavlink_flies_a_mission_on_the_vehicles_own_estimator,
    topside_clients::estimator::the_surface_restarts_the_vehicles_estimator_mid_dive,
    served_layouts::the_topside_layout_served_in_process,
    served_layouts::the_topside_layout_served_in_qemu,
    topside_gcs_mavsdk::mavsdk_connects_reads_parameters_flies_a_mission_goes_to_a_point_tests_a_motor_and_disarms,
    topside_clients::mavproxy_flies_a_mission_it_loads_from_a_file,
    topside_guided::a_restarted_surface_reads_guided_back_and_the_go_to_goes_on,
    topside_gcs_ident::the_identification_manoeuvre_runs_from_a_ground_station_and_is_refused_in_words,
    topside_clients::pymavlink_flies_the_simulated_vehicle_and_reads_the_tlog,
    topside_gcs_params::the_ground_station_failsafe_warns_disarms_and_holds_depth_when_its_heartbeat_stops,
    topside_clients::pymavlink_uploads_a_mission_and_flies_it_in_auto,
    topside_safety::commands_addressed_to_another_system_or_component_change_nothing,
    topside_safety::control_changes_hands_with_the_passkey_one_grant_at_a_time_and_without_a_thrust_jump,
    topside_compass_cal::pymavlink_starts_the_compass_turn_and_reads_the_fit_back,
    topside_gcs_params::pilot_speed_dn_bounds_the_descent_the_heave_stick_asks_in_alt_hold,
    served_layouts::the_onboard_image_served_in_qemu,
    served_vehicle::pymavlink_flies_a_served_vehicle_through_topside_tcp,
    topside_clients::probes::one_commander_at_a_time_and_bad_commands_change_nothing,
    topside_layout::the_topside_program_runs_the_emulated_topside_layout,
    topside_safety::arming_or_changing_mode_with_a_stick_held_gives_no_thrust,
    topside_gcs_motor::the_motor_test_turns_one_thruster_for_ardusubs_window_and_is_refused_in_words,
    topside_clients::pymavlink_flies_a_mission_in_a_global_frame_after_setting_the_origin,
    topside_clients::a_manual_control_flood_starves_neither_the_tether_nor_a_second_ground_station,
    topside_safety::a_quiet_vehicle_does_not_end_the_surface_program,
    topside_clients::probes::a_mission_upload_is_one_stations_transaction_and_auto_keeps_its_mission,
    topside_safety::a_restart_mid_dive_with_the_saved_file_flies_again_within_5_s,
    topside_safety::vehicle_frames_out_of_range_are_refused_and_counted,
    topside_gcs_params::health_parameters_are_set_refused_in_words_acted_on_and_restored_with_the_system_id,
    topside_clients::probes::two_starts_write_two_sets_of_logs_and_the_first_is_intact,
    served_vehicle::a_session_through_the_served_tether_and_a_cut,
    topside_layout_serial::the_topside_drives_a_topside_board_on_a_serial_line_and_shows_its_node_link,
    topside_layout::a_pilot_drives_the_topside_layout_in_manual,
    topside_serial::the_topside_drives_a_vehicle_on_a_serial_line,
    topside_layout::the_ground_station_sees_the_node_link_cut_within_250_ms,
    topside_clients::pymavlink_changes_gains_the_vehicle_and_a_timeout_which_survive_a_restart_and_bad_ones_are_refused,
    topside_safety::fence_and_rally_leave_the_mission_and_every_item_is_answered,
    topside_clients::probes::a_tcp_ground_station_may_disconnect_and_come_back,
    topside_gcs::the_vehicle_given_wins_over_a_saved_parameter_file_and_the_start_says_so,
    topside_clients::probes::the_escs_neutral_is_not_a_parameter_a_ground_station_can_move,
    topside_serial::a_serial_device_that_is_not_there_is_a_clear_error,
    topside_clients::probes::an_empty_datagram_and_garbage_do_not_end_the_topside,
    served_vehicle::refused_before_start_and_a_busy_port,
];

/// How many tests run at once where neither `--test-threads` nor `RUST_TEST_THREADS` says.
const DEFAULT_TEST_THREADS: usize = 6;

fn main() -> std::process::ExitCode {
    let mut args = Arguments::from_args();
    if args.test_threads.is_none() {
        let from_env = std::env::var("RUST_TEST_THREADS").ok();
        args.test_threads = Some(match from_env.as_deref().map(str::parse::<usize>) {
            Some(Ok(n)) if n > 0 => n,
            Some(_) => {
                eprintln!("RUST_TEST_THREADS must be a positive whole number");
                return std::process::ExitCode::from(101);
            }
            None => DEFAULT_TEST_THREADS,
        });
    }
    // `ROV_TEST_TIMES` set: each test's wall time on stderr when it ends (libtest's
    // `--report-time` is unstable and this harness has none).
    let report_times = std::env::var_os("ROV_TEST_TIMES").is_some();
    let trials = TESTS
        .iter()
        .map(|&(name, test, ignored)| {
            Trial::test(name, move || {
                let t0 = std::time::Instant::now();
                test();
                if report_times {
                    eprintln!("TIME {name} {:.1} s", t0.elapsed().as_secs_f64());
                }
                Ok(())
            })
            .with_ignored_flag(ignored)
        })
        .collect();
    libtest_mimic::run(&args, trials).exit_code()
}
