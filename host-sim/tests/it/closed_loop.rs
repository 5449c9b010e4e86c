//! Closed loop through the f32 core on the built-in paper scenarios, and the runner's
//! mechanics (step counts, measurement delay and noise, divergence stop).
//!
//! The bounds on the paper laws are the numbers measured with `cargo run -p host-sim
//! --release` (see the report in `docs/` / README), with a margin.

use host_sim::closed_loop::runner::{run, RunOptions, Summary};
use host_sim::closed_loop::{Navigation, TruthNav};
use sim_scenario::{NoiseStd, Scenario};
use sim_world::plant::PlantState;

fn run_builtin(name: &str) -> Summary {
    let sc = Scenario::load(name).unwrap();
    run(&sc.resolve().unwrap(), &RunOptions::default())
        .unwrap()
        .summary
}

#[test]
fn paper_xy_law_tracks_the_paper_reference_below_1_cm() {
    let s = run_builtin("paper-xy");
    assert!(!s.diverged && !s.nan_detected, "{s:?}");
    assert!(
        s.final_position_error_m < 0.01,
        "final {}",
        s.final_position_error_m
    );
    assert!(
        s.max_position_error_m < 0.01,
        "max {}",
        s.max_position_error_m
    );
    // ... but only with thrusters no real vehicle has: the initial yaw request is far beyond
    // the pair's 4.2 N m.
    assert!(
        s.max_abs_requested_force[1] > 10.0,
        "{:?}",
        s.max_abs_requested_force
    );
}

#[test]
fn paper_xz_law_does_not_track_x() {
    // Measured verdict (MODEL_NOTES section 5 predicted it): with unlimited thrusters the
    // paper's XZ law diverges (measured: thrust command > 10 kN at t = 45.9 s, the pitch
    // error having grown past 1.8 rad); with the real limits it wanders metres off the
    // reference (measured: final 23.7 m, last-20 % RMS 22.0 m, 33.5 m at most after 10 s,
    // swinging +-30 m at up to 2.6 m/s): it has run away.
    let s = run_builtin("paper-xz");
    assert!(s.diverged, "{s:?}");
    assert!(!s.nan_detected);
    assert!(
        s.simulated_s > 20.0,
        "it follows for a while: {}",
        s.simulated_s
    );
    let s = run_builtin("paper-xz-saturated");
    assert!(!s.nan_detected && s.diverged, "{s:?}");
    assert_eq!(s.rule.as_ref().map(|r| r.name.as_str()), Some("runaway"));
    assert!(s.targets.as_ref().is_some_and(|t| t.met), "{s:?}");
    assert!(s.rms_position_error_tail_m > 5.0, "{s:?}");
    assert!(s.max_abs_thruster_force_n <= 20.0 + 1e-4);
}

#[test]
fn paper_xy_law_with_real_thrusters_keeps_a_sideways_offset() {
    // Measured: the initial yaw request saturates the pair, the vehicle leaves the line
    // sideways, and the paper's law never removes that cross-track offset (final 0.49 m).
    let s = run_builtin("paper-xy-saturated");
    assert!(!s.nan_detected && !s.diverged, "{s:?}");
    assert!(
        s.final_position_error_m > 0.1 && s.final_position_error_m < 1.0,
        "{s:?}"
    );
    assert!(s.max_abs_thruster_force_n <= 20.0 + 1e-4);
    assert!(s.saturated_fraction > 0.0);
}

#[test]
fn runner_counts_steps_and_holds_the_command() {
    let sc = Scenario::from_toml(
        "name = \"n\"\nplane = \"xy\"\ncontroller = \"paper\"\nduration_s = 2.0\ncontrol_period_s = 0.02\nplant_dt_s = 0.002\n[reference]\nkind = \"hold\"\n",
        "n",
    )
    .unwrap();
    let out = run(
        &sc.resolve().unwrap(),
        &RunOptions {
            record: true,
            ..RunOptions::default()
        },
    )
    .unwrap();
    assert_eq!(out.summary.sim_steps, 1000);
    assert_eq!(out.summary.control_steps, 101);
    assert_eq!(out.log.len(), 101);
    assert!((out.log[100].t_s - 2.0).abs() < 1e-12);
    assert_eq!(out.summary.stop_reason, "completed");
}

#[test]
fn runner_stops_on_divergence() {
    let sc = Scenario::from_toml(
        "name = \"d\"\nplane = \"xz\"\ncontroller = \"paper\"\nduration_s = 10.0\n[reference]\nkind = \"hold\"\n[initial]\nu_m_s = 500.0\n",
        "d",
    )
    .unwrap();
    let s = run(&sc.resolve().unwrap(), &RunOptions::default())
        .unwrap()
        .summary;
    assert!(s.diverged, "{s:?}");
    assert!(s.stop_reason.contains("velocity"), "{}", s.stop_reason);
    assert!(s.sim_steps < 100);
}

