//! The estimator learns the compass's constant bias. The operator's case: the
//! lawnmower survey with the full sensor suite in a 0.2 m/s beam current (across the legs),
//! the compass off by 1, 3, 6 and 10 degrees; and the circle with USBL only, 5 degrees off.
//! Every tracking figure is the TRUE position against the reference, RMS over the last 80 %.

use host_sim::closed_loop::runner::{run, RunOptions, Summary};
use sim_scenario::Scenario;

/// `nav-lawnmower-3d` in a 0.2 m/s current across its legs (east; the legs run north).
fn survey(bias_deg: f64) -> Scenario {
    let mut sc = Scenario::load("nav-lawnmower-3d").unwrap();
    sc.disturbance.current_m_s = [0.0, 0.2, 0.0];
    if let Some(c) = sc.sensors.compass.as_mut() {
        c.bias_rad = bias_deg.to_radians();
    }
    sc.validate().unwrap();
    sc
}

fn measure(label: &str, sc: &Scenario) -> Summary {
    let s = run(&sc.resolve().unwrap(), &RunOptions::default())
        .unwrap()
        .summary;
    println!(
        "| {label} | {:.1} cm | {:.1} cm | {:.2} | {} | {} |",
        100.0 * s.rms_position_error_last80_m,
        100.0 * s.rms_estimation_error_m,
        s.navigation.nees_in_bounds_fraction.unwrap_or(f64::NAN),
        s.navigation.usbl_fixes_rejected,
        s.verdict,
    );
    assert!(!s.nan_detected && !s.diverged, "{label}: {}", s.verdict);
    s
}

fn full_suite_with_bias(bias_deg: f64) {
    let s = measure(
        &format!("lawnmower, 0.2 m/s beam, bias {bias_deg} deg"),
        &survey(bias_deg),
    );
    assert!(
        s.rms_position_error_last80_m <= 0.10,
        "bias {bias_deg} deg: tracking {:.3} m",
        s.rms_position_error_last80_m
    );
    let nees = s.navigation.nees_in_bounds_fraction.unwrap_or(0.0);
    assert!(nees >= 0.9, "bias {bias_deg} deg: NEES share {nees:.3}");
}

#[test]
fn survey_in_beam_current_compass_bias_0_deg() {
    full_suite_with_bias(0.0);
}

#[test]
fn survey_in_beam_current_compass_bias_1_deg() {
    full_suite_with_bias(1.0);
}

#[test]
fn survey_in_beam_current_compass_bias_3_deg() {
    full_suite_with_bias(3.0);
}

#[test]
fn survey_in_beam_current_compass_bias_6_deg() {
    full_suite_with_bias(6.0);
}

#[test]
fn survey_in_beam_current_compass_bias_10_deg() {
    full_suite_with_bias(10.0);
}

#[test]
fn usbl_only_with_a_5_deg_compass_bias_within_30_cm() {
    let mut sc = Scenario::load("nav-usbl-circle-3d").unwrap();
    if let Some(c) = sc.sensors.compass.as_mut() {
        c.bias_rad = 5f64.to_radians();
    }
    let s = measure("USBL only circle, bias 5 deg", &sc);
    assert!(
        s.rms_position_error_last80_m <= 0.30,
        "tracking {:.3} m",
        s.rms_position_error_last80_m
    );
}

/// The state learns the bias itself (it does not only hide it in the heading): after the
/// survey, the estimate of a 6 deg bias is within 1 deg, and inside 3 of its own sigma.
#[test]
fn the_compass_bias_state_learns_the_bias() {
    use host_sim::closed_loop::estimator_nav::EstimatorNav;
    use host_sim::closed_loop::{run_closed_loop, CoreEndpoint};
    let sc = survey(6.0);
    let sc = sc.resolve().unwrap();
    let mut nav = EstimatorNav::for_scenario(&sc, sc.disturbance.noise_seed).unwrap();
    let mut ep = CoreEndpoint::for_scenario(&sc).unwrap();
    run_closed_loop(&sc, &RunOptions::default(), &mut nav, &mut ep).unwrap();
    let (b, sd) = nav.estimator().compass_bias_rad();
    let (b, sd) = (f64::from(b).to_degrees(), f64::from(sd).to_degrees());
    println!("compass bias 6 deg: estimated {b:.2} deg, sigma {sd:.2} deg");
    assert!((b - 6.0).abs() <= 1.0, "{b}");
    assert!((b - 6.0).abs() <= 3.0 * sd, "{b} +- {sd}");
}
