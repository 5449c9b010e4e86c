//! The surface program (`rov-topside --tcp` in front of `host-sim vehicle`) driven by a ground
//! station we did not write: pymavlink.
//!
//! The client (`tests/clients/pymavlink_session.py`) connects, checks the vehicle type and the
//! telemetry streams, sets MANUAL, arms, flies forward on `MANUAL_CONTROL`, stops the stream
//! and sees the vehicle's failsafe, flies ALT_HOLD (depth and heading held with the sticks
//! centred, a climb on the throttle and the new depth held), sets STABILIZE, is refused AUTO
//! (no missions yet), sets POSHOLD, disarms, and sends garbage. Then the `.tlog` is read back with pymavlink.
//!
//! Without Python 3 or pymavlink this test prints SKIPPED with the fix; with
//! `ROV_REQUIRE_PYMAVLINK=1` (set by `.ci/run`) it fails instead.

use crate::gcs;
// The probes with a ground station's raw bytes, and the flights on the vehicle's own
// estimator (in the folder beside this file, not test binaries of their own).
#[path = "topside_clients/estimator.rs"]
pub(crate) mod estimator;
#[path = "topside_clients/probes.rs"]
pub(crate) mod probes;

use gcs::{dive, free_udp_port, pymavlink_or_skip, stop, Dive};
use std::net::UdpSocket;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

pub(crate) fn pymavlink_flies_the_simulated_vehicle_and_reads_the_tlog() {
    if !pymavlink_or_skip() {
        return;
    }
    fly_session("in-process", &["--speedup", "2"]);
}

/// The same session against the firmware image in QEMU (the emulated STM32F405), served by
/// `host-sim vehicle --qemu=ELF`.
pub(crate) fn pymavlink_flies_the_emulated_board() {
    if !crate::long_test("topside_clients::pymavlink_flies_the_emulated_board", 50) {
        return;
    }
    if !pymavlink_or_skip() {
        return;
    }
    let Some(elf) = host_sim::tether::qemu::image_or_skip().unwrap() else {
        return;
    };
    let qemu = format!("--qemu={}", elf.display());
    fly_session("emulated", &[&qemu]);
}

