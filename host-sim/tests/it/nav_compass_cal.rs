//! The compass swing. The vehicle turns a full circle in place; the simulated
//! compass (5 deg hard-iron deviation, a thrust-dependent offset, its noise) and gyro (its
//! drawn bias) feed `CompassSwing`; the fitted deviation must be within 1 deg of the truth at
//! every heading. Then the survey is flown with that calibration applied to the compass.
//! Figures on the TRUE position.

use controller_core::nav::compass_cal::{CalRefusal, CompassCalibration, CompassSwing};
use host_sim::closed_loop::runner::{run, RunOptions};
use sim_scenario::Scenario;
use sim_world::plant::PlantState;
use sim_world::sensor_sim::SensorSuite;
use sim_world::sensors::{CompassSpec, ImuSpec, Measurement, SensorsSpec};

const HARD_IRON_RAD: f64 = 0.0873; // 5 deg
const PHASE_RAD: f64 = 0.7;
/// 2 deg at 10 N of summed thrust.
const THRUST_OFFSET_RAD_PER_N: f64 = 0.00349;

fn compass() -> CompassSpec {
    CompassSpec {
        hard_iron_rad: HARD_IRON_RAD,
        hard_iron_phase_rad: PHASE_RAD,
        thrust_offset_rad_per_n: THRUST_OFFSET_RAD_PER_N,
        ..CompassSpec::default()
    }
}

/// A turn in place at `rate` rad/s for `seconds`: the gyro's rates and the compass's
/// readings into a swing.
fn swing(rate: f64, seconds: f64) -> CompassSwing {
    let spec = SensorsSpec {
        imu: Some(ImuSpec::default()),
        compass: Some(compass()),
        ..SensorsSpec::default()
    };
    let mut suite = SensorSuite::new(&spec, 11);
    // The turning torque: the two horizontal thrusters 2 N each, opposite.
    suite.set_thrust_n([2.0, -2.0, 0.0]);
    let mut s = CompassSwing::new();
    let mut out = Vec::new();
    let mut last_imu_s = 0.0;
    let n = (seconds * 1000.0) as u64;
    for k in 1..=n {
        let t = k as f64 * 1e-3;
        let truth = PlantState {
            eta: [0.0, 0.0, 2.0, 0.0, 0.0, 0.3 + rate * t],
            nu: [0.0, 0.0, 0.0, 0.0, 0.0, rate],
        };
        suite.sample(t, &truth, &mut out);
        for (_, m) in out.drain(..) {
            match m {
                Measurement::Imu(i) => {
                    let ts = i.t_us as f64 * 1e-6;
                    s.rate(i.gyro_rad_s[2], (ts - last_imu_s) as f32);
                    last_imu_s = ts;
                }
                Measurement::Heading(h) => s.reading(h.yaw_rad),
                _ => {}
            }
        }
    }
    s
}

fn worst_error_deg(cal: &CompassCalibration) -> f64 {
    (0..360)
        .map(|d| {
            let psi = f64::from(d).to_radians();
            let truth = HARD_IRON_RAD * (psi + PHASE_RAD).sin();
            (f64::from(cal.deviation_rad(psi as f32)) - truth)
                .abs()
                .to_degrees()
        })
        .fold(0.0, f64::max)
}

fn calibrated() -> CompassCalibration {
    let (cal, residual) = swing(0.25, 30.0).fit().unwrap();
    println!(
        "swing 0.25 rad/s x 30 s: fitted sin {:.4} cos {:.4} rad (truth {:.4}, {:.4}), residual {:.4} rad, worst error {:.2} deg",
        cal.sin_rad,
        cal.cos_rad,
        HARD_IRON_RAD * PHASE_RAD.cos(),
        HARD_IRON_RAD * PHASE_RAD.sin(),
        residual,
        worst_error_deg(&cal)
    );
    cal
}

#[test]
fn a_full_swing_fits_the_deviation_within_1_deg_and_a_short_one_is_refused() {
    let cal = calibrated();
    assert!(worst_error_deg(&cal) <= 1.0);
    assert_eq!(swing(0.25, 20.0).fit(), Err(CalRefusal::NotFullTurn));
}

fn survey(cal: Option<CompassCalibration>) -> f64 {
    let mut sc = Scenario::load("nav-lawnmower-3d").unwrap();
    sc.disturbance.current_m_s = [0.0, 0.2, 0.0];
    sc.sensors.compass = Some(compass());
    sc.navigation.compass_calibration = cal.map(|c| [f64::from(c.sin_rad), f64::from(c.cos_rad)]);
    sc.validate().unwrap();
    let s = run(&sc.resolve().unwrap(), &RunOptions::default())
        .unwrap()
        .summary;
    println!(
        "survey, 0.2 m/s beam current, hard iron 5 deg + 2 deg at 10 N, calibration {}: tracking {:.1} cm, estimation {:.1} cm, NEES {:.2}",
        if cal.is_some() { "applied" } else { "none" },
        100.0 * s.rms_position_error_last80_m,
        100.0 * s.rms_estimation_error_m,
        s.navigation.nees_in_bounds_fraction.unwrap_or(f64::NAN)
    );
    assert!(!s.nan_detected && !s.diverged, "{}", s.verdict);
    s.rms_position_error_last80_m
}

#[test]
fn the_survey_after_the_swing_tracks_within_10_cm() {
    let without = survey(None);
    let with = survey(Some(calibrated()));
    println!(
        "without {:.1} cm, with {:.1} cm",
        100.0 * without,
        100.0 * with
    );
    assert!(with <= 0.10, "{with}");
}
