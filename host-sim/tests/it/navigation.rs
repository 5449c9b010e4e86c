//! The loop closed on the estimator: the built-in `nav-*` scenarios against the
//! issue's numbers. Every tracking figure is the **true** position against the reference;
//! the estimation figure is the estimate against the truth.

use crate::long_emulated::campaign_runs;
use host_sim::closed_loop::estimator_nav::EstimatorNav;
use host_sim::closed_loop::runner::{run, RunOptions, RunOutput, Summary};
use host_sim::closed_loop::{run_closed_loop, CoreEndpoint};
use host_sim::commands::monte_carlo::{run_batch, McConfig};
use sim_scenario::Scenario;

fn load(name: &str) -> Scenario {
    Scenario::load(name).unwrap()
}

fn run_sc(sc: &Scenario, record: bool) -> RunOutput {
    run(
        &sc.resolve().unwrap(),
        &RunOptions {
            record,
            ..RunOptions::default()
        },
    )
    .unwrap()
}

fn print(s: &Summary) {
    println!(
        "{:24} last-80 % RMS {:6.1} cm, max after 10 s {:6.1} cm, estimation RMS {:6.1} cm, NEES in 95 % bound {:.3}, outliers {}/{} rejected",
        s.scenario,
        100.0 * s.rms_position_error_last80_m,
        100.0 * s.max_position_error_after_10s_m,
        100.0 * s.rms_estimation_error_m,
        s.navigation.nees_in_bounds_fraction.unwrap_or(f64::NAN),
        s.navigation.usbl_fixes_rejected,
        s.navigation.usbl_outliers_injected,
    );
}

fn assert_healthy(s: &Summary) {
    assert!(!s.nan_detected && !s.diverged, "{}", s.verdict);
    assert_eq!(s.navigation.source, "estimator");
    assert!(s.max_abs_thruster_force_n <= 20.0 + 1e-6);
}

#[test]
fn full_suite_tracks_within_10_cm_and_estimates_within_10_cm() {
    for name in ["nav-circle-3d", "nav-lawnmower-3d"] {
        let s = run_sc(&load(name), false).summary;
        print(&s);
        assert_healthy(&s);
        assert!(
            s.rms_position_error_last80_m <= 0.10,
            "{name}: tracking {}",
            s.rms_position_error_last80_m
        );
        assert!(
            s.rms_estimation_error_m <= 0.10,
            "{name}: estimation {}",
            s.rms_estimation_error_m
        );
    }
}

/// Consistency is a property of the filter over the noise, not of one noise draw: the
/// errors are correlated over tens of seconds, so one run's share of ticks inside the 95 %
/// bound scatters widely (0.70 to 1.0 over 40 draws of the lawnmower). The check is the
/// ensemble's: the mean share over 20 draws of the sensor noise, nominal plant, must be
/// >= 0.9 (0.95 is a perfectly consistent filter).
#[test]
fn the_covariance_is_honest_nees_inside_its_95_percent_bound_on_average_over_20_noise_draws() {
    for name in ["nav-circle-3d", "nav-lawnmower-3d", "nav-usbl-circle-3d"] {
        let sc = load(name);
        let (_, runs) = run_batch(
            &sc.resolve().unwrap(),
            &McConfig {
                runs: 20,
                seed: 7,
                perturb: 0.0,
                progress: false,
            },
            (0, 1),
        )
        .unwrap();
        let f: Vec<f64> = runs
            .runs
            .iter()
            .map(|r| r.nees_in_bounds_fraction)
            .collect();
        let mean = f.iter().sum::<f64>() / f.len() as f64;
        let below = f.iter().filter(|&&x| x < 0.9).count();
        let single = run_sc(&sc, false)
            .summary
            .navigation
            .nees_in_bounds_fraction
            .unwrap();
        println!(
            "{name}: NEES share in bound, mean of 20 draws {mean:.3} (min {:.3}, {below} of 20 under 0.9); the built-in's own draw {single:.3}",
            f.iter().copied().fold(1.0, f64::min)
        );
        assert!(f.iter().all(|x| x.is_finite()));
        assert!(mean >= 0.9, "{name}: mean NEES share {mean}");
    }
}

