//! The sensor errors on the emulated MCU: the estimator on the firmware's `qemu` image
//! against the software run of the same draws, within 10 % + 1 cm (true position, tracking
//! RMS over the last 80 % and estimation RMS): 20 % near USBL outliers (1-2 m off), the
//! compass calibration turn flown by the board (against the firmware library in process: a
//! software run cannot fly it), drawn runs of the Monte Carlo campaign of
//! `nav_monte_carlo.rs`, and the 23-minute survey with 30 % far outliers. Skipped, with a
//! message, without `qemu-system-arm` or the thumbv7em target (the pattern of `nav_hil.rs`);
//! under `ROV_REQUIRE_QEMU` a skip fails. Each run has a wall-clock guard
//! (`HilOptions::wall_limit`).
//!
//! The emulation runs at about 1-2 s of wall time per simulated second (lock-step, on the
//! host's clock; 2 shared cores), so CI runs shortened versions (about 4 minutes in all, in
//! parallel) and the whole-length runs are `#[ignore]`d with their figures
//! (`docs/navigation.md`, "The errors on the emulated MCU"). The shortened runs too
//! take minutes of QEMU: they run where `ROV_LONG` is set (CI; `long_emulated`).

use crate::long_emulated;
use crate::nav_twins;

use host_sim::closed_loop::runner::{run, RunOptions};
use host_sim::closed_loop::{RunOutput, Sample};
use host_sim::commands::hil::{run_hil, HilOptions, HilOutput, HilTarget};
use host_sim::tether::qemu::image_or_skip;
use nav_twins::{drawn_run, rms_from, within_10_percent_plus_1_cm, worst_deviation_error_deg};
use sim_scenario::Scenario;
use std::time::{Duration, Instant};

/// Longest wall time an emulated run of `simulated_s` may take: 6 s of wall per simulated
/// second and a minute (a 310 s run took over 900 s with the machine's load at 8 on 2 cores,
/// 2026-11-26).
fn wall_limit(simulated_s: f64) -> Duration {
    Duration::from_secs_f64(60.0 + 6.0 * simulated_s)
}

/// The scenario with 20 % of its USBL fixes replaced by near outliers 1-2 m off (the
/// software test's draw, `nav_outliers.rs`).
fn with_near_outliers(mut sc: Scenario) -> Scenario {
    if let Some(u) = sc.sensors.usbl.as_mut() {
        u.outlier_fraction = 0.2;
        u.outlier_m = 1.0;
    }
    sc.validate().unwrap();
    sc
}

/// The scenario on the emulated board (its wall time in seconds) or `None` when QEMU or the
/// image is missing (skipped).
fn on_qemu(sc: &Scenario) -> Option<(HilOutput, f64)> {
    let elf = image_or_skip().expect("the firmware's qemu image")?;
    Some(on_target(
        sc,
        HilTarget::Qemu { elf },
        wall_limit(sc.duration_s),
    ))
}

/// The scenario on `target`, recorded, with its wall time (s).
fn on_target(sc: &Scenario, target: HilTarget, wall_limit: Duration) -> (HilOutput, f64) {
    let mut o = HilOptions::new(target);
    o.wall_limit = wall_limit;
    // The thrust the law commands, as in software (not that of the ESC pulses).
    o.apply_pulses = false;
    o.record = true;
    let t0 = Instant::now();
    let h = run_hil(&sc.resolve().unwrap(), &o, None).unwrap();
    let wall_s = t0.elapsed().as_secs_f64();
    assert!(
        h.report.onboard_estimator,
        "the estimator did not run on board"
    );
    assert!(
        !h.run.summary.nan_detected && !h.run.summary.diverged,
        "{}",
        h.run.summary.verdict
    );
    (h, wall_s)
}

/// The same scenario in software, recorded.
fn in_software(sc: &Scenario) -> RunOutput {
    let out = run(
        &sc.resolve().unwrap(),
        &RunOptions {
            record: true,
            ..RunOptions::default()
        },
    )
    .unwrap();
    assert!(!out.summary.nan_detected && !out.summary.diverged);
    out
}