fn fly_session(name: &str, extra: &[&str]) {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("topside-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let port = free_udp_port();
    let topside = topside(
        port,
        &dir.join("session.tlog"),
        &dir.join("params.json"),
        extra,
    );
    let script = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/clients/pymavlink_session.py"
    );
    let t0 = Instant::now();
    let out = Command::new("python3")
        .arg(script)
        .arg(port.to_string())
        .output()
        .unwrap();
    stop(topside);
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!("{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(
        out.status.success(),
        "the pymavlink session failed ({name})"
    );
    // A hung session fails; the image in QEMU is served at 0.1x to 0.2x real time on the
    // loaded 2-core machine, and the session's sticks last the vehicle's seconds.
    let wall_limit_s = if name == "emulated" { 900 } else { 180 };
    assert!(t0.elapsed() < Duration::from_secs(wall_limit_s));
    assert_eq!(stdout.matches("PASS:").count(), 32, "every check ran");
    // The logs of this start, under time-stamped names.
    let tlog = only_file(&dir, "tlog");

    // The .tlog, read by pymavlink: what was sent and what was received.
    let read = Command::new("python3")
        .args([
            "-c",
            "import sys\nfrom pymavlink import mavutil\nm = mavutil.mavlink_connection(sys.argv[1])\nc = {}\nwhile True:\n    x = m.recv_match()\n    if x is None: break\n    c[x.get_type()] = c.get(x.get_type(), 0) + 1\nprint(' '.join(f'{k}={v}' for k, v in sorted(c.items())))",
        ])
        .arg(&tlog)
        .output()
        .unwrap();
    let counts = String::from_utf8_lossy(&read.stdout).to_string();
    println!("tlog: {counts}");
    let count = |k: &str| -> u32 {
        counts
            .split_whitespace()
            .find_map(|kv| kv.strip_prefix(&format!("{k}=")))
            .map_or(0, |v| v.parse().unwrap())
    };
    assert!(count("HEARTBEAT") >= 5);
    assert!(count("LOCAL_POSITION_NED") >= 50);
    assert!(count("COMMAND_LONG") >= 4, "received commands are logged");
    assert!(count("MANUAL_CONTROL") >= 20);
    assert!(count("COMMAND_ACK") >= 5);
    assert!(count("STATUSTEXT") >= 2);

    // The raw tether log beside it: every frame both ways decodes, and it holds what the
    // session did on the vehicle (arming, modes, the pilot's thrust) and its telemetry.
    let frames = host_sim::tether::tether_log::decode(
        &host_sim::tether::tether_log::read(&only_file(&dir, "tether")).unwrap(),
    );
    use firmware::protocol::{Command as Cmd, Reply};
    let commands = |f: &dyn Fn(&Cmd) -> bool| frames.commands.iter().filter(|c| f(&c.2)).count();
    let telemetry = frames
        .replies
        .iter()
        .filter(|r| matches!(r.2, Reply::Telemetry(_)))
        .count();
    println!(
        "tether log: {} commands, {} replies ({telemetry} telemetry), {} dropped",
        frames.commands.len(),
        frames.replies.len(),
        frames.dropped
    );
    assert_eq!(frames.dropped, 0);
    assert!(commands(&|c| matches!(c, Cmd::Arm)) >= 1);
    assert!(commands(&|c| matches!(c, Cmd::SetMode(_))) >= 3);
    assert!(commands(&|c| matches!(c, Cmd::ManualThrust(_))) >= 50);
    // Without --vehicle the surface keeps the vehicle's own description, as with a real one.
    assert_eq!(commands(&|c| matches!(c, Cmd::SetVehicle(_))), 0);
    // The vehicle's 10 Hz telemetry over the session, every frame logged.
    let stamps: Vec<u64> = frames
        .replies
        .iter()
        .filter_map(|r| match &r.2 {
            Reply::Telemetry(t) => Some(t.t_us),
            _ => None,
        })
        .collect();
    // The rate is judged over at least 10 s of the vehicle's clock (the session's length on
    // that clock depends on how fast the vehicle is served: 18.6-25 s seen with the image in
    // QEMU on a loaded machine).
    let span_s = (stamps.last().unwrap() - stamps.first().unwrap()) as f64 * 1e-6;
    assert!(
        telemetry as f64 >= 0.9 * 10.0 * span_s && span_s > 10.0,
        "{telemetry} telemetry frames over {span_s:.1} s of the vehicle's time"
    );

    // The dive drawn from its log: the same files as a simulated run.
    let replay_dir = dir.join("replay");
    let out = host_sim::commands::replay::replay(&tlog, &replay_dir).unwrap();
    println!(
        "replay: {} / {}",
        out.summary.stop_reason, out.summary.verdict
    );
    for f in [
        "summary.json",
        "timeseries.csv",
        "fig_xy.png",
        "fig_thrusters.png",
    ] {
        assert!(replay_dir.join(f).is_file(), "{f}");
    }
    let first = out.log.first().unwrap().state.eta[0];
    let north = out
        .log
        .iter()
        .map(|s| s.state.eta[0] - first)
        .fold(0.0, f64::max);
    assert!(north > 0.3, "the replay shows the dash forward: {north} m");
    assert!(out.log.iter().any(|s| s.pulse_us[0] > 1550.0));
}

/// The one file in `dir` with the extension `ext` (the topside names its logs with a time
/// stamp).
fn only_file(dir: &std::path::Path, ext: &str) -> PathBuf {
    let found = files(dir, ext);
    assert_eq!(found.len(), 1, "one .{ext} in {}: {found:?}", dir.display());
    found.into_iter().next().unwrap()
}

/// The files in `dir` with the extension `ext`, sorted by name.
fn files(dir: &std::path::Path, ext: &str) -> Vec<PathBuf> {
    let mut found: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    found.sort();
    found
}

/// `circle-3d` flown through the surface program to `udpout:127.0.0.1:PORT`, with `extra`
/// options (`gcs::dive`).
fn topside(port: u16, tlog: &std::path::Path, params: &std::path::Path, extra: &[&str]) -> Dive {
    dive(
        "circle-3d",
        port,
        tlog,
        params,
        &[&["--duration", "300"], extra].concat(),
    )
}

fn client(args: &[&str]) -> String {
    let (passed, stdout) = gcs::run_client("pymavlink_params.py", args);
    assert!(passed, "pymavlink_params.py {args:?} failed");
    stdout
}

pub(crate) fn pymavlink_changes_gains_the_vehicle_and_a_timeout_which_survive_a_restart_and_bad_ones_are_refused(
) {
    if !pymavlink_or_skip() {
        return;
    }
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("topside-params");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let params = dir.join("params.json");
    let tlog = dir.join("p.tlog");

    let port = free_udp_port();
    let first = topside(port, &tlog, &params, &["--speedup", "2"]);
    let out = client(&[&port.to_string(), "set"]);
    stop(first);
    let value = out
        .lines()
        .find_map(|l| l.strip_prefix("VALUE="))
        .expect("the client printed the value it set")
        .to_string();
    let saved = std::fs::read_to_string(&params).expect("the accepted changes were saved");
    assert!(
        saved.contains("\"VEH_MASS\": 12.5") && saved.contains("\"FS_PILOT_STALE\": 0.8"),
        "{saved}"
    );

    let port = free_udp_port();
    let second = topside(port, &tlog, &params, &["--speedup", "2"]);
    client(&[&port.to_string(), "check", &value]);
    stop(second);
}

