//! The sensors' real errors are simulated as specified, and implausible ones
//! are refused with the key named.

use sim_scenario::Scenario;
use sim_world::plant::PlantState;
use sim_world::sensor_sim::SensorSuite;
use sim_world::sensors::{CompassSpec, DvlSpec, Measurement, SensorsSpec, UsblSpec};

fn state(psi_rad: f64, uv_m_s: [f64; 2]) -> PlantState {
    PlantState {
        eta: [1.0, 2.0, 3.0, 0.0, 0.0, psi_rad],
        nu: [uv_m_s[0], uv_m_s[1], 0.0, 0.0, 0.0, 0.0],
    }
}

/// Every measurement the suite makes over `t` seconds at 1 kHz on a constant state.
fn sample(
    spec: &SensorsSpec,
    truth: &PlantState,
    thrust_n: [f64; 3],
    t: f64,
) -> Vec<(f64, Measurement)> {
    let mut suite = SensorSuite::new(spec, 3);
    suite.set_thrust_n(thrust_n);
    let mut out = Vec::new();
    let mut k = 1;
    while k as f64 * 1e-3 <= t + 1e-9 {
        suite.sample(k as f64 * 1e-3, truth, &mut out);
        k += 1;
    }
    out
}

fn wrap(a: f64) -> f64 {
    (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
}

#[test]
fn a_biased_compass_reads_bias_plus_hard_iron_sine_plus_thrust_offset() {
    let compass = CompassSpec {
        noise_rad: 0.02,
        bias_rad: 3f64.to_radians(),
        hard_iron_rad: 5f64.to_radians(),
        hard_iron_phase_rad: 0.7,
        thrust_offset_rad_per_n: 0.1f64.to_radians(),
        ..CompassSpec::default()
    };
    let spec = SensorsSpec {
        compass: Some(compass),
        ..SensorsSpec::default()
    };
    for psi in [-2.5, -1.0, 0.0, 0.4, 1.6, 3.0] {
        for thrust in [[0.0, 0.0, 0.0], [10.0, -5.0, 4.0]] {
            let out = sample(&spec, &state(psi, [0.0; 2]), thrust, 100.0);
            let errs: Vec<f64> = out
                .iter()
                .filter_map(|(_, m)| match m {
                    Measurement::Heading(h) => Some(wrap(f64::from(h.yaw_rad) - psi)),
                    _ => None,
                })
                .collect();
            assert_eq!(errs.len(), 1000, "10 Hz for 100 s");
            let mean = errs.iter().sum::<f64>() / errs.len() as f64;
            let sd =
                (errs.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / errs.len() as f64).sqrt();
            let effort: f64 = thrust.iter().map(|f: &f64| f.abs()).sum();
            let expected = 3f64.to_radians()
                + 5f64.to_radians() * (psi + 0.7).sin()
                + 0.1f64.to_radians() * effort;
            // The mean of 1000 draws of 0.02 rad noise is within 4 sigma = 2.5 mrad.
            assert!(
                (mean - expected).abs() < 2.5e-3,
                "psi {psi} thrust {thrust:?}: mean error {mean} expected {expected}"
            );
            assert!((sd - 0.02).abs() < 0.002, "noise sd {sd}");
        }
    }
}

#[test]
fn dvl_scale_and_mounting_yaw_and_usbl_bias_and_jitter_are_simulated() {
    let spec = SensorsSpec {
        dvl: Some(DvlSpec {
            noise_m_s: 0.0,
            scale_error: 0.02,
            mounting_yaw_rad: 0.1,
            ..DvlSpec::default()
        }),
        usbl: Some(UsblSpec {
            noise_m: 0.0,
            bias_m: [0.5, -0.25],
            latency_jitter_s: 0.3,
            ..UsblSpec::default()
        }),
        ..SensorsSpec::default()
    };
    let out = sample(&spec, &state(0.3, [0.4, 0.1]), [0.0; 3], 50.0);
    let (s, c) = 0.1f64.sin_cos();
    let want = [1.02 * (c * 0.4 + s * 0.1), 1.02 * (-s * 0.4 + c * 0.1)];
    let mut latencies = Vec::new();
    for (arrival, m) in &out {
        match m {
            Measurement::Dvl(d) => {
                for (got, want) in d.velocity_m_s.iter().zip(want) {
                    assert!((f64::from(*got) - want).abs() < 1e-6);
                }
            }
            Measurement::Position(p, _) => {
                assert!((f64::from(p.north_m) - 1.5).abs() < 1e-6);
                assert!((f64::from(p.east_m) - 1.75).abs() < 1e-6);
                latencies.push(arrival - p.t_us as f64 * 1e-6);
            }
            _ => {}
        }
    }
    assert_eq!(latencies.len(), 50);
    let lo = latencies.iter().copied().fold(f64::MAX, f64::min);
    let hi = latencies.iter().copied().fold(f64::MIN, f64::max);
    assert!(lo >= 0.5 - 1e-9 && hi <= 0.8 + 1e-9, "latency {lo}..{hi}");
    assert!(hi - lo > 0.2, "jitter spread {}", hi - lo);
}

fn refused(extra: &str) -> String {
    let text = format!(
        "name = \"x\"\nplane = \"3d\"\ncontroller = \"tracking\"\nduration_s = 10.0\n\
         [reference]\nkind = \"circle\"\ncenter_m = [0.0, 5.0, 2.0]\nradius_m = 5.0\nspeed_m_s = 0.25\n\
         [navigation]\nsource = \"estimator\"\n[sensors.imu]\n[sensors.depth]\n{extra}\n[sensors.usbl]\n"
    );
    match Scenario::from_toml(&text, "test") {
        Ok(_) => String::new(),
        Err(e) => format!("{e:#}"),
    }
}

#[test]
fn implausible_compass_and_dvl_errors_are_refused_with_the_key_named() {
    assert_eq!(
        refused("[sensors.compass]\nbias_rad = 0.5\n[sensors.dvl]\nscale_error = 0.05"),
        ""
    );
    for (extra, key) in [
        (
            "[sensors.compass]\nbias_rad = 0.6\n[sensors.dvl]",
            "sensors.compass.bias_rad",
        ),
        (
            "[sensors.compass]\nhard_iron_rad = -0.6\n[sensors.dvl]",
            "sensors.compass.hard_iron_rad",
        ),
        (
            "[sensors.compass]\nthrust_offset_rad_per_n = 0.01\n[sensors.dvl]",
            "sensors.compass.thrust_offset_rad_per_n",
        ),
        (
            "[sensors.compass]\n[sensors.dvl]\nscale_error = 0.11",
            "sensors.dvl.scale_error",
        ),
        (
            "[sensors.compass]\n[sensors.dvl]\nmounting_yaw_rad = 0.7",
            "sensors.dvl.mounting_yaw_rad",
        ),
    ] {
        let e = refused(extra);
        assert!(e.contains(key), "{extra}: {e}");
    }
}