#[test]
fn usbl_without_dvl_is_model_aided_within_30_cm_and_40_cm_in_a_current() {
    for (name, bound) in [("nav-usbl-circle-3d", 0.30), ("nav-usbl-current-3d", 0.40)] {
        let s = run_sc(&load(name), false).summary;
        print(&s);
        assert_healthy(&s);
        assert!(
            s.rms_position_error_last80_m <= bound,
            "{name}: {}",
            s.rms_position_error_last80_m
        );
    }
}

#[test]
fn every_usbl_outlier_is_rejected_and_tracking_stays_within_1_cm_of_the_clean_run() {
    let sc = load("nav-usbl-outliers-3d");
    let sc = sc.resolve().unwrap();
    let mut nav = EstimatorNav::for_scenario(&sc, sc.disturbance.noise_seed).unwrap();
    let mut ep = CoreEndpoint::for_scenario(&sc).unwrap();
    let with = run_closed_loop(&sc, &RunOptions::default(), &mut nav, &mut ep)
        .unwrap()
        .summary;
    print(&with);
    let outliers: Vec<_> = nav.fixes().iter().filter(|f| f.outlier).collect();
    assert!(
        outliers.len() >= 3,
        "too few outliers to test: {}",
        outliers.len()
    );
    for f in &outliers {
        assert_eq!(
            f.refused,
            Some(controller_core::nav::Refusal::Outlier),
            "outlier at {} s was not rejected",
            f.t_valid_s
        );
    }
    assert_eq!(
        with.navigation.usbl_outliers_injected,
        outliers.len() as u64
    );
    // Rejections count every gated fix: the outliers, and the rare good fix outside the
    // 99.9 % gate.
    assert!(with.navigation.usbl_fixes_rejected >= outliers.len() as u64);

    let mut clean_sc = sc.scenario().clone();
    clean_sc.sensors.usbl.as_mut().unwrap().outlier_fraction = 0.0;
    let clean = run_sc(&clean_sc, false).summary;
    print(&clean);
    let d = (with.rms_position_error_last80_m - clean.rms_position_error_last80_m).abs();
    assert!(
        d <= 0.01,
        "with outliers {} vs without {}",
        with.rms_position_error_last80_m,
        clean.rms_position_error_last80_m
    );
}

