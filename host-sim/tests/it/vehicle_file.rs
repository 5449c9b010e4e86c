//! Vehicle files: `host-sim run` flies another vehicle given by the scenario key `vehicle`,
//! and a vehicle the laws would not be safe on is refused by name.

use host_sim::closed_loop::runner::run;
use host_sim::closed_loop::RunOptions;
use sim_scenario::vehicle::OBSERVER_TOML;
use sim_scenario::Scenario;
use std::path::PathBuf;

const CIRCLE: &str = r#"
name = "heavy-circle"
plane = "3d"
controller = "tracking"
duration_s = 80.0
vehicle = "heavy.toml"
[reference]
kind = "circle"
center_m = [0.0, 5.0, 2.0]
radius_m = 5.0
speed_m_s = 0.25
[initial]
z_m = 2.0
[thrusters]
saturate = true
"#;

fn dir(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A vehicle 40 % heavier (1.5 N buoyant), with stronger and slower thrusters.
fn heavy() -> String {
    OBSERVER_TOML
        .replace("mass_kg = 10.84", "mass_kg = 15.2")
        .replace("i_z_kg_m2 = 0.2", "i_z_kg_m2 = 0.3")
        .replace("buoyancy_offset_n = 0.0", "buoyancy_offset_n = 1.5")
        .replace("thrust_max_forward_n = 20.0", "thrust_max_forward_n = 25.0")
        .replace(
            "thruster_time_constant_s = 0.1",
            "thruster_time_constant_s = 0.15",
        )
}

#[test]
fn a_scenario_flies_the_vehicle_its_file_describes() {
    let d = dir("vehicle-file-heavy");
    std::fs::write(d.join("heavy.toml"), heavy()).unwrap();
    let path = d.join("heavy-circle.toml");
    std::fs::write(&path, CIRCLE).unwrap();
    let sc = Scenario::load(path.to_str().unwrap()).unwrap();
    assert_eq!(sc.vehicle_params.mass_kg, 15.2);
    assert_eq!(sc.vehicle_params.thrust_max_forward_n, 25.0);
    let heavy = run(&sc.resolve().unwrap(), &RunOptions::default())
        .unwrap()
        .summary;

    let observer =
        Scenario::from_toml(&CIRCLE.replace("vehicle = \"heavy.toml\"\n", ""), "o").unwrap();
    let light = run(&observer.resolve().unwrap(), &RunOptions::default())
        .unwrap()
        .summary;
    eprintln!(
        "heavy: tail RMS {:.4} m, max after 10 s {:.4} m, max thrust {:.2} N; observer: {:.4} m, {:.2} N",
        heavy.rms_position_error_tail_m,
        heavy.max_position_error_after_10s_m,
        heavy.max_abs_thruster_force_n,
        light.rms_position_error_tail_m,
        light.max_abs_thruster_force_n
    );
    assert!(!heavy.nan_detected && !heavy.diverged);
    // The laws use the file's model, so the heavier vehicle tracks like the light one.
    assert!(heavy.rms_position_error_tail_m < 0.01, "{heavy:?}");
    assert!(heavy.max_position_error_after_10s_m < 0.05, "{heavy:?}");
    assert!(heavy.max_abs_thruster_force_n <= 25.0 + 1e-6);
    // And it is another body: holding 1.5 N of buoyancy and more mass takes other thrust.
    assert!((heavy.max_abs_thruster_force_n - light.max_abs_thruster_force_n).abs() > 0.05);
}

#[test]
fn a_vehicle_the_laws_are_not_safe_on_is_refused_by_name() {
    let d = dir("vehicle-file-bad");
    std::fs::write(
        d.join("heavy.toml"),
        OBSERVER_TOML.replace("buoyancy_offset_n = 0.0", "buoyancy_offset_n = 8.0"),
    )
    .unwrap();
    let path = d.join("bad.toml");
    std::fs::write(&path, CIRCLE).unwrap();
    let e = format!("{:#}", Scenario::load(path.to_str().unwrap()).unwrap_err());
    assert!(
        e.contains("vehicle") && e.contains("buoyancy_offset_n"),
        "{e}"
    );
    let e = format!(
        "{:#}",
        Scenario::from_toml(&CIRCLE.replace("heavy.toml", "no-such-file.toml"), "s").unwrap_err()
    );
    assert!(e.contains("no-such-file.toml"), "{e}");
}
