//! The navigation floor: every estimator run's `summary.json` carries the RMS of a
//! fixed-interval smoother on the same measurements (`navigation.floor`), and the on-board
//! estimator is judged against it. Prints the docs' results table:
//! `cargo test -p host-sim --release --test nav_floor -- --nocapture --test-threads 1`.

use host_sim::closed_loop::floor::NavFloor;
use host_sim::closed_loop::runner::{run, RunOptions, Summary};
use host_sim::scenario::Scenario;

fn load(name: &str) -> Scenario {
    Scenario::load(name).unwrap()
}

/// `nav-lawnmower-3d` in a 0.2 m/s current across its legs, the compass `bias_deg` off.
fn survey_bias(bias_deg: f64) -> Scenario {
    let mut sc = load("nav-lawnmower-3d");
    sc.disturbance.current_m_s = [0.0, 0.2, 0.0];
    if let Some(c) = sc.sensors.compass.as_mut() {
        c.bias_rad = bias_deg.to_radians();
    }
    sc
}

/// The survey with the USBL at 0.2 Hz.
fn survey_usbl_slow() -> Scenario {
    let mut sc = load("nav-lawnmower-3d");
    if let Some(u) = sc.sensors.usbl.as_mut() {
        u.rate_hz = 0.2;
    }
    sc
}

fn measure(label: &str, sc: &Scenario) -> (Summary, NavFloor) {
    let s = run(&sc.resolve().unwrap(), &RunOptions::default())
        .unwrap()
        .summary;
    let f = s.navigation.floor.clone().expect("an estimator run has a floor");
    println!(
        "| {label} | {:.2} cm | {:.2} cm | {:.2} cm | **{:.2}** | {:.2} cm | {:.2} | {:.2} | {} |",
        100.0 * s.rms_position_error_last80_m,
        100.0 * f.filter_rms_m,
        100.0 * f.floor_rms_m,
        f.ratio,
        100.0 * f.forward_rms_m,
        f.ratio_to_forward,
        s.navigation.nees_in_bounds_fraction.unwrap_or(f64::NAN),
        s.navigation.usbl_fixes_rejected,
    );
    assert!(!s.nan_detected && !s.diverged, "{label}: {}", s.verdict);
    // The floor is a floor: hindsight never does worse than the forward pass it smooths.
    assert!(f.floor_rms_m <= f.forward_rms_m * 1.02, "{label}: {f:?}");
    (s, f)
}

#[test]
fn every_estimator_run_reports_its_floor_and_the_filter_is_measured_against_it() {
    println!(
        "| scenario | tracking (last 80 %) | filter RMS | floor (smoother) | ratio | forward f64 | ratio to forward | NEES share | USBL refused |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let mut rows = Vec::new();
    for name in ["nav-circle-3d", "nav-lawnmower-3d", "nav-current-3d"] {
        rows.push((name.to_string(), measure(name, &load(name))));
    }
    for bias in [0.0, 1.0, 3.0, 6.0, 10.0] {
        let label = format!("survey, 0.2 m/s beam, compass {bias} deg");
        rows.push((label.clone(), measure(&label, &survey_bias(bias))));
    }
    let label = "survey, USBL 0.2 Hz".to_string();
    rows.push((label.clone(), measure(&label, &survey_usbl_slow())));
    for name in ["nav-usbl-circle-3d", "nav-usbl-outliers-3d", "nav-usbl-dropout-3d"] {
        rows.push((name.to_string(), measure(name, &load(name))));
    }
    // The floor is below the filter on every run (a smoother on the same data).
    for (label, (_, f)) in &rows {
        assert!(f.ratio >= 1.0, "{label}: ratio {}", f.ratio);
    }
}