#[test]
fn a_60_s_usbl_dropout_with_dvl_grows_the_error_by_under_1_percent_of_the_distance_plus_10_cm() {
    let sc = load("nav-usbl-dropout-3d");
    let [t0, t1] = sc.sensors.usbl.as_ref().unwrap().dropouts_s[0];
    let out = run_sc(&sc, true);
    print(&out.summary);
    assert_healthy(&out.summary);
    let err = |s: &host_sim::closed_loop::runner::Sample| {
        (0..3)
            .map(|i| (s.nav_pos_m[i] - s.state.eta[i]).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let at_start = out.log.iter().find(|s| s.t_s >= t0).map(err).unwrap();
    // Until the first fix after the dropout arrives (its latency later).
    let latency = sc.sensors.usbl.as_ref().unwrap().latency_s;
    let window: Vec<_> = out
        .log
        .iter()
        .filter(|s| s.t_s >= t0 && s.t_s <= t1 + latency)
        .collect();
    let worst = window.iter().map(|s| err(s)).fold(0.0, f64::max);
    let mut distance = 0.0;
    for w in window.windows(2) {
        let d: f64 = (0..3)
            .map(|i| (w[1].state.eta[i] - w[0].state.eta[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        distance += d;
    }
    let growth = worst - at_start;
    println!(
        "dropout {t0}-{t1} s: error {:.1} cm at the start, worst {:.1} cm, growth {:.1} cm over {distance:.1} m (bound {:.1} cm)",
        100.0 * at_start,
        100.0 * worst,
        100.0 * growth,
        100.0 * (0.01 * distance + 0.10)
    );
    assert!(
        distance > 10.0,
        "the vehicle should travel during the dropout"
    );
    assert!(growth <= 0.01 * distance + 0.10);
}

#[test]
fn monte_carlo_of_the_full_suite_stays_within_twice_the_nominal_p95() {
    let sc = load("nav-circle-3d");
    let nominal = run_sc(&sc, false).summary.rms_position_error_last80_m;
    let runs = campaign_runs(
        "navigation",
        "monte_carlo_of_the_full_suite_stays_within_twice_the_nominal_p95",
        100,
        25,
    );
    let (summary, _) = run_batch(
        &sc.resolve().unwrap(),
        &McConfig {
            runs,
            seed: 1,
            perturb: 0.2,
            progress: false,
        },
        (0, 1),
    )
    .unwrap();
    println!(
        "Monte Carlo nav-circle-3d, {runs} runs +-20 %: last-80 % RMS p50 {:.1} cm p95 {:.1} cm max {:.1} cm (nominal {:.1} cm); estimation p95 {:.1} cm; NaN {}, diverged {}, diverged filters {}",
        100.0 * summary.rms_position_error_last80_m.p50,
        100.0 * summary.rms_position_error_last80_m.p95,
        100.0 * summary.rms_position_error_last80_m.max,
        100.0 * nominal,
        100.0 * summary.rms_estimation_error_m.p95,
        summary.nan_runs,
        summary.diverged_runs,
        summary.diverged_filters
    );
    assert_eq!(summary.nan_runs, 0);
    assert_eq!(summary.diverged_runs, 0);
    assert_eq!(summary.diverged_filters, 0);
    assert!(summary.rms_position_error_last80_m.p95 <= 2.0 * nominal);
}

#[test]
fn the_truth_path_is_still_the_default() {
    let s = run_sc(&load("circle-3d"), false).summary;
    assert_eq!(s.navigation.source, "truth");
    assert!(s.navigation.nees_in_bounds_fraction.is_none());
    assert!(s.rms_position_error_last80_m < 0.001);
}

fn parse(extra: &str) -> anyhow::Result<Scenario> {
    let base = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenarios/circle-3d.toml"
    ))
    .unwrap();
    Scenario::from_toml(&format!("{base}\n{extra}\n"), "test")
}

#[test]
fn the_estimator_without_its_sensors_is_an_error_that_names_them() {
    let e =
        parse("[navigation]\nsource = \"estimator\"\n[sensors.imu]\n[sensors.depth]").unwrap_err();
    let msg = format!("{e:#}");
    assert!(msg.contains("[sensors.compass]"), "{msg}");
    assert!(msg.contains("[sensors.dvl] or [sensors.usbl]"), "{msg}");
    assert!(!msg.contains("[sensors.imu]"), "{msg}");
}

#[test]
fn out_of_range_sensor_keys_are_refused_by_name() {
    for (extra, key) in [
        ("[sensors.depth]\nnoise_m = -0.1", "sensors.depth.noise_m"),
        ("[sensors.imu]\nrate_hz = 0.0", "sensors.imu.rate_hz"),
        ("[sensors.dvl]\nrate_hz = -5.0", "sensors.dvl.rate_hz"),
        ("[sensors.usbl]\nlatency_s = 10.0", "sensors.usbl.latency_s"),
        (
            "[sensors.usbl]\noutlier_fraction = 1.5",
            "sensors.usbl.outlier_fraction",
        ),
        (
            "[sensors.usbl]\noutlier_fraction = -0.1",
            "sensors.usbl.outlier_fraction",
        ),
        (
            "[sensors.compass]\nnoise_rad = nan",
            "sensors.compass.noise_rad",
        ),
        (
            "[sensors.usbl]\ndropouts_s = [[5.0, 1.0]]",
            "sensors.usbl.dropouts_s[0]",
        ),
    ] {
        let msg = format!("{:#}", parse(extra).unwrap_err());
        assert!(msg.contains(key), "{extra:?}: {msg}");
    }
    let msg = format!("{:#}", parse("[sensors.usbl]\nlatency = 0.5").unwrap_err());
    assert!(msg.contains("unknown field"), "{msg}");
    let msg = format!(
        "{:#}",
        parse("[navigation]\nsource = \"oracle\"").unwrap_err()
    );
    assert!(msg.contains("oracle"), "{msg}");
}
