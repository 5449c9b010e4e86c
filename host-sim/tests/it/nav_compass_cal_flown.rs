//! The compass calibration turn FLOWN in closed loop by the firmware (its library in
//! process behind the same frames as the board, `host-sim hil --in-process`): the survey in a
//! 0.2 m/s beam current with the full sensor suite, a compass with a 5 deg hard-iron
//! deviation and a thrust-dependent 2 deg (at 10 N of summed thrust). The scenario's
//! `[calibration]` makes the vehicle turn a full circle in `Hold` first; the fit becomes the
//! calibration in force, then the survey is flown. Figures on the TRUE position.

use crate::nav_twins;

use controller_core::nav::compass_cal::{CalRefusal, CompassCalibration};
use firmware::compass_swing::SwingOutcome;
use host_sim::commands::hil::{run_hil, HilOptions, HilOutput, HilTarget};
use nav_twins::worst_deviation_error_deg;
use sim_scenario::{CalibrationSpec, Scenario};
use sim_world::sensors::CompassSpec;

const HARD_IRON_RAD: f64 = 0.0873; // 5 deg
const PHASE_RAD: f64 = 0.7;
/// 2 deg at 10 N of summed thrust.
const THRUST_OFFSET_RAD_PER_N: f64 = 0.00349;

/// The survey with that compass and the turn first.
fn survey_with_calibration(time_limit_s: f64) -> HilOutput {
    survey_with_hard_iron(HARD_IRON_RAD, time_limit_s)
}

/// The survey with a compass of `hard_iron_rad` and the turn first.
fn survey_with_hard_iron(hard_iron_rad: f64, time_limit_s: f64) -> HilOutput {
    let mut sc = Scenario::load("nav-lawnmower-3d").unwrap();
    sc.disturbance.current_m_s = [0.0, 0.2, 0.0];
    sc.sensors.compass = Some(CompassSpec {
        hard_iron_rad,
        hard_iron_phase_rad: PHASE_RAD,
        thrust_offset_rad_per_n: THRUST_OFFSET_RAD_PER_N,
        ..CompassSpec::default()
    });
    sc.calibration = Some(CalibrationSpec {
        yaw_rate_rad_s: 0.25,
        time_limit_s,
    });
    // The whole survey after the turn (about 30 s).
    sc.duration_s += 60.0;
    let sc = sc.resolve().unwrap();
    let mut o = HilOptions::new(HilTarget::InProcess);
    // The thrust the law commands, as in software.
    o.apply_pulses = false;
    o.record = true;
    run_hil(&sc, &o, None).unwrap()
}

/// Tracking RMS over the last 80 % of the run after the turn (m).
fn rms_after(h: &HilOutput, end_s: f64) -> f64 {
    let log = &h.run.log;
    let t_last = log.last().map_or(0.0, |x| x.t_s);
    let from_s = end_s + 0.2 * (t_last - end_s);
    let errs: Vec<f64> = log
        .iter()
        .filter(|x| x.t_s >= from_s)
        .map(|x| x.pos_err_norm_m)
        .collect();
    (errs.iter().map(|e| e * e).sum::<f64>() / errs.len().max(1) as f64).sqrt()
}

/// A 10 deg hard iron: the estimator's compass bias learned the uncalibrated deviation at
/// the hold heading; the fit swapped in at the end of the turn must carry it (before, the
/// heading was reset onto the new readings with the old bias 7 times, 33 good fixes were
/// refused and the survey ended 24-30 cm).
#[test]
#[ignore = "not met: 9.07 cm after the turn (fit 0.33 deg off, 4 resets, 3 fixes refused; 24-30 cm before the calibration carried the bias), 2026-11-28"]
fn a_10_deg_hard_iron_calibrated_by_the_flown_turn_surveys_within_8_cm() {
    let h = survey_with_hard_iron(2.0 * HARD_IRON_RAD, 60.0);
    let end_s = h.report.calibration_end_s.expect("the turn ended");
    let Some(SwingOutcome::Accepted { cal, .. }) = h.report.compass_swing else {
        panic!("turn not accepted: {:?}", h.report.compass_swing);
    };
    let worst = worst_deviation_error_deg(&cal, 2.0 * HARD_IRON_RAD, PHASE_RAD);
    let rms = rms_after(&h, end_s);
    eprintln!(
        "10 deg hard iron: turn ended at {end_s:.2} s, worst deviation error {worst:.2} deg; survey after it: tracking last-80 % RMS {:.2} cm; {:?}",
        100.0 * rms,
        h.report.nav_health
    );
    assert!(!h.run.summary.nan_detected && !h.run.summary.diverged);
    assert!(worst <= 1.0, "fitted deviation {worst} deg off the truth");
    assert!(rms <= 0.08, "tracking after the turn {rms} m");
}

