//! Tracking and station keeping in currents, and a known measurement delay. Every
//! figure is the plant's **true** position against the reference, from closed-loop runs on
//! the 6-DOF plant with the tracking law (current observer on, nothing told about the
//! current).

use host_sim::closed_loop::runner::run;
use host_sim::closed_loop::{RunOptions, RunOutput};
use host_sim::commands::current_sweep::{cell, sweep, PATHS, RMS_BOUND_M};
use host_sim::commands::monte_carlo::{run_batch, McConfig};
use sim_scenario::Scenario;

use crate::long_emulated::campaign_runs;
use rayon::prelude::*;

fn fly(name: &str, current_m_s: Option<[f64; 3]>) -> RunOutput {
    let sc = Scenario::load(name).unwrap();
    let opts = RunOptions {
        record: true,
        current_m_s,
        ..RunOptions::default()
    };
    run(&sc.resolve().unwrap(), &opts).unwrap()
}

/// The sweep: line, circle and lawnmower, 0.1-0.3 m/s from every 30 degrees (quick: the
/// fastest current, 0.3 m/s, from every 90 degrees on each path).
#[test]
fn every_current_direction_up_to_0_3_m_s_is_tracked_within_5_cm_rms() {
    let full = 3 * 3 * 12;
    let name = "every_current_direction_up_to_0_3_m_s_is_tracked_within_5_cm_rms";
    let cells = if campaign_runs("currents", name, full, 12) == full {
        sweep().unwrap()
    } else {
        let quick: Vec<_> = PATHS
            .iter()
            .flat_map(|p| [0.0, 90.0, 180.0, 270.0].map(|d| (*p, d)))
            .collect();
        quick
            .par_iter()
            .map(|&(path, dir)| cell(path, 0.3, dir).unwrap())
            .collect()
    };
    assert!(cells.len() == full || cells.len() == 12);
    for c in &cells {
        eprintln!(
            "{:13} {:.1} m/s from {:3.0} deg: RMS {:5.1} mm, max after 10 s {:5.1} mm",
            c.path,
            c.speed_m_s,
            c.direction_deg,
            c.rms_last80_m * 1e3,
            c.max_after_10s_m * 1e3
        );
        assert!(!c.nan, "{c:?}");
        assert!(c.max_thrust_n <= 20.0 + 1e-9, "{c:?}");
        assert!(c.rms_last80_m <= RMS_BOUND_M, "{c:?}");
        assert!(c.max_after_10s_m <= 0.2, "{c:?}");
    }
}

/// `current-3d` (0.2 m/s, 5 N of buoyancy, noise, 10 ms delay): within 2 cm RMS over the last
/// 80 %.
#[test]
fn current_3d_is_tracked_within_2_cm() {
    let s = fly("current-3d", None).summary;
    eprintln!(
        "current-3d: RMS over the last 80 % {:.1} mm, final {:.1} mm",
        s.rms_position_error_last80_m * 1e3,
        s.final_position_error_m * 1e3
    );
    assert!(!s.nan_detected);
    assert!(s.rms_position_error_last80_m <= 0.02, "{s:?}");
}

/// Monte Carlo `mc-circle-3d` (0.1 m/s from a random direction, +-20 % plant parameters,
/// noise, 10 ms delay) and the same campaign in 0.2 m/s: p95 of the whole run's RMS within
/// 5 cm, no NaN.
#[test]
fn monte_carlo_in_0_1_and_0_2_m_s_currents_keeps_p95_within_5_cm() {
    let runs = campaign_runs(
        "currents",
        "monte_carlo_in_0_1_and_0_2_m_s_currents_keeps_p95_within_5_cm",
        200,
        50,
    );
    for speed in [0.1, 0.2] {
        let mut sc = Scenario::load("mc-circle-3d").unwrap();
        sc.disturbance.current_m_s = [speed, 0.0, 0.0];
        let cfg = McConfig {
            runs,
            seed: 1,
            perturb: 0.2,
            progress: false,
        };
        let (m, _) = run_batch(&sc.resolve().unwrap(), &cfg, (0, 1)).unwrap();
        let p = &m.rms_position_error_m;
        eprintln!(
            "mc-circle-3d in {speed} m/s: RMS p50 {:.1} mm, p95 {:.1} mm, max {:.1} mm; last 80 % p95 {:.1} mm; NaN {}",
            p.p50 * 1e3,
            p.p95 * 1e3,
            p.max * 1e3,
            m.rms_position_error_last80_m.p95 * 1e3,
            m.nan_runs
        );
        assert_eq!(m.nan_runs, 0);
        assert!(m.thrust_within_limits);
        assert!(p.p95 <= 0.05, "{speed} m/s: {m:?}");
    }
}