#[test]
fn sensor_delays_by_whole_plant_steps() {
    let at = |x: f64| PlantState {
        eta: [x, 0.0, 0.0, 0.0, 0.0, 0.0],
        ..PlantState::default()
    };
    let mut s = TruthNav::new(at(-1.0), 10, None, 1);
    for k in 0..10 {
        s.observe(0.0, &at(k as f64));
        assert_eq!(
            s.measure().x_m,
            -1.0,
            "initial state until the delay has passed"
        );
    }
    for k in 10..30 {
        s.observe(0.0, &at(k as f64));
        assert_eq!(s.measure().x_m, (k - 10) as f32);
    }
    let mut s0 = TruthNav::new(at(0.0), 0, None, 1);
    s0.observe(0.0, &at(5.0));
    assert_eq!(s0.measure().x_m, 5.0);
}

#[test]
fn sensor_noise_has_the_configured_spread_and_is_seeded() {
    let std = NoiseStd {
        position_m: 0.1,
        angle_rad: 0.01,
        velocity_m_s: 0.05,
        rate_rad_s: 0.02,
    };
    let mut a = TruthNav::new(PlantState::default(), 0, Some(std), 9);
    let mut b = TruthNav::new(PlantState::default(), 0, Some(std), 9);
    let n = 20_000;
    let (mut sx, mut sxx, mut sr) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..n {
        let m = a.measure();
        assert_eq!(m, b.measure(), "same seed, same noise");
        sx += f64::from(m.x_m);
        sxx += f64::from(m.x_m).powi(2);
        sr += f64::from(m.r_rad_s).powi(2);
    }
    let mean = sx / n as f64;
    let sd = (sxx / n as f64 - mean * mean).sqrt();
    assert!(mean.abs() < 0.005, "mean {mean}");
    assert!((sd - 0.1).abs() < 0.005, "sd {sd}");
    assert!(((sr / n as f64).sqrt() - 0.02).abs() < 0.001);
}

#[test]
fn a_run_writes_summary_csv_and_figures() {
    let sc = Scenario::from_toml(
        "name = \"w\"\nplane = \"xz\"\ncontroller = \"paper\"\nduration_s = 3.0\n[reference]\nkind = \"paper\"\nt_f_s = 40.0\n",
        "w",
    )
    .unwrap();
    let out = run(
        &sc.resolve().unwrap(),
        &RunOptions {
            record: true,
            ..RunOptions::default()
        },
    )
    .unwrap();
    let dir = std::env::temp_dir().join(format!("host-sim-test-{}", std::process::id()));
    host_sim::output::write_run(&dir, &out).unwrap();
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    for key in [
        "scenario",
        "plane",
        "controller",
        "final_position_error_m",
        "max_position_error_m",
        "rms_position_error_m",
        "rms_position_error_tail_m",
        "final_angle_error_rad",
        "max_abs_thruster_force_n",
        "saturated_fraction",
        "diverged",
        "nan_detected",
        "sim_steps",
        "wall_time_s",
        "verdict",
    ] {
        assert!(json.get(key).is_some(), "summary.json lacks {key}");
    }
    let csv = std::fs::read_to_string(dir.join("timeseries.csv")).unwrap();
    let mut lines = csv.lines();
    let header = lines.next().unwrap();
    assert_eq!(
        header.split(',').count(),
        host_sim::output::CSV_COLUMNS.len()
    );
    assert_eq!(lines.count(), out.log.len());
    for fig in [
        "fig_errors.png",
        "fig_velocity_errors.png",
        "fig_trajectory.png",
        "fig_positions.png",
        "fig_thrusters.png",
    ] {
        let bytes = std::fs::read(dir.join(fig)).unwrap();
        assert_eq!(&bytes[1..4], b"PNG", "{fig}");
        assert!(bytes.len() > 10_000, "{fig} looks empty");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn three_d_runs_in_bad_water_stay_finite_and_within_limits() {
    // Runner mechanics on the 6-DOF plant with current, buoyancy offset, noise and delay
    // (tracking accuracy is asserted by the tracking law's own tests).
    let mut sc = Scenario::load("current-3d").unwrap();
    sc.duration_s = 20.0;
    let s = run(&sc.resolve().unwrap(), &RunOptions::default())
        .unwrap()
        .summary;
    assert!(!s.nan_detected && !s.diverged, "{s:?}");
    // On the truth path the plant steps once a 10 ms control period (RunSetup::plant_steps).
    assert_eq!(s.sim_steps, 2_000);
    assert!(s.max_abs_thruster_force_n <= 20.0 + 1e-4);
    assert!(s.final_position_error_m < 5.0, "{s:?}");
}
