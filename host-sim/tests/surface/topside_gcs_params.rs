//! ArduSub's health, ground-station-failsafe, pilot-speed and system-id parameters from a
//! ground station (`clients/pymavlink_health_params.py`) against `host-sim vehicle` +
//! `rov-topside --tcp`: refusals in words, the vehicle acting on a new low-voltage threshold
//! and depth limit, the values restored (and `SYSID_THISMAV` taken) at the next start, and
//! `FS_GCS_ENABLE` warn / disarm / depth hold when the station's heartbeat stops.
//!
//! Without pymavlink: SKIPPED with the fix (a failure with `ROV_REQUIRE_PYMAVLINK=1`).

use crate::gcs;

use gcs::{dive, free_udp_port, pymavlink_or_skip, stop};
use std::path::PathBuf;

fn dir(name: &str) -> PathBuf {
    crate::gcs::scratch_dir(&format!("topside-gcs-{name}"))
}

/// Run the python client in `phase`: whether it passed, and its output.
fn client(port: u16, phase: &str) -> (bool, String) {
    gcs::run_client(
        "pymavlink_health_params.py",
        &[port.to_string().as_str(), phase],
    )
}

pub(crate) fn health_parameters_are_set_refused_in_words_acted_on_and_restored_with_the_system_id()
{
    if !pymavlink_or_skip() {
        return;
    }
    let d = dir("health-params");
    let params = d.join("params.json");
    let port = free_udp_port();
    let flight = dive(
        "circle-3d",
        port,
        &d.join("s.tlog"),
        &params,
        &["--duration", "600"],
    );
    let (passed, _) = client(port, "set");
    stop(flight);
    assert!(passed, "pymavlink_health_params.py set failed");
    let saved = std::fs::read_to_string(&params).unwrap();
    let map: std::collections::BTreeMap<String, f32> = serde_json::from_str(&saved).unwrap();
    assert_eq!(map.get("DEPTH_LIMIT_M"), Some(&2.0), "{saved}");
    assert_eq!(map.get("BATT_LOW_VOLT"), Some(&30.0), "{saved}");
    assert_eq!(map.get("SYSID_THISMAV"), Some(&2.0), "{saved}");

    // The next start: a fresh vehicle, the saved file.
    let port = free_udp_port();
    let flight = dive(
        "circle-3d",
        port,
        &d.join("s2.tlog"),
        &params,
        &["--duration", "600"],
    );
    let (passed, _) = client(port, "restart");
    stop(flight);
    assert!(passed, "pymavlink_health_params.py restart failed");
}

pub(crate) fn the_ground_station_failsafe_warns_disarms_and_holds_depth_when_its_heartbeat_stops() {
    if !pymavlink_or_skip() {
        return;
    }
    let d = dir("fs-gcs");
    let port = free_udp_port();
    let flight = dive(
        "circle-3d",
        port,
        &d.join("s.tlog"),
        &d.join("params.json"),
        &["--duration", "600"],
    );
    let (passed, out) = client(port, "gcs");
    stop(flight);
    assert!(passed, "pymavlink_health_params.py gcs failed");
    let after: f64 = out
        .lines()
        .find_map(|l| l.strip_prefix("FS_GCS disarm after "))
        .and_then(|l| l.trim_end_matches(" s").parse().ok())
        .expect("the disarm's delay printed");
    // FS_GCS_TIMEOUT 2 s after the last heartbeat, within the client's 0.1 s polling and a
    // loaded machine's scheduling.
    assert!(
        (1.9..=6.0).contains(&after),
        "disarmed {after:.2} s after the last heartbeat"
    );
}

pub(crate) fn pilot_speed_dn_bounds_the_descent_the_heave_stick_asks_in_alt_hold() {
    if !crate::long_test(
        "topside_gcs_params::pilot_speed_dn_bounds_the_descent_the_heave_stick_asks_in_alt_hold",
        30,
    ) {
        return;
    }
    if !pymavlink_or_skip() {
        return;
    }
    let d = dir("pilot-speed");
    let port = free_udp_port();
    let flight = dive(
        "circle-3d",
        port,
        &d.join("s.tlog"),
        &d.join("params.json"),
        &["--duration", "600"],
    );
    let (passed, out) = client(port, "pilot");
    stop(flight);
    assert!(passed, "pymavlink_health_params.py pilot failed");
    let rate = |which: &str| -> f64 {
        out.lines()
            .find_map(|l| l.strip_prefix(&format!("RATE {which} ")))
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("no {which} rate printed"))
    };
    let (limited, free) = (rate("limited"), rate("free"));
    println!("full stick down in ALT_HOLD: {limited:.3} m/s (PILOT_SPEED_DN 20 cm/s, 0.10 m/s asked at gain 0.5), {free:.3} m/s (500 cm/s)");
    // 0.10 m/s asked: at most that with a margin for the telemetry's delay, still descending.
    assert!(
        (0.02..=0.13).contains(&limited),
        "{limited:.3} m/s with 0.10 m/s asked"
    );
    assert!(
        free > 1.5 * limited,
        "{free:.3} m/s free against {limited:.3} m/s limited"
    );
}
