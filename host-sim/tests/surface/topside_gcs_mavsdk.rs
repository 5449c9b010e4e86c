//! MAVSDK as a third ground station (`clients/mavsdk_gcs.py`, the `mavsdk` package's native
//! binding) against `host-sim vehicle` + `rov-topside --tcp`: connect, download the
//! parameters, upload (and read back) a 3-waypoint mission and fly it (each waypoint reached
//! within 0.3 m on the served vehicle's truth), go to a global point, the motor test, disarm.
//!
//! Without the `mavsdk` package: SKIPPED with the fix (`python3 -m pip install mavsdk`), a
//! failure with `ROV_REQUIRE_PYMAVLINK=1`.

use crate::gcs;

use gcs::{dive, free_udp_port, stop};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// Is the `mavsdk` package importable? Without it: SKIPPED with the fix, or a panic when CI
/// requires the ground-station clients.
fn mavsdk_or_skip() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import mavsdk; mavsdk.Mavsdk"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        let why = "python3 with the mavsdk package (4.x) not found";
        if std::env::var("ROV_REQUIRE_PYMAVLINK").is_ok_and(|v| v == "1") {
            panic!("{why} and ROV_REQUIRE_PYMAVLINK=1; fix: python3 -m pip install mavsdk");
        }
        println!("SKIPPED: {why}; fix: python3 -m pip install mavsdk");
    }
    ok
}

/// The truth log's `x_m, y_m, z_m` rows.
fn truth_rows(path: &Path) -> Vec<[f64; 3]> {
    gcs::truth_columns(path, ["x_m", "y_m", "z_m"])
}

pub(crate) fn mavsdk_connects_reads_parameters_flies_a_mission_goes_to_a_point_tests_a_motor_and_disarms(
) {
    if !crate::long_test("topside_gcs_mavsdk::mavsdk_connects_reads_parameters_flies_a_mission_goes_to_a_point_tests_a_motor_and_disarms", 45) {
        return;
    }
    if !mavsdk_or_skip() {
        return;
    }
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("topside-gcs-mavsdk");
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let port = free_udp_port();
    let flight = dive(
        "circle-3d",
        port,
        &d.join("s.tlog"),
        &d.join("params.json"),
        &["--speedup", "2", "--duration", "1500"],
    );
    let waypoints: [[f64; 3]; 3] = [[3.0, 0.0, 2.0], [6.0, 2.0, 2.0], [8.0, 5.0, 2.5]];
    let goto = [10.0, 8.0, 2.0];
    let mut args = vec![port.to_string(), "-35.3632620".into(), "149.1652370".into()];
    for [n, e, z] in waypoints.iter().chain([&goto]) {
        args.push(format!("{n},{e},{z}"));
    }
    let (passed, _) = gcs::run_client("mavsdk_gcs.py", &args);
    let truth = flight.truth();
    stop(flight);
    assert!(passed, "mavsdk_gcs.py failed");
    let rows = truth_rows(&truth);
    let mut worst: f64 = 0.0;
    for (i, [n, e, z]) in waypoints.iter().enumerate() {
        let closest = rows
            .iter()
            .map(|r| ((r[0] - n).powi(2) + (r[1] - e).powi(2) + (r[2] - z).powi(2)).sqrt())
            .fold(f64::INFINITY, f64::min);
        println!("waypoint {i} ({n}, {e}, {z}): truth came within {closest:.3} m");
        worst = worst.max(closest);
    }
    assert!(
        worst <= 0.3,
        "a waypoint missed by {worst:.3} m on the truth"
    );
}
