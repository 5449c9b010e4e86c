//! An unknown start. The estimator is told a launch point 5 m off and a
//! heading 30 degrees off, with the uncertainty of that (5 m, 0.6 rad); the compass and the
//! USBL fixes must bring it in. The estimate is not ready for position modes until its
//! uncertainty is below the core's threshold. Figures on the TRUE position.

use controller_core::nav::{HEADING_READY_STD_RAD, POSITION_READY_STD_M};
use host_sim::closed_loop::estimator_nav::EstimatorNav;
use host_sim::closed_loop::runner::RunOptions;
use host_sim::closed_loop::{run_closed_loop, CoreEndpoint};
use sim_scenario::Scenario;

fn unknown_start(name: &str) -> Scenario {
    let mut sc = Scenario::load(name).unwrap();
    sc.navigation.start_error_m = [3.0, -4.0];
    sc.navigation.start_heading_error_rad = 30f64.to_radians();
    sc.navigation.start_position_std_m = Some(5.0);
    sc.navigation.start_heading_std_rad = Some(0.6);
    sc.validate().unwrap();
    sc
}

fn check(name: &str) {
    let sc = unknown_start(name);
    let sc = sc.resolve().unwrap();
    let mut nav = EstimatorNav::for_scenario(&sc, sc.disturbance.noise_seed).unwrap();
    let mut ep = CoreEndpoint::for_scenario(&sc).unwrap();
    let out = run_closed_loop(
        &sc,
        &RunOptions {
            record: true,
            ..RunOptions::default()
        },
        &mut nav,
        &mut ep,
    )
    .unwrap();
    let s = &out.summary;
    assert!(!s.nan_detected && !s.diverged, "{}", s.verdict);
    let ready = nav.position_ready_at_s();
    // The tracking error and the estimation error (true position) from 120 s on.
    let after: Vec<_> = out.log.iter().filter(|x| x.t_s >= 120.0).collect();
    let rms = |f: &dyn Fn(&host_sim::closed_loop::Sample) -> f64| {
        (after.iter().map(|x| f(x).powi(2)).sum::<f64>() / after.len() as f64).sqrt()
    };
    let tracking = rms(&|x| x.pos_err_norm_m);
    let estimation = rms(&|x| {
        ((x.nav_pos_m[0] - x.state.eta[0]).powi(2) + (x.nav_pos_m[1] - x.state.eta[1]).powi(2))
            .sqrt()
    });
    let at_120 = after.first().map_or(f64::NAN, |x| {
        ((x.nav_pos_m[0] - x.state.eta[0]).powi(2) + (x.nav_pos_m[1] - x.state.eta[1]).powi(2))
            .sqrt()
    });
    println!(
        "{name}, told 5 m and 30 deg off: ready at {ready:?} s (std <= {POSITION_READY_STD_M} m, heading <= {HEADING_READY_STD_RAD} rad); from 120 s: tracking RMS {:.1} cm, estimation RMS {:.1} cm; horizontal estimation error at 120 s {:.1} cm",
        100.0 * tracking,
        100.0 * estimation,
        100.0 * at_120
    );
    let t_ready = ready.expect("never ready");
    assert!(t_ready > 0.0, "ready at once with a 5 m start");
    assert!(t_ready <= 10.0, "ready only at {t_ready} s");
    assert!(tracking <= 0.10, "tracking {tracking} m from 120 s");
    assert!(estimation <= 0.10, "estimation {estimation} m from 120 s");
}

#[test]
fn told_5_m_and_30_deg_off_the_survey_is_within_10_cm_by_120_s() {
    check("nav-lawnmower-3d");
}

#[test]
fn told_5_m_and_30_deg_off_the_circle_is_within_10_cm_by_120_s() {
    check("nav-circle-3d");
}
