//! ArduSub's motor test from a ground station (`clients/pymavlink_motor_test.py`) against
//! `host-sim vehicle` + `rov-topside --tcp`: each refusal in words, the tested thruster's pulse
//! in the served vehicle's truth log for ArduSub's 0.5 s window with the others neutral, the
//! vehicle disarmed at its end, a resent request keeping it going.
//!
//! Without pymavlink: SKIPPED with the fix (a failure with `ROV_REQUIRE_PYMAVLINK=1`).

use crate::gcs;

use gcs::{dive, free_udp_port, pymavlink_or_skip, run_client as client, stop};
use std::path::{Path, PathBuf};

/// Simulated time per wall time.
const SPEEDUP: &str = "2";

fn dir(name: &str) -> PathBuf {
    crate::gcs::scratch_dir(&format!("topside-gcs-{name}"))
}

/// The vehicle's telemetry in the surface's tether log: its time (s) and the three pulse
/// widths its ESCs saw.
fn pulses(dir: &Path) -> Vec<(f64, [f64; 3])> {
    let log = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "tether"))
        .expect("the surface's tether log");
    let frames = topside::tether_log::decode(&topside::tether_log::read(&log).unwrap());
    frames
        .replies
        .iter()
        .filter_map(|(_, _, r)| match r {
            protocol::Reply::Telemetry(t) => {
                Some((t.t_us as f64 * 1e-6, t.pulse_us.map(f64::from)))
            }
            _ => None,
        })
        .collect()
}

/// The truth log's `t_s`, `z_m` and `yaw_rad` rows.
fn truth_rows(path: &Path) -> Vec<[f64; 3]> {
    gcs::truth_columns(path, ["t_s", "z_m", "yaw_rad"])
}

/// The runs (start, end time) of consecutive rows for which `on` holds.
fn runs(rows: &[(f64, [f64; 3])], on: impl Fn(&[f64; 3]) -> bool) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::new();
    let mut open: Option<(f64, f64)> = None;
    for (t, p) in rows {
        match (&mut open, on(p)) {
            (Some(r), true) => r.1 = *t,
            (None, true) => open = Some((*t, *t)),
            (Some(r), false) => {
                out.push(*r);
                open = None;
            }
            (None, false) => {}
        }
    }
    out.extend(open);
    out
}

pub(crate) fn the_motor_test_turns_one_thruster_for_ardusubs_window_and_is_refused_in_words() {
    if !pymavlink_or_skip() {
        return;
    }
    let d = dir("motor-test");
    let port = free_udp_port();
    let flight = dive(
        "circle-3d",
        port,
        &d.join("s.tlog"),
        &d.join("params.json"),
        &["--speedup", SPEEDUP, "--duration", "600"],
    );
    let (passed, out) = client("pymavlink_motor_test.py", &[port.to_string()]);
    let truth = flight.truth();
    stop(flight);
    assert!(passed, "pymavlink_motor_test.py failed");
    let refusals = out
        .lines()
        .filter(|l| l.starts_with("TEXT: Motor test refused"))
        .count();
    assert!(refusals >= 6, "{refusals} refusals said");
    let rows = pulses(&d);
    assert!(rows.len() > 100, "{} telemetry frames", rows.len());
    let neutral = 1500.0;
    // The single request: output 3 at 1700 us, the others neutral, for 0.5 s.
    let single = runs(&rows, |p| p[2] == 1700.0);
    println!("output 3 at 1700 us: {single:?}");
    assert_eq!(
        single.len(),
        1,
        "one run of the vertical thruster: {single:?}"
    );
    let (a, b) = single[0];
    let period = rows[rows.len() - 1].0 - rows[rows.len() - 2].0;
    let length = b - a + period;
    // Telemetry comes every `period` (0.1 s): the window is seen to that step.
    assert!(
        (0.5 - period - 1e-6..=0.5 + period + 1e-6).contains(&length),
        "the window lasted {length:.3} s (0.5 s asked, telemetry every {period:.2} s)"
    );
    let during: Vec<_> = rows.iter().filter(|(t, _)| (a..=b).contains(t)).collect();
    assert!(
        during
            .iter()
            .all(|(_, p)| p[0] == neutral && p[1] == neutral),
        "the other thrusters moved during the test"
    );
    // The truth: the vertical thruster pushed the vehicle down, the horizontal ones did not
    // turn it.
    let truth = truth_rows(&truth);
    let at = |t: f64| truth.iter().find(|r| r[0] >= t).copied().unwrap();
    let (before, after) = (at(a), at(b + 1.0));
    println!(
        "truth over the test: depth {:.3} -> {:.3} m, yaw {:.4} -> {:.4} rad",
        before[1], after[1], before[2], after[2]
    );
    assert!(after[1] - before[1] > 0.005, "the vehicle did not go down");
    assert!((after[2] - before[2]).abs() < 0.01, "the vehicle turned");
    // Resent every 0.2 s of the vehicle's time: one run of output 1 at 1700 us, about 4 s.
    let kept = runs(&rows, |p| {
        p[0] == 1700.0 && p[1] == neutral && p[2] == neutral
    });
    println!("output 1 at 1700 us (kept going): {kept:?}");
    let longest = kept.iter().map(|(a, b)| b - a + period).fold(0.0, f64::max);
    assert!(
        (3.0..=4.6).contains(&longest),
        "kept going for {longest:.2} s (2 s of wall time at 2x, then the 0.5 s window)"
    );
    // Output 2 at 1300 us is ended by the mode change: shorter than its window.
    let ended = runs(&rows, |p| p[1] == 1300.0);
    println!("output 2 at 1300 us (ended by a mode change): {ended:?}");
    assert!(
        ended.iter().all(|(a, b)| b - a + period < 0.5),
        "the mode change did not end it: {ended:?}"
    );
}