/// Largest horizontal distance of the estimate from the truth after `t0_s` (m): an estimate
/// that jumped onto an outlier shows here.
fn worst_estimation_error_after(log: &[Sample], t0_s: f64) -> f64 {
    log.iter()
        .filter(|x| x.t_s > t0_s)
        .map(|x| (x.nav_pos_m[0] - x.state.eta[0]).hypot(x.nav_pos_m[1] - x.state.eta[1]))
        .fold(0.0, f64::max)
}

/// The near-outlier run of `sc` on QEMU and in software: tracking and estimation within 10 % +
/// 1 cm, no reset on board, the estimate never more than 0.5 m off after 10 s. With
/// `clean_too`, the clean run on QEMU as well, for the figure (the 1 cm against the clean run
/// is not met in software either: `nav_outliers.rs`).
fn near_outliers_match_software(label: &str, clean: Scenario, clean_too: bool) {
    let sc = with_near_outliers(clean.clone());
    let Some((h, wall_s)) = on_qemu(&sc) else {
        return;
    };
    let sw = in_software(&sc);
    let (hs, ss) = (&h.run.summary, &sw.summary);
    let health = h.report.nav_health.expect("the board's estimator counters");
    let worst_m = worst_estimation_error_after(&h.run.log, 10.0);
    eprintln!(
        "{label}, 20 % near outliers 1-2 m ({:.0} s simulated, {wall_s:.0} s wall): tracking \
         last-80 % RMS HIL {:.4} m, software {:.4} m; estimation RMS HIL {:.4} m, software \
         {:.4} m; {} outliers injected; on board {} fixes fused, {} refused, {} resets \
         (software: {} refused); worst estimation error after 10 s {worst_m:.3} m",
        hs.simulated_s,
        hs.rms_position_error_last80_m,
        ss.rms_position_error_last80_m,
        hs.rms_estimation_error_m,
        ss.rms_estimation_error_m,
        hs.navigation.usbl_outliers_injected,
        health.position_fused,
        health.position_outliers,
        health.resets,
        ss.navigation.usbl_fixes_rejected,
    );
    assert!(hs.navigation.usbl_outliers_injected > 0, "no outlier drawn");
    within_10_percent_plus_1_cm(
        "tracking",
        hs.rms_position_error_last80_m,
        ss.rms_position_error_last80_m,
    );
    within_10_percent_plus_1_cm(
        "estimation",
        hs.rms_estimation_error_m,
        ss.rms_estimation_error_m,
    );
    assert_eq!(health.resets, 0, "a reset onto near outliers on board");
    assert!(worst_m < 0.5, "the estimate jumped: {worst_m} m");
    if clean_too {
        if let Some((c, _)) = on_qemu(&clean) {
            let cs = &c.run.summary;
            eprintln!(
                "{label} clean on QEMU: tracking last-80 % RMS {:.4} m, estimation RMS {:.4} m; \
                 near outliers - clean {:+.2} cm (software: clean {:.4} m)",
                cs.rms_position_error_last80_m,
                cs.rms_estimation_error_m,
                100.0 * (hs.rms_position_error_last80_m - cs.rms_position_error_last80_m),
                in_software(&clean).summary.rms_position_error_last80_m
            );
        }
    }
}

/// CI's run: the circle's first 60 s (the last 80 % from 12 s, about 12 outliers): the
/// comparison is of the two estimators on the same fixes, which a shorter run still makes.
#[test]
fn hil_circle_with_20_percent_near_outliers_matches_software() {
    if !long_emulated::long_test(
        "nav_hil_errors",
        "hil_circle_with_20_percent_near_outliers_matches_software",
        90,
    ) {
        return;
    }
    let mut sc = Scenario::load("nav-circle-3d").unwrap();
    sc.duration_s = 60.0;
    near_outliers_match_software("nav-circle-3d, 60 s", sc, false);
}

#[test]
#[ignore = "~12-25 min of QEMU (near outliers and clean): run with --ignored; measured 9.42 cm HIL, 9.41 cm software (estimation 11.43 cm both), 27 of 27 outliers refused on board, 0 resets; clean on QEMU 8.04 cm (+1.37 cm, as in software), 2026-11-26"]
fn hil_whole_circle_with_20_percent_near_outliers_matches_software() {
    near_outliers_match_software(
        "nav-circle-3d",
        Scenario::load("nav-circle-3d").unwrap(),
        true,
    );
}

