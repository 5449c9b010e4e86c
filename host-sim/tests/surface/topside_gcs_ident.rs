//! The identification manoeuvre started from a ground station (`clients/pymavlink_ident.py`,
//! `MAV_CMD_USER_2`) against `host-sim vehicle` + `rov-topside --tcp`: refused in words while
//! disarmed, with a room out of range or deeper than the vehicle; armed in POSHOLD at 10 m it
//! flies (the served vehicle's truth moves in its first minute and stays in its room), its
//! progress and its end (finished, or stopped with the reason) said; a stick stops it.
//!
//! Without pymavlink: SKIPPED with the fix (a failure with `ROV_REQUIRE_PYMAVLINK=1`).

use crate::gcs;
use crate::long_emulated;

use gcs::{dive, free_udp_port, pymavlink_or_skip, stop};
use std::path::{Path, PathBuf};

/// The truth log's `t_s, x_m, y_m, z_m` rows.
fn truth_rows(path: &Path) -> Vec<[f64; 4]> {
    gcs::truth_columns(path, ["t_s", "x_m", "y_m", "z_m"])
}

pub(crate) fn the_identification_manoeuvre_runs_from_a_ground_station_and_is_refused_in_words() {
    if !pymavlink_or_skip() {
        return;
    }
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("topside-gcs-ident");
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let port = free_udp_port();
    // nav-circle-3d started at 10 m: room for the default 6 m depth band.
    let base = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenarios/nav-circle-3d.toml"
    ))
    .unwrap();
    let scenario = base.replace("[initial]\nz_m = 2.0\n", "[initial]\nz_m = 10.0\n");
    assert_ne!(scenario, base, "the scenario starts at 2 m");
    let file = d.join("ident-10m.toml");
    std::fs::write(&file, scenario).unwrap();
    let flight = dive(
        &file,
        port,
        &d.join("s.tlog"),
        &d.join("params.json"),
        &["--duration", "1200", "--speedup", "4", "--start-nav"],
    );
    // The whole 160 s manoeuvre (40 s of wall at 4x, and the second start) where `ROV_LONG` is
    // set (CI); elsewhere its first 40 s, stopped by the stick.
    let quick = !long_emulated::long_runs_wanted();
    let mut args = vec![port.to_string()];
    args.extend(quick.then(|| "quick".to_string()));
    let (passed, _) = gcs::run_client("pymavlink_ident.py", &args);
    let truth = flight.truth();
    stop(flight);
    assert!(passed, "pymavlink_ident.py failed");
    // The manoeuvre's first minute in Hold (its first 40 s in the quick run) (it may be stopped later by a late sensor on a
    // loaded machine, said by the surface as a failsafe): the truth moves off the
    // start point and stays within the 30 m room and the 6 m band.
    let rows = truth_rows(&truth);
    let text = std::fs::read_to_string(&truth).unwrap();
    let head: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let mode_col = head.iter().position(|c| *c == "mode").unwrap();
    let modes: Vec<&str> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(mode_col).unwrap_or(""))
        .collect();
    let first_hold = modes
        .iter()
        .position(|m| *m == "Hold")
        .expect("Hold in the truth log");
    // The manoeuvre starts after arming and 2 s of hold (the client's 2 s at 4x: 8 s).
    let start = rows[first_hold];
    let window: Vec<&[f64; 4]> = rows
        .iter()
        .filter(|r| r[0] >= start[0] && r[0] <= start[0] + 60.0)
        .collect();
    let farthest = window
        .iter()
        .map(|r| (r[1] - start[1]).hypot(r[2] - start[2]))
        .fold(0.0, f64::max);
    let deepest_off = window
        .iter()
        .map(|r| (r[3] - start[3]).abs())
        .fold(0.0, f64::max);
    println!(
        "truth over the manoeuvre: at most {farthest:.2} m from the start, {deepest_off:.2} m off its depth"
    );
    assert!(farthest > 1.0, "the vehicle hardly moved: {farthest:.2} m");
    assert!(farthest < 30.0, "out of the 30 m room: {farthest:.2} m");
    assert!(deepest_off < 6.0, "out of the 6 m band: {deepest_off:.2} m");
}