/// A Python client against a fresh dive of `circle-3d`: the topside on `port` (plus
/// `extra`), then `clients/SCRIPT PORT ARGS...`; `DIR` in `args` is the session's folder.
/// Returns the client's output after checking that it succeeded.
fn client_session(name: &str, script: &str, port: u16, extra: &[&str], args: &[&str]) -> String {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("topside-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let topside = topside(
        port,
        &dir.join(format!("{name}.tlog")),
        &dir.join("params.json"),
        extra,
    );
    let dir_arg = dir.to_string_lossy().to_string();
    let args: Vec<&str> = args
        .iter()
        .map(|&a| if a == "DIR" { dir_arg.as_str() } else { a })
        .collect();
    let out = Command::new("python3")
        .arg(format!(
            "{}/tests/clients/{script}",
            env!("CARGO_MANIFEST_DIR")
        ))
        .arg(port.to_string())
        .args(args)
        .output()
        .unwrap();
    stop(topside);
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    println!("{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "{script} failed");
    stdout
}

/// Two ground stations on two connections, one flooding `MANUAL_CONTROL`: neither the tether
/// loop nor the other station is starved (bad input).
pub(crate) fn a_manual_control_flood_starves_neither_the_tether_nor_a_second_ground_station() {
    if !pymavlink_or_skip() {
        return;
    }
    let (pilot, observer) = (free_udp_port(), free_udp_port());
    let second = format!("udpout:127.0.0.1:{observer}");
    let out = client_session(
        "two-gcs",
        "pymavlink_two_gcs.py",
        pilot,
        &["--mavlink", &second],
        &[&observer.to_string()],
    );
    assert!(out.contains("PASS: disarmed"), "the session ran to its end");
}

/// Missions: pymavlink uploads a 3-waypoint mission through the standard protocol,
/// downloads it back, has bad ones refused (too many items, a NaN or unreachable depth, a
/// global frame) with the mission in use unchanged, flies it in AUTO on the vehicle (each
/// `MISSION_ITEM_REACHED`, the end within 0.3 m of the last waypoint), and clears it.
pub(crate) fn pymavlink_uploads_a_mission_and_flies_it_in_auto() {
    if !pymavlink_or_skip() {
        return;
    }
    let out = client_session(
        "mission",
        "pymavlink_mission.py",
        free_udp_port(),
        &["--speedup", "8"],
        &[],
    );
    assert!(
        out.contains("PASS: AUTO without a mission refused"),
        "the session ran to its last check"
    );
}

/// Global frames: refused before `SET_GPS_GLOBAL_ORIGIN`, then a mission in
/// `MAV_FRAME_GLOBAL_RELATIVE_ALT_INT` (positions from pymavlink's own geodesy) flown in AUTO
/// to its last waypoint, `GLOBAL_POSITION_INT` on the map's terms.
pub(crate) fn pymavlink_flies_a_mission_in_a_global_frame_after_setting_the_origin() {
    if !crate::long_test(
        "topside_clients::pymavlink_flies_a_mission_in_a_global_frame_after_setting_the_origin",
        15,
    ) {
        return;
    }
    if !pymavlink_or_skip() {
        return;
    }
    let out = client_session(
        "global",
        "pymavlink_global.py",
        free_udp_port(),
        &["--speedup", "8"],
        &[],
    );
    assert!(out.contains("PASS: disarmed"), "the session ran to its end");
}

/// MAVProxy (PyPI), typed into as an operator would: ALT_HOLD, `wp load` of a QGC WPL file,
/// arm, AUTO to the last waypoint, disarm. SKIPPED without `mavproxy.py` unless
/// `ROV_REQUIRE_PYMAVLINK=1` (`.ci/run` installs both).
pub(crate) fn mavproxy_flies_a_mission_it_loads_from_a_file() {
    if !pymavlink_or_skip() {
        return;
    }
    let have = Command::new("mavproxy.py")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !have {
        let why = "mavproxy.py not found";
        if std::env::var("ROV_REQUIRE_PYMAVLINK").is_ok_and(|v| v == "1") {
            panic!("{why} and ROV_REQUIRE_PYMAVLINK=1; fix: python3 -m pip install MAVProxy");
        }
        println!("SKIPPED: {why}; fix: python3 -m pip install MAVProxy");
        return;
    }
    let out = client_session(
        "mavproxy",
        "mavproxy_session.py",
        free_udp_port(),
        &["--speedup", "8"],
        &["DIR"],
    );
    assert!(out.contains("PASS: `disarm`: DISARMED"));
}