#[test]
#[ignore = "~25 min of QEMU (near outliers and clean): run with --ignored; measured 10.39 cm HIL and software (estimation 10.98 cm both), 0 resets; clean on QEMU 9.17 cm (+1.22 cm, as in software), 2026-11-26"]
fn hil_survey_with_20_percent_near_outliers_matches_software() {
    near_outliers_match_software(
        "nav-lawnmower-3d",
        Scenario::load("nav-lawnmower-3d").unwrap(),
        true,
    );
}

/// `scenarios/nav-survey-outliers-3d.toml` (23 minutes, 30 % of the fixes 10-20 m off) on the
/// emulated board against software: within 10 % + 1 cm, no reset on board, the estimate never
/// more than 0.5 m off after 10 s (an outlier fused or reset onto is 10-20 m), at least as
/// many fixes refused on board as outliers injected, tracking <= 10 cm.
#[test]
#[ignore = "~35-60 min of QEMU: run with --ignored; measured 6.79 cm HIL and software (estimation 6.63 cm both), 446 outliers, 0 resets, worst 0.265 m, 3,526 s wall, 2026-11-26"]
fn hil_23_minute_survey_with_30_percent_far_outliers_matches_software() {
    let sc = Scenario::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenarios/nav-survey-outliers-3d.toml"
    ))
    .unwrap();
    let Some((h, wall_s)) = on_qemu(&sc) else {
        return;
    };
    let sw = in_software(&sc);
    let (hs, ss) = (&h.run.summary, &sw.summary);
    let health = h.report.nav_health.expect("the board's estimator counters");
    let worst_m = worst_estimation_error_after(&h.run.log, 10.0);
    eprintln!(
        "nav-survey-outliers-3d ({:.0} s simulated, {wall_s:.0} s wall): tracking last-80 % RMS \
         HIL {:.4} m, software {:.4} m; estimation RMS HIL {:.4} m, software {:.4} m; {} \
         outliers injected; on board {} fixes fused, {} refused, {} resets (software: {} \
         refused); worst estimation error after 10 s HIL {worst_m:.3} m, software {:.3} m",
        hs.simulated_s,
        hs.rms_position_error_last80_m,
        ss.rms_position_error_last80_m,
        hs.rms_estimation_error_m,
        ss.rms_estimation_error_m,
        hs.navigation.usbl_outliers_injected,
        health.position_fused,
        health.position_outliers,
        health.resets,
        ss.navigation.usbl_fixes_rejected,
        worst_estimation_error_after(&sw.log, 10.0),
    );
    assert!(hs.simulated_s >= 1379.0);
    assert!(hs.navigation.usbl_outliers_injected > 300);
    within_10_percent_plus_1_cm(
        "tracking",
        hs.rms_position_error_last80_m,
        ss.rms_position_error_last80_m,
    );
    within_10_percent_plus_1_cm(
        "estimation",
        hs.rms_estimation_error_m,
        ss.rms_estimation_error_m,
    );
    assert_eq!(health.resets, 0, "a reset on board");
    assert!(
        u64::from(health.position_outliers) >= hs.navigation.usbl_outliers_injected,
        "fewer fixes refused than outliers injected"
    );
    assert!(worst_m < 0.5, "the estimate jumped: {worst_m} m");
    assert!(hs.rms_position_error_last80_m <= 0.10);
}

/// The compass of `nav_compass_cal_flown.rs`: 5 deg hard iron at phase 0.7 rad, 2 deg at
/// 10 N of summed thrust.
const HARD_IRON_RAD: f64 = 0.0873;
const HARD_IRON_PHASE_RAD: f64 = 0.7;

/// The survey in a 0.2 m/s beam current with that compass, the calibration turn at
/// 0.25 rad/s (60 s limit) first, and `survey_s` of the survey after it (the turn ends at
/// about 30 s).
fn survey_after_the_turn(survey_s: f64) -> Scenario {
    let mut sc = Scenario::load("nav-lawnmower-3d").unwrap();
    sc.disturbance.current_m_s = [0.0, 0.2, 0.0];
    sc.sensors.compass = Some(sim_world::sensors::CompassSpec {
        hard_iron_rad: HARD_IRON_RAD,
        hard_iron_phase_rad: HARD_IRON_PHASE_RAD,
        thrust_offset_rad_per_n: 0.00349,
        ..Default::default()
    });
    sc.calibration = Some(sim_scenario::CalibrationSpec {
        yaw_rate_rad_s: 0.25,
        time_limit_s: 60.0,
    });
    sc.duration_s = 30.0 + survey_s;
    sc.validate().unwrap();
    sc
}

