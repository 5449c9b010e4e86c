//! Verdicts that never cry wolf: each kind of scenario of `tests/verdicts/` flown by the
//! built binary, as a script would, and judged right: the exit code and the rule that fired
//! (named with its figure in `summary.json` and on the command line).

use std::path::{Path, PathBuf};
use std::process::Output;

use crate::common;
use common::host_sim;

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// A scenario file of `tests/verdicts/`.
fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/verdicts")
        .join(format!("{name}.toml"))
}

/// `host-sim run FIXTURE --out DIR/o` in a fresh folder; the output and `summary.json`.
fn run(name: &str) -> (Output, Option<serde_json::Value>) {
    let (o, s, _) = run_in(name);
    (o, s)
}

/// [`run`], and the output folder.
fn run_in(name: &str) -> (Output, Option<serde_json::Value>, PathBuf) {
    let dir = common::scratch("verdicts", name);
    let f = fixture(name);
    let o = host_sim(&dir, &["run", f.to_str().unwrap(), "--out", "o"]);
    let summary = std::fs::read_to_string(dir.join("o/summary.json"))
        .ok()
        .map(|t| serde_json::from_str(&t).unwrap());
    (o, summary, dir.join("o"))
}

/// A scenario the vehicle would refuse is refused (exit 2) with the vehicle's reason, and
/// nothing is flown.
fn assert_refused(name: &str, reason: &str) {
    let (o, summary) = run(name);
    assert_eq!(o.status.code(), Some(2), "{name}: {}", text(&o));
    assert!(text(&o).contains(reason), "{name}: {}", text(&o));
    assert!(
        summary.is_none(),
        "{name}: a refused scenario wrote outputs"
    );
}

#[test]
fn a_vehicle_as_heavy_as_its_vertical_thruster_is_refused_with_the_vehicles_reason() {
    assert_refused("buoyancy-heavy-15n", "more than half the vertical thrust");
}

#[test]
fn a_vehicle_18_n_light_is_refused_with_the_vehicles_reason() {
    assert_refused("buoyancy-light-18n", "more than half the vertical thrust");
}

#[test]
fn a_reference_beyond_the_vehicles_range_is_refused_with_its_bound() {
    assert_refused("reference-2km", "start_m");
}

#[test]
fn an_unknown_delay_that_wanders_metres_off_is_a_runaway() {
    // 5.8 m off at most, 3.4 m (last-20 % RMS) at the end, 1.5 turns more than the path.
    let (o, s) = run("delay-0.42-current-3d");
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let s = s.unwrap();
    assert_eq!(s["diverged"], true, "{s}");
    assert_eq!(s["rule"]["name"], "runaway", "{s}");
    assert_eq!(s["rule"]["threshold"], 1.0, "{s}");
    let figure = s["rule"]["figure"].as_f64().unwrap();
    assert!(figure > 2.0, "{s}");
    assert!(s["max_turns_off_path"].as_f64().unwrap() < 2.0, "{s}");
    assert!(text(&o).contains("lost position control"), "{}", text(&o));
    assert!(text(&o).contains("DIVERGED runaway"), "{}", text(&o));
}

#[test]
fn an_unknown_delay_that_keeps_to_its_circle_is_not_called_lost() {
    // 18 cm last-20 % RMS, 25 cm at most: worse tracking, no control lost, no targets.
    let (o, s) = run("delay-0.4-circle-3d");
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let s = s.unwrap();
    assert_eq!(s["diverged"], false, "{s}");
    assert!(s["rule"].is_null(), "{s}");
    assert!(
        s["max_position_error_after_settle_m"].as_f64().unwrap() < 0.5,
        "{s}"
    );
}

#[test]
fn a_run_that_tracks_in_a_beam_current_is_not_lost_however_it_turns() {
    let (o, s) = run("beam-current-nav-circle-3d");
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let s = s.unwrap();
    // The turns that fired the heading rule before: the vehicle heads into the current.
    assert!(s["max_turns_off_path"].as_f64().unwrap() > 2.0, "{s}");
    assert!(
        s["rms_position_error_last80_m"].as_f64().unwrap() <= 0.10,
        "{s}"
    );
    assert_eq!(s["diverged"], false, "{s}");
    assert!(s["lost_control"].is_null() && s["rule"].is_null(), "{s}");
    assert!(text(&o).contains("meets its targets"), "{}", text(&o));
}

#[test]
fn the_topside_layouts_summary_carries_the_estimators_figures() {
    let (o, s, dir) = run_in("topside-usbl-outliers-3d");
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let s = s.unwrap();
    let layout: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("layout.json")).unwrap()).unwrap();
    let nav = &s["navigation"];
    // The NEES share of the topside's estimate (in process 99.9 % of 6,000 ticks; the onboard
    // estimator on the same sensors 99.2 %).
    let nees = nav["nees_in_bounds_fraction"].as_f64().unwrap();
    assert!((0.9..=1.0).contains(&nees), "{nav}");
    // The fixes refused on the gate: the layout's own count of the topside's refusals, every
    // outlier the topside received (13 of 13 in 60 s at 20 %).
    let rejected = nav["usbl_fixes_rejected"].as_u64().unwrap();
    assert!(rejected >= 5, "{nav}");
    assert_eq!(layout["usbl_fixes_rejected"].as_u64(), Some(rejected));
    assert_eq!(
        layout["nack_reasons"]["NavRefused(Outlier)"].as_u64(),
        Some(rejected),
        "{layout}"
    );
    assert_eq!(
        nav["usbl_outliers_injected"].as_u64(),
        Some(rejected),
        "{nav}"
    );
    assert!(text(&o).contains("meets its targets"), "{}", text(&o));
}
