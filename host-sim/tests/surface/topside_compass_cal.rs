//! The compass calibration turn started from a ground station we did not write
//! (pymavlink, `clients/pymavlink_compass_cal.py`) with ArduPilot's
//! `MAV_CMD_DO_START_MAG_CAL`, on `host-sim topside --sim` (the firmware library in process,
//! its estimator on the simulated sensors). The simulated compass has a 5 deg hard-iron
//! deviation; the fit the vehicle makes becomes `COMPASS_DEV_SIN` / `COMPASS_DEV_COS` at the
//! ground station, within 1 deg of the truth. Refused while disarmed, with the old values
//! kept. Without pymavlink: SKIPPED with the fix (a failure with `ROV_REQUIRE_PYMAVLINK=1`).

use crate::gcs;

use gcs::{dive, free_udp_port, pymavlink_or_skip, stop};
use std::path::PathBuf;

/// The simulated compass's deviation: `A sin(psi + phase)` = `A cos(phase) sin(psi) +
/// A sin(phase) cos(psi)`, so `COMPASS_DEV_SIN` = `A cos(phase)`, `COMPASS_DEV_COS` =
/// `A sin(phase)` (degrees).
const HARD_IRON_DEG: f64 = 5.0;
const PHASE_RAD: f64 = 0.7;

pub(crate) fn pymavlink_starts_the_compass_turn_and_reads_the_fit_back() {
    if !pymavlink_or_skip() {
        return;
    }
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("topside-compass-cal");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    // nav-circle-3d with that compass.
    let base = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenarios/nav-circle-3d.toml"
    ))
    .unwrap();
    let scenario = base.replace(
        "[sensors.compass]\n",
        &format!(
            "[sensors.compass]\nhard_iron_rad = {}\nhard_iron_phase_rad = {PHASE_RAD}\n",
            HARD_IRON_DEG.to_radians()
        ),
    );
    assert_ne!(scenario, base, "the scenario has a [sensors.compass] table");
    let file = dir.join("compass-cal.toml");
    std::fs::write(&file, scenario).unwrap();

    let port = free_udp_port();
    let topside = dive(
        &file,
        port,
        &dir.join("cal.tlog"),
        &dir.join("params.json"),
        &["--duration", "600", "--speedup", "4", "--start-nav"],
    );
    let (passed, stdout) = gcs::run_client(
        "pymavlink_compass_cal.py",
        &[
            port.to_string(),
            format!("{}", HARD_IRON_DEG * PHASE_RAD.cos()),
            format!("{}", HARD_IRON_DEG * PHASE_RAD.sin()),
        ],
    );
    stop(topside);
    assert!(passed, "the pymavlink client failed");
    assert_eq!(stdout.matches("PASS:").count(), 10, "every check ran");
    // The fit was saved with the other parameters (a restart restores it).
    let saved: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("params.json")).expect("parameters saved"),
    )
    .unwrap();
    let deg = |k: &str| saved[k].as_f64().unwrap_or(f64::NAN);
    let (ds, dc) = (
        deg("COMPASS_DEV_SIN") - HARD_IRON_DEG * PHASE_RAD.cos(),
        deg("COMPASS_DEV_COS") - HARD_IRON_DEG * PHASE_RAD.sin(),
    );
    assert!(ds.hypot(dc) <= 1.0, "saved: {saved}");
}