/// What a flown turn gave: the fit's worst error against the truth over 360 headings (deg),
/// its `(sin, cos)` terms (rad), and the tracking RMS over the last 80 % of the time after the
/// turn (m).
fn turn_and_survey(h: &HilOutput) -> (f64, [f64; 2], f64) {
    use firmware::compass_swing::SwingOutcome;
    let end_s = h.report.calibration_end_s.expect("the turn ended");
    let Some(SwingOutcome::Accepted { cal, .. }) = h.report.compass_swing else {
        panic!("turn not accepted: {:?}", h.report.compass_swing);
    };
    assert_eq!(
        h.report.compass_cal,
        Some(cal),
        "the fit is the calibration in force"
    );
    let t_last = h.run.log.last().map_or(0.0, |x| x.t_s);
    let from_s = end_s + 0.2 * (t_last - end_s);
    let rms_m = rms_from(&h.run.log, from_s, |x| x.pos_err_norm_m);
    (
        worst_deviation_error_deg(&cal, HARD_IRON_RAD, HARD_IRON_PHASE_RAD),
        [f64::from(cal.sin_rad), f64::from(cal.cos_rad)],
        rms_m,
    )
}

/// The turn flown by the emulated board against the same firmware library in process (the
/// software twin: a software `run` refuses `[calibration]`, the turn is the firmware's).
fn calibration_turn_matches_the_library(survey_s: f64, tracking_bound_m: Option<f64>) {
    let sc = survey_after_the_turn(survey_s);
    let Some((q, wall_s)) = on_qemu(&sc) else {
        return;
    };
    let (l, _) = on_target(&sc, HilTarget::InProcess, wall_limit(sc.duration_s));
    let (q_worst_deg, q_fit, q_rms_m) = turn_and_survey(&q);
    let (l_worst_deg, l_fit, l_rms_m) = turn_and_survey(&l);
    eprintln!(
        "calibration turn then {survey_s:.0} s of survey ({wall_s:.0} s wall): turn ended at \
         {:?} s on QEMU, {:?} s in process; fit sin/cos {:.4}/{:.4} rad on QEMU, {:.4}/{:.4} \
         in process (truth {:.4}/{:.4}); worst deviation error {q_worst_deg:.2} deg on QEMU, \
         {l_worst_deg:.2} in process; tracking after the turn, last-80 % RMS {:.4} m on QEMU, \
         {:.4} m in process; {:?}",
        q.report.calibration_end_s,
        l.report.calibration_end_s,
        q_fit[0],
        q_fit[1],
        l_fit[0],
        l_fit[1],
        HARD_IRON_RAD * HARD_IRON_PHASE_RAD.cos(),
        HARD_IRON_RAD * HARD_IRON_PHASE_RAD.sin(),
        q_rms_m,
        l_rms_m,
        q.report.nav_health
    );
    assert!(q_worst_deg <= 1.0, "fitted deviation {q_worst_deg} deg off");
    within_10_percent_plus_1_cm("tracking after the turn", q_rms_m, l_rms_m);
    if let Some(bound_m) = tracking_bound_m {
        assert!(q_rms_m <= bound_m, "tracking after the turn {q_rms_m} m");
    }
}

/// CI's run: the turn and the survey's first 40 s after it. The board against the library
/// only: the first minute after the turn holds the settling from the turn's hold point onto
/// the survey (23.6 cm over 60 s on both, 2026-11-26), so the 10 cm is asserted on
/// the whole survey (ignored run below and `nav_compass_cal_flown.rs`).
#[test]
fn hil_flown_compass_turn_fits_within_1_deg_and_matches_the_library() {
    if !long_emulated::long_test(
        "nav_hil_errors",
        "hil_flown_compass_turn_fits_within_1_deg_and_matches_the_library",
        110,
    ) {
        return;
    }
    calibration_turn_matches_the_library(40.0, None);
}