/// The hard case: a current from behind as fast as the path (no speed through the water).
#[test]
fn a_current_from_behind_at_the_path_speed_is_tracked_without_a_limit_cycle() {
    let out = fly("current-line-behind-3d", None);
    let s = &out.summary;
    eprintln!("{s:?}");
    assert!(!s.nan_detected);
    assert!(s.rms_position_error_last80_m <= 0.02, "{s:?}");
    assert!(s.max_position_error_after_10s_m <= 0.05, "{s:?}");
    // No limit cycle: the heading stays put over the last half.
    let yaw: Vec<f64> = out.log[out.log.len() / 2..]
        .iter()
        .map(|x| x.state.eta[5])
        .collect();
    let span =
        yaw.iter().cloned().fold(f64::MIN, f64::max) - yaw.iter().cloned().fold(f64::MAX, f64::min);
    assert!(span < 0.1, "yaw swings by {span} rad");
}

#[test]
fn a_cross_current_as_fast_as_the_path_is_crabbed_into() {
    let s = fly("current-line-cross-3d", None).summary;
    eprintln!("{s:?}");
    assert!(!s.nan_detected);
    assert!(s.rms_position_error_last80_m <= 0.02, "{s:?}");
    assert!(s.max_abs_thruster_force_n <= 20.0 + 1e-9);
}

/// Unwrapped yaw excursion (max - min) of the samples from `t0_s` to `t1_s`.
fn yaw_excursion(out: &RunOutput, t0_s: f64, t1_s: f64) -> f64 {
    let mut prev = None;
    let (mut acc, mut lo, mut hi) = (0.0f64, 0.0f64, 0.0f64);
    for x in out.log.iter().filter(|x| x.t_s >= t0_s && x.t_s <= t1_s) {
        let y = x.state.eta[5];
        if let Some(p) = prev {
            let mut d: f64 = y - p;
            d = (d + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
            acc += d;
            lo = lo.min(acc);
            hi = hi.max(acc);
        }
        prev = Some(y);
    }
    hi - lo
}

/// End of a path in 0.2 m/s from every 30 degrees: the vehicle turns to the heading the
/// current allows and holds the last point, and its weather-vane swing dies out (smaller over
/// the last 30 s than over the 30 s before).
#[test]
fn the_end_of_a_path_is_held_in_0_2_m_s_from_any_direction_without_a_full_turn() {
    let end_s = 40.0; // 10 m at 0.25 m/s
    for i in 0..12 {
        let a = f64::from(i) * 30f64.to_radians();
        let out = fly(
            "current-hold-end-3d",
            Some([0.2 * a.cos(), 0.2 * a.sin(), 0.0]),
        );
        let s = &out.summary;
        let t_end = out.summary.simulated_s;
        let turn = yaw_excursion(&out, end_s, t_end);
        let swing_before = yaw_excursion(&out, t_end - 60.0, t_end - 30.0);
        let swing = yaw_excursion(&out, t_end - 30.0, t_end);
        eprintln!(
            "{:3} deg: tail RMS {:.1} mm, final {:.1} mm, max after 10 s {:.1} mm, yaw excursion after the end {:.2} rad, yaw swing over the 30 s before the last {:.3} rad, over the last 30 s {:.3} rad",
            i * 30,
            s.rms_position_error_tail_m * 1e3,
            s.final_position_error_m * 1e3,
            s.max_position_error_after_10s_m * 1e3,
            turn,
            swing_before,
            swing
        );
        assert!(!s.nan_detected);
        assert!(s.rms_position_error_tail_m <= 0.05, "{i}: {s:?}");
        assert!(
            turn < std::f64::consts::TAU,
            "{i}: a full turn ({turn} rad)"
        );
        assert!(
            swing <= 0.2 && (swing < swing_before || swing < 1e-3),
            "{i}: the yaw swings by {swing} rad over the last 30 s ({swing_before} before)"
        );
    }
}

/// 0.3 s of known delay at 0.3 m/s: predicted through the model, within 2 cm; told nothing,
/// the same run lags by ~9 cm (the prediction is what closes the gap).
#[test]
fn a_known_0_3_s_delay_at_0_3_m_s_is_compensated_by_prediction() {
    let known = fly("delay-line-3d", None).summary;
    let mut sc = Scenario::load("delay-line-3d").unwrap();
    sc.disturbance.delay_known = false;
    let unknown = run(&sc.resolve().unwrap(), &RunOptions::default())
        .unwrap()
        .summary;
    eprintln!(
        "known: RMS {:.2} mm, max after 10 s {:.2} mm; unknown: RMS {:.1} mm",
        known.rms_position_error_last80_m * 1e3,
        known.max_position_error_after_10s_m * 1e3,
        unknown.rms_position_error_last80_m * 1e3
    );
    assert!(known.rms_position_error_last80_m <= 0.02);
    assert!(known.max_position_error_after_10s_m <= 0.02);
    assert!(unknown.rms_position_error_last80_m > 0.05);
}

#[test]
fn still_water_is_not_changed_by_the_current_handling() {
    // With no current the estimate stays in its dead zone and the law is the still-water
    // one: the line is tracked to a fraction of a millimetre.
    let c = cell("line-3d", 0.0, 0.0).unwrap();
    assert!(!c.nan && c.rms_last80_m < 0.001, "{c:?}");
}
