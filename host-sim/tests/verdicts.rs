//! Verdicts that never cry wolf: each kind of scenario of `tests/verdicts/` flown by the
//! built binary, as a script would, and judged right: the exit code and the rule that fired
//! (named with its figure in `summary.json` and on the command line).

use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
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
    let dir = common::scratch("verdicts", name);
    let f = fixture(name);
    let o = host_sim(&dir, &["run", f.to_str().unwrap(), "--out", "o"]);
    let summary = std::fs::read_to_string(dir.join("o/summary.json"))
        .ok()
        .map(|t| serde_json::from_str(&t).unwrap());
    (o, summary)
}

/// A scenario the vehicle would refuse is refused (exit 2) with the vehicle's reason, and
/// nothing is flown.
fn assert_refused(name: &str, reason: &str) {
    let (o, summary) = run(name);
    assert_eq!(o.status.code(), Some(2), "{name}: {}", text(&o));
    assert!(text(&o).contains(reason), "{name}: {}", text(&o));
    assert!(summary.is_none(), "{name}: a refused scenario wrote outputs");
}

#[test]
fn a_vehicle_as_heavy_as_its_vertical_thruster_is_refused_with_the_vehicles_reason() {
    assert_refused(
        "buoyancy-heavy-15n",
        "more than half the vertical thrust",
    );
}

#[test]
fn a_vehicle_18_n_light_is_refused_with_the_vehicles_reason() {
    assert_refused(
        "buoyancy-light-18n",
        "more than half the vertical thrust",
    );
}

#[test]
fn a_reference_beyond_the_vehicles_range_is_refused_with_its_bound() {
    assert_refused("reference-2km", "start_m");
}

#[test]
fn an_unknown_delay_that_wanders_metres_off_is_lost_position_control() {
    let (o, s) = run("delay-0.4-circle-3d");
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let s = s.unwrap();
    assert_eq!(s["diverged"], true, "{s}");
    assert!(text(&o).contains("lost position control"), "{}", text(&o));
    assert_eq!(s["rule"]["name"], "runaway", "{s}");
    assert!(s["rule"]["figure"].as_f64().unwrap() > 1.0, "{s}");
}
