//! Ground stations as they are: what pymavlink, MAVProxy and a `mavlink`-crate station send
//! by default, against `host-sim vehicle` + `rov-topside --tcp` (the path of a real dive).
//!
//! - `--vehicle` flown whatever a saved parameter file holds, said at start.
//! - What QGroundControl asks at connection (`AUTOPILOT_VERSION`, `HOME_POSITION`,
//!   `REQUEST_MESSAGE`, `SET_MESSAGE_INTERVAL`, `SYSTEM_TIME`, `EKF_STATUS_REPORT`), go-to in
//!   every frame, and every refusal in words (`clients/pymavlink_gcs.py`).
//! - MAVProxy's `wp load` of a local- and a global-frame file with its default settings,
//!   flown in AUTO and checked against the served vehicle's truth log; `guided` (both ways)
//!   and `position` (`clients/mavproxy_gcs.py`).
//!
//! Without pymavlink or MAVProxy: SKIPPED with the fix (a failure with
//! `ROV_REQUIRE_PYMAVLINK=1`).

use crate::gcs;

use gcs::{dive, free_udp_port, pymavlink_or_skip, run_client as client, stop, wait};
use mavlink::dialects::ardupilotmega::{MavMessage, PARAM_REQUEST_READ_DATA};
use mavlink::{MavConnection, MavHeader};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

/// Simulated time per wall time (the debug surface program keeps its tether heartbeat at 2x).
const SPEEDUP: &str = "2";

fn dir(name: &str) -> PathBuf {
    crate::gcs::scratch_dir(&format!("topside-gcs-{name}"))
}

/// A word an operator cannot read: an internal name in CamelCase (`NoReference`,
/// `OutOfRange`): a capital, a small letter, then another capital (`NaN` excepted).
fn internal_name(text: &str) -> Option<&str> {
    text.split(|c: char| !c.is_ascii_alphanumeric() && c != '_')
        .find(|w| {
            let b = w.as_bytes();
            *w != "NaN"
                && b.first().is_some_and(u8::is_ascii_uppercase)
                && b.windows(2)
                    .any(|p| p[0].is_ascii_lowercase() && p[1].is_ascii_uppercase())
        })
}