#[test]
fn the_flown_turn_fits_within_1_deg_and_the_survey_after_it_tracks_within_10_cm() {
    let h = survey_with_calibration(60.0);
    let end_s = h.report.calibration_end_s.expect("the turn ended");
    let Some(SwingOutcome::Accepted { cal, residual_rad }) = h.report.compass_swing else {
        panic!("turn not accepted: {:?}", h.report.compass_swing);
    };
    assert_eq!(
        h.report.compass_cal,
        Some(cal),
        "the fit is the calibration in force"
    );
    // Tracking after the calibration: RMS over the last 80 % of it.
    let log = &h.run.log;
    let t_last = log.last().map_or(0.0, |x| x.t_s);
    let from_s = end_s + 0.2 * (t_last - end_s);
    let errs: Vec<f64> = log
        .iter()
        .filter(|x| x.t_s >= from_s)
        .map(|x| x.pos_err_norm_m)
        .collect();
    let rms = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len().max(1) as f64).sqrt();
    let worst = worst_deviation_error_deg(&cal, HARD_IRON_RAD, PHASE_RAD);
    eprintln!(
        "flown turn at 0.25 rad/s: ended at {end_s:.2} s, fit sin {:.4} cos {:.4} rad (truth {:.4}, {:.4}), residual {residual_rad:.4} rad, worst deviation error {worst:.2} deg; survey after it ({:.0} s): tracking last-80 % RMS {:.2} cm; {:?}",
        cal.sin_rad,
        cal.cos_rad,
        HARD_IRON_RAD * PHASE_RAD.cos(),
        HARD_IRON_RAD * PHASE_RAD.sin(),
        t_last - end_s,
        100.0 * rms,
        h.report.nav_health
    );
    assert!(!h.run.summary.nan_detected && !h.run.summary.diverged);
    assert!(worst <= 1.0, "fitted deviation {worst} deg off the truth");
    assert!(rms <= 0.10, "tracking after the turn {rms} m");
}

#[test]
fn a_turn_not_done_within_its_limit_is_refused_and_the_old_calibration_stays() {
    // 10 s at 0.25 rad/s: 2.5 rad, less than a circle.
    let h = survey_with_calibration(10.0);
    eprintln!(
        "10 s limit: {:?} at {:?} s, in force {:?}",
        h.report.compass_swing, h.report.calibration_end_s, h.report.compass_cal
    );
    assert_eq!(
        h.report.compass_swing,
        Some(SwingOutcome::Refused(CalRefusal::NotFullTurn))
    );
    assert_eq!(h.report.compass_cal, Some(CompassCalibration::NONE));
}

/// The turn is the firmware's: a software run of a scenario with `[calibration]` is refused,
/// naming the way to fly it; an implausible turn is refused in the file with the key named.
#[test]
fn a_software_run_and_bad_calibration_keys_are_refused_with_the_reason() {
    let mut sc = Scenario::load("nav-lawnmower-3d").unwrap();
    sc.calibration = Some(CalibrationSpec {
        yaw_rate_rad_s: 0.25,
        time_limit_s: 60.0,
    });
    let e = host_sim::closed_loop::runner::run(&sc.resolve().unwrap(), &Default::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("host-sim hil"), "{e}");
    for (rate, limit, key) in [
        (2.0, 60.0, "calibration.yaw_rate_rad_s"),
        (0.25, 0.0, "calibration.time_limit_s"),
    ] {
        sc.calibration = Some(CalibrationSpec {
            yaw_rate_rad_s: rate,
            time_limit_s: limit,
        });
        let e = sc.validate().unwrap_err().to_string();
        assert!(e.contains(key), "{e}");
    }
}
