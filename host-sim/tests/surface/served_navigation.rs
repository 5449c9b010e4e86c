//! The survey of `nav-lawnmower-3d` flown as a real dive is: the vehicle served by
//! `host-sim vehicle --usbl-to`, its DVL's fixes reaching its estimator as the A50's `wrz`
//! reports on its DVL port (parsed and gated by the firmware), the USBL's fixes sent as
//! `$PSIMSSB` NMEA over UDP to the surface program (`rov-topside --usbl udpin:`), which
//! converts them into the dive's local frame and relays them down the tether; a pymavlink
//! ground station (`clients/pymavlink_survey.py`) flies the survey's legs as a mission in AUTO.
//! The vehicle's estimate against the truth (the served vehicle's truth log, from 10 s after
//! AUTO is taken to 250 s after it) is held within 10 % + 1 cm of the estimation RMS of
//! `host-sim run nav-lawnmower-3d` (after 10 s, over its 250 s), and every waypoint is
//! reported reached. Skipped with the fix without pymavlink.

// Test code: a failed expectation should stop the test.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use crate::gcs;
use crate::long_emulated;

use gcs::{dive, free_udp_port, pymavlink_or_skip, stop};
use host_sim::closed_loop::runner::{run, RunOptions};
use sim_scenario::Scenario;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The scenario's duration (s): the figure is over the span of its software run.
const SURVEY_S: f64 = 250.0;

/// The lawnmower's legs (`[reference]` of `nav-lawnmower-3d`: from (0, 0, 3 m), heading
/// north, 3 legs of 15 m, 5 m apart) as waypoints `north,east,depth`.
const LEGS: [&str; 5] = ["15,0,3", "15,5,3", "0,5,3", "0,10,3", "15,10,3"];

/// The truth log's time, true position and the vehicle's estimate.
fn read_truth(path: &Path) -> Vec<(f64, [f64; 3], [f64; 3])> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let cols: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| cols.iter().position(|c| *c == name).unwrap();
    let (t, x, y, z) = (col("t_s"), col("x_m"), col("y_m"), col("z_m"));
    let (nx, ny, nz) = (col("nav_x_m"), col("nav_y_m"), col("nav_z_m"));
    lines
        .filter_map(|l| {
            let v: Vec<f64> = l
                .split(',')
                .map(|x| x.parse().unwrap_or(f64::NAN))
                .collect();
            // A killed process may leave its last line unfinished.
            (v.len() == cols.len()).then(|| (v[t], [v[x], v[y], v[z]], [v[nx], v[ny], v[nz]]))
        })
        .collect()
}

pub(crate) fn the_lawnmower_survey_with_the_dvl_and_usbl_on_their_wires_matches_software() {
    let name = "the_lawnmower_survey_with_the_dvl_and_usbl_on_their_wires_matches_software";
    if !long_emulated::long_test_of("surface", &format!("served_navigation::{name}"), 90)
        || !pymavlink_or_skip()
    {
        return;
    }
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("served-navigation");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let port = free_udp_port();
    let flight = dive(
        "nav-lawnmower-3d",
        port,
        &dir.join("survey.tlog"),
        &dir.join("params.json"),
        &["--duration", "1200", "--speedup", "4", "--surface-nav"],
    );
    let out = Command::new("python3")
        .arg(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/clients/pymavlink_survey.py"
        ))
        .arg(port.to_string())
        .arg(SURVEY_S.to_string())
        .args(LEGS)
        .output()
        .unwrap();
    let truth_path = flight.truth();
    stop(flight);
    let stdout = String::from_utf8_lossy(&out.stdout);
    // The PASS lines, and every 500th position (a track to read).
    let pass: Vec<&str> = stdout
        .lines()
        .enumerate()
        .filter(|(i, l)| !l.starts_with("POS") || i % 500 == 0)
        .map(|(_, l)| l)
        .collect();
    println!(
        "{}\n{}",
        pass.join("\n"),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "the pymavlink client failed");

    let start_s = stdout
        .lines()
        .find_map(|l| l.strip_prefix("START "))
        .and_then(|v| v.trim().parse::<f64>().ok())
        .expect("the client's START line")
        / 1e3;
    // Every waypoint reported reached (MISSION_ITEM_REACHED, as the ground station saw it):
    // the survey was flown, not only its first leg.
    let reached = stdout
        .lines()
        .find_map(|l| l.strip_prefix("REACHED "))
        .expect("the client's REACHED line");
    let want = format!(
        "[{}]",
        (0..LEGS.len())
            .map(|k| k.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    assert_eq!(reached.trim(), want, "waypoints reached");
    let rows = read_truth(&truth_path);
    let scored: Vec<f64> = rows
        .iter()
        .filter(|(t, _, _)| (start_s + 10.0..=start_s + SURVEY_S).contains(t))
        .map(|(_, truth, nav)| (0..3).map(|k| (nav[k] - truth[k]).powi(2)).sum())
        .collect();
    assert!(scored.len() >= 1000, "{} rows scored", scored.len());
    let served_rms = (scored.iter().sum::<f64>() / scored.len() as f64).sqrt();
    let sc = Scenario::load("nav-lawnmower-3d").unwrap();
    let sw = run(&sc.resolve().unwrap(), &RunOptions::default()).unwrap();
    let software_rms = sw.summary.rms_estimation_error_m;
    let bound = 1.1 * software_rms + 0.01;
    println!(
        "estimate against the truth from 10 s after AUTO (at {start_s:.1} s): {:.2} cm served \
         ({} rows), {:.2} cm in software (host-sim run); bound {:.2} cm",
        served_rms * 100.0,
        scored.len(),
        software_rms * 100.0,
        bound * 100.0
    );
    assert!(served_rms <= bound);
}
