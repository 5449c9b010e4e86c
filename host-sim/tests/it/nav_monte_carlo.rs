//! Monte Carlo over the sensors' real errors and the start. 200 runs of the
//! lawnmower survey (full suite), each with its own sensor noise and its own draw of: the
//! compass bias (uniform +-5 deg), the DVL scale factor (+-1 %) and mounting yaw (+-2 deg),
//! and the launch point the estimator is told (5 m off in a random direction, heading
//! +-5 deg off, with that uncertainty). Figures on the TRUE position, RMS over the last
//! 80 %.

use crate::long_emulated::campaign_runs;
use crate::nav_twins;

use host_sim::closed_loop::runner::{run, RunOptions};
use nav_twins::drawn_run;
use rayon::prelude::*;
use sim_scenario::Scenario;

const RUNS: usize = 200;

fn percentile(sorted: &[f64], p: f64) -> f64 {
    let i = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[i]
}

#[test]
fn two_hundred_surveys_with_drawn_biases_and_start_errors_p95_within_15_cm() {
    let base = Scenario::load("nav-lawnmower-3d").unwrap();
    let runs = campaign_runs(
        "nav_monte_carlo",
        "two_hundred_surveys_with_drawn_biases_and_start_errors_p95_within_15_cm",
        RUNS,
        40,
    ) as u64;
    let results: Vec<_> = (0..runs)
        .into_par_iter()
        .map(|k| {
            let s = run(
                &drawn_run(&base, k).resolve().unwrap(),
                &RunOptions::default(),
            )
            .unwrap()
            .summary;
            (
                s.rms_position_error_last80_m,
                s.rms_estimation_error_m,
                s.nan_detected,
                s.diverged,
            )
        })
        .collect();
    let nan = results.iter().filter(|r| r.2).count();
    let diverged = results.iter().filter(|r| r.3).count();
    // A filter is diverged when its estimation RMS exceeds 1 m.
    let diverged_filters = results.iter().filter(|r| r.1.is_nan() || r.1 > 1.0).count();
    let mut tracking: Vec<f64> = results.iter().map(|r| r.0).collect();
    tracking.sort_by(f64::total_cmp);
    let mut estimation: Vec<f64> = results.iter().map(|r| r.1).collect();
    estimation.sort_by(f64::total_cmp);
    let p95 = percentile(&tracking, 0.95);
    println!(
        "{runs} surveys: tracking p50 {:.1} cm, p95 {:.1} cm, max {:.1} cm; estimation p95 {:.1} cm; NaN {nan}, diverged {diverged}, diverged filters {diverged_filters}",
        100.0 * percentile(&tracking, 0.5),
        100.0 * p95,
        100.0 * tracking[tracking.len() - 1],
        100.0 * percentile(&estimation, 0.95),
    );
    assert_eq!((nan, diverged, diverged_filters), (0, 0, 0));
    assert!(p95 <= 0.15, "p95 {p95} m");
}
