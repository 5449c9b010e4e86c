//! ArduSub's joystick buttons and gain from a ground station
//! (`clients/pymavlink_buttons.py`) against `host-sim vehicle` + `rov-topside --tcp`: the
//! default `BTNn_FUNCTION` arm, change modes, step the gain once per press and disarm; a
//! replayed frame, another station's and a button held across a lapse never act; the sticks
//! reach the vehicle scaled by the gain (the tether log's `ManualThrust`).
//!
//! Without pymavlink: SKIPPED with the fix (a failure with `ROV_REQUIRE_PYMAVLINK=1`).

use crate::gcs;

use gcs::{dive, free_udp_port, pymavlink_or_skip, stop};
use std::path::PathBuf;

fn dir(name: &str) -> PathBuf {
    crate::gcs::scratch_dir(&format!("topside-gcs-{name}"))
}

pub(crate) fn the_joystick_buttons_act_once_per_press_and_the_gain_scales_the_sticks() {
    if !pymavlink_or_skip() {
        return;
    }
    let d = dir("buttons");
    let (port, port2) = (free_udp_port(), free_udp_port());
    let second = format!("udpout:127.0.0.1:{port2}");
    let flight = dive(
        "circle-3d",
        port,
        &d.join("s.tlog"),
        &d.join("params.json"),
        &["--speedup", "2", "--duration", "600", "--mavlink", &second],
    );
    let (passed, _) = gcs::run_client(
        "pymavlink_buttons.py",
        &[port.to_string(), port2.to_string()],
    );
    stop(flight);
    assert!(passed, "pymavlink_buttons.py failed");
    // The sticks full ahead at a gain of 50 %: the vehicle is sent a surge of 0.5, never more.
    let log = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "tether"))
        .expect("the surface's tether log");
    let frames = topside::tether_log::decode(&topside::tether_log::read(&log).unwrap());
    let surges: Vec<f32> = frames
        .commands
        .iter()
        .filter_map(|(_, _, c)| match c {
            protocol::Command::ManualThrust(m) if m.surge != 0.0 => Some(m.surge),
            _ => None,
        })
        .collect();
    println!(
        "{} sticks sent off centre, surge {:?}",
        surges.len(),
        surges.first()
    );
    assert!(
        surges.len() >= 10,
        "{} sticks off centre sent",
        surges.len()
    );
    assert!(
        surges.iter().all(|s| (s - 0.5).abs() < 1e-6),
        "a surge other than 0.5: {surges:?}"
    );
}
