//! What the navigation tests share: the comparison of an emulated run with its
//! software twin (`nav_hil.rs`, `nav_hil_errors.rs`) and the Monte Carlo campaign's draw of a
//! run (`nav_monte_carlo.rs`, and its twins on the emulated board in `nav_hil_errors.rs`);
//! the error of a fitted compass deviation (`nav_compass_cal_flown.rs`, `nav_hil_errors.rs`).

// Each test binary that includes this module uses part of it.
#![allow(dead_code)]

use controller_core::nav::compass_cal::CompassCalibration;
use host_sim::closed_loop::Sample;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sim_scenario::Scenario;

/// `|hil - sw| <= 10 % of sw + 1 cm` (the bound for the emulated MCU).
pub fn within_10_percent_plus_1_cm(what: &str, hil_m: f64, sw_m: f64) {
    let bound_m = 0.1 * sw_m + 0.01;
    assert!(
        (hil_m - sw_m).abs() <= bound_m,
        "{what}: HIL {hil_m} m vs software {sw_m} m (bound {bound_m} m)"
    );
}

/// RMS of `f` over the samples from `t0_s` on.
pub fn rms_from(log: &[Sample], t0_s: f64, f: impl Fn(&Sample) -> f64) -> f64 {
    let v: Vec<f64> = log.iter().filter(|x| x.t_s >= t0_s).map(f).collect();
    (v.iter().map(|e| e * e).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// Run `k` of the Monte Carlo campaign on `base`: its own noise seed and its own draw
/// of the compass bias (uniform +-5 deg), the DVL scale factor (+-1 %) and mounting yaw
/// (+-2 deg), and the launch point the estimator is told (5 m off in a random direction,
/// heading +-5 deg off, with 5 m / 0.2 rad of uncertainty). Run `k` draws from its own
/// stream, so it is the same run wherever it is flown.
pub fn drawn_run(base: &Scenario, k: u64) -> Scenario {
    let mut rng = ChaCha8Rng::seed_from_u64(0x26_0000 + k);
    let mut u = |half: f64| half * (2.0 * rng.random::<f64>() - 1.0);
    let mut sc = base.clone();
    sc.disturbance.noise_seed = 1000 + k;
    if let Some(c) = sc.sensors.compass.as_mut() {
        c.bias_rad = u(5f64.to_radians());
    }
    if let Some(d) = sc.sensors.dvl.as_mut() {
        d.scale_error = u(0.01);
        d.mounting_yaw_rad = u(2f64.to_radians());
    }
    let a = u(std::f64::consts::PI);
    sc.navigation.start_error_m = [5.0 * a.cos(), 5.0 * a.sin()];
    sc.navigation.start_heading_error_rad = u(5f64.to_radians());
    sc.navigation.start_position_std_m = Some(5.0);
    sc.navigation.start_heading_std_rad = Some(0.2);
    sc.validate().unwrap();
    sc
}

/// Worst error of the deviation curve `cal` against a hard iron `amplitude_rad * sin(psi +
/// phase_rad)` over 360 headings (deg).
pub fn worst_deviation_error_deg(
    cal: &CompassCalibration,
    amplitude_rad: f64,
    phase_rad: f64,
) -> f64 {
    (0..360)
        .map(|d| {
            let psi = f64::from(d).to_radians();
            let truth = amplitude_rad * (psi + phase_rad).sin();
            (f64::from(cal.deviation_rad(psi as f32)) - truth)
                .abs()
                .to_degrees()
        })
        .fold(0.0, f64::max)
}