pub(crate) fn the_vehicle_given_wins_over_a_saved_parameter_file_and_the_start_says_so() {
    let d = dir("vehicle-wins");
    let params = d.join("params.json");
    // A saved file from another vehicle: its mass, and a gain the operator set.
    std::fs::write(&params, r#"{"VEH_MASS": 12.5, "TRK_XY_KP": 0.9}"#).unwrap();
    let port = free_udp_port();
    let station =
        mavlink::connect::<MavMessage>(&format!("udpin:127.0.0.1:{port}")).expect("udpin");
    let light = concat!(env!("CARGO_MANIFEST_DIR"), "/../vehicles/light.toml");
    let flight = dive(
        "circle-3d",
        port,
        &d.join("s.tlog"),
        &params,
        &["--speedup", SPEEDUP, "--vehicle", light, "--duration", "60"],
    );
    let mut texts = Vec::new();
    let mut text_of = |m: &MavMessage| match m {
        MavMessage::STATUSTEXT(s) => {
            let t: String = s
                .text
                .iter()
                .take_while(|&&b| b != 0)
                .map(|&b| char::from(b))
                .collect();
            texts.push(t.clone());
            Some(t)
        }
        _ => None,
    };
    let start = wait(&station, Duration::from_secs(30), |m| {
        text_of(m).filter(|t| t.starts_with("Flying"))
    });
    // The rest of the start line (a text of 50 characters a message).
    let _ = wait(&station, Duration::from_secs(2), |m| {
        text_of(m).filter(|t| t.contains("restored)"))
    });
    let read = |name: &str| {
        let h = MavHeader {
            system_id: 255,
            component_id: 190,
            sequence: 0,
        };
        station
            .send(
                &h,
                &MavMessage::PARAM_REQUEST_READ(PARAM_REQUEST_READ_DATA {
                    param_index: -1,
                    target_system: 1,
                    target_component: 1,
                    param_id: name.into(),
                }),
            )
            .unwrap();
        wait(&station, Duration::from_secs(10), |m| match m {
            MavMessage::PARAM_VALUE(p) if p.param_id.to_str().ok() == Some(name) => {
                Some(p.param_value)
            }
            _ => None,
        })
    };
    let mass = read("VEH_MASS");
    let kp = read("TRK_XY_KP");
    stop(flight);
    println!("texts: {texts:?}\nVEH_MASS {mass:?}, TRK_XY_KP {kp:?}");
    let start = start.expect("a start line naming the vehicle");
    // STATUSTEXT carries 50 characters a message: the start is split between words.
    let said = texts.join(" ");
    assert!(said.contains("light.toml"), "{said}");
    assert!(said.contains("params.json"), "{said}");
    assert!(
        said.contains("--vehicle") && said.contains("not restored"),
        "{said}"
    );
    assert!(start.starts_with("Flying the vehicle of"), "{start}");
    assert_eq!(
        mass,
        Some(7.05),
        "the light vehicle's mass, not the saved 12.5"
    );
    assert_eq!(kp, Some(0.9), "the saved gain is restored");
}

/// Every `STATUSTEXT` a client printed (`TEXT: ...`), none with an internal name.
fn texts_in_words(stdout: &str) -> Vec<&str> {
    let texts: Vec<&str> = stdout
        .lines()
        .filter_map(|l| l.strip_prefix("TEXT: "))
        .collect();
    for t in &texts {
        assert!(internal_name(t).is_none(), "an internal name in {t:?}");
    }
    texts
}

pub(crate) fn a_ground_station_gets_what_it_asks_at_connection_goes_to_points_and_reads_refusals_in_words(
) {
    if !crate::long_test("topside_gcs::a_ground_station_gets_what_it_asks_at_connection_goes_to_points_and_reads_refusals_in_words", 55) {
        return;
    }
    if !pymavlink_or_skip() {
        return;
    }
    let d = dir("pymavlink");
    let port = free_udp_port();
    let flight = dive(
        "circle-3d",
        port,
        &d.join("s.tlog"),
        &d.join("params.json"),
        &["--speedup", SPEEDUP, "--duration", "900"],
    );
    let (passed, out) = client("pymavlink_gcs.py", &[port.to_string()]);
    stop(flight);
    assert!(passed, "pymavlink_gcs.py failed");
    let texts = texts_in_words(&out);
    let refusals = texts.iter().filter(|t| t.contains("refused")).count();
    println!(
        "{} status texts, {refusals} refusals, none with an internal name",
        texts.len()
    );
    assert!(refusals >= 12, "{refusals} refusals seen");
    assert_eq!(out.lines().filter(|l| l.starts_with("FAIL:")).count(), 0);
}

pub(crate) fn mavproxy_flies_local_and_global_missions_and_its_guided_and_position_commands() {
    if !crate::long_test("topside_gcs::mavproxy_flies_local_and_global_missions_and_its_guided_and_position_commands", 100) {
        return;
    }
    if !pymavlink_or_skip() {
        return;
    }
    if Command::new("mavproxy.py")
        .arg("--version")
        .output()
        .is_err()
    {
        println!("SKIPPED: mavproxy.py not found; fix: python3 -m pip install MAVProxy");
        return;
    }
    let d = dir("mavproxy");
    let port = free_udp_port();
    let watch = free_udp_port();
    let watch_arg = format!("udpout:127.0.0.1:{watch}");
    let flight = dive(
        "circle-3d",
        port,
        &d.join("s.tlog"),
        &d.join("params.json"),
        &[
            "--speedup",
            SPEEDUP,
            "--duration",
            "1200",
            "--mavlink",
            &watch_arg,
        ],
    );
    let origin = topside::surface::GlobalOrigin::from_mavlink(-353_632_620, 1_491_652_370, 0)
        .expect("an origin on the globe");
    // A survey line with gentle turns (the path cuts a corner by r (1/cos(turn/2) - 1) with
    // its 1.5 m arcs: 0.12 m at 45 degrees), local then global.
    let local: [[f64; 3]; 3] = [[4.0, 0.0, 2.0], [8.0, 2.0, 2.0], [11.0, 5.0, 2.5]];
    let global_ne: [[f64; 3]; 2] = [[14.0, 8.0, 2.0], [18.0, 9.0, 2.0]];
    let mut args = vec![
        port.to_string(),
        watch.to_string(),
        d.to_string_lossy().to_string(),
        format!("{:.7}", origin.lat_deg),
        format!("{:.7}", origin.lon_deg),
    ];
    for [n, e, z] in local {
        args.push(format!("L,{n},{e},{z}"));
    }
    for [n, e, z] in global_ne {
        let [lat, lon] = origin.to_global(n, e);
        args.push(format!("G,{lat:.8},{lon:.8},{z}"));
    }
    let (passed, out) = client("mavproxy_gcs.py", &args);
    let truth = flight.truth();
    stop(flight);
    assert!(passed, "mavproxy_gcs.py failed");
    texts_in_words(&out);
    let rows = truth_rows(&truth);
    assert!(rows.len() > 100, "{} truth rows", rows.len());
    let mut worst: f64 = 0.0;
    for (i, [n, e, z]) in local.iter().chain(global_ne.iter()).enumerate() {
        let closest = rows
            .iter()
            .map(|r| ((r[0] - n).powi(2) + (r[1] - e).powi(2) + (r[2] - z).powi(2)).sqrt())
            .fold(f64::INFINITY, f64::min);
        println!("waypoint {i} ({n}, {e}, {z}): truth came within {closest:.3} m");
        worst = worst.max(closest);
    }
    assert!(worst <= 0.3, "a waypoint missed by {worst:.3} m");
}

/// The truth log's `x_m, y_m, z_m` rows.
fn truth_rows(path: &Path) -> Vec<[f64; 3]> {
    gcs::truth_columns(path, ["x_m", "y_m", "z_m"])
}