#[test]
#[ignore = "~10-23 min of QEMU: run with --ignored; measured fit 0.19 deg off on QEMU and in process, tracking after the turn 8.16 cm both, 2026-11-26"]
fn hil_flown_compass_turn_then_the_whole_survey_matches_the_library() {
    calibration_turn_matches_the_library(280.0, Some(0.10));
}

/// Runs `0..runs` of the campaign, each `duration_s` long, on the emulated board, each
/// against its software twin: tracking (last 80 %) and estimation RMS within 10 % + 1 cm, no
/// NaN, no diverged run or filter (estimation RMS over 1 m). The vehicle waits, armed and
/// neutral, for its estimate to be ready (`Track` taken at about 1.5 s) and flies the
/// reference from then; the software run flies it from 0.
fn drawn_runs_match_software(runs: std::ops::Range<u64>, duration_s: f64) {
    let mut base = Scenario::load("nav-lawnmower-3d").unwrap();
    base.duration_s = duration_s;
    for k in runs {
        let sc = drawn_run(&base, k);
        let Some((h, wall_s)) = on_qemu(&sc) else {
            return;
        };
        let sw = in_software(&sc);
        let (hs, ss) = (&h.run.summary, &sw.summary);
        eprintln!(
            "drawn run {k} of the survey ({duration_s:.0} s, {wall_s:.0} s wall; compass bias \
             {:.2} deg, DVL scale {:+.4}, mounting {:+.2} deg, start told {:?} m and {:+.2} deg \
             off; Track taken at {:?} s): tracking last-80 % RMS HIL {:.4} m, software {:.4} m; \
             estimation RMS HIL {:.4} m, software {:.4} m; {:?}",
            sc.sensors
                .compass
                .as_ref()
                .map_or(0.0, |c| c.bias_rad.to_degrees()),
            sc.sensors.dvl.as_ref().map_or(0.0, |d| d.scale_error),
            sc.sensors
                .dvl
                .as_ref()
                .map_or(0.0, |d| d.mounting_yaw_rad.to_degrees()),
            sc.navigation.start_error_m,
            sc.navigation.start_heading_error_rad.to_degrees(),
            h.report.mode_set_at_s,
            hs.rms_position_error_last80_m,
            ss.rms_position_error_last80_m,
            hs.rms_estimation_error_m,
            ss.rms_estimation_error_m,
            h.report.nav_health
        );
        assert!(
            hs.rms_estimation_error_m <= 1.0,
            "run {k}: the board's filter diverged"
        );
        within_10_percent_plus_1_cm(
            &format!("run {k}, tracking"),
            hs.rms_position_error_last80_m,
            ss.rms_position_error_last80_m,
        );
        within_10_percent_plus_1_cm(
            &format!("run {k}, estimation"),
            hs.rms_estimation_error_m,
            ss.rms_estimation_error_m,
        );
    }
}

/// The campaign's first two draws (one test each, so that they run in parallel; CI flies the
/// first, `ROV_LONG=all` both), the survey's first 60 s (the last 80 % from 12 s: the estimate's convergence from the
/// 5 m start is inside the window, the part where the board and the software could part).
#[test]
fn hil_drawn_monte_carlo_run_0_matches_its_software_twin() {
    if !long_emulated::long_test(
        "nav_hil_errors",
        "hil_drawn_monte_carlo_run_0_matches_its_software_twin",
        90,
    ) {
        return;
    }
    drawn_runs_match_software(0..1, 60.0);
}

#[test]
fn hil_drawn_monte_carlo_run_1_matches_its_software_twin() {
    if !long_emulated::long_test_all(
        "nav_hil_errors",
        "hil_drawn_monte_carlo_run_1_matches_its_software_twin",
        90,
    ) {
        return;
    }
    drawn_runs_match_software(1..2, 60.0);
}

#[test]
#[ignore = "~20 min of QEMU: run with --ignored; measured tracking 11.02/11.80/15.95 cm HIL vs 10.95/11.64/17.16 cm software, 2026-11-26"]
fn hil_three_drawn_monte_carlo_runs_of_100_s_match_their_software_twins() {
    drawn_runs_match_software(0..3, 100.0);
}
