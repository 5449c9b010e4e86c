//! A scenario of the topside layout (`[deployment] control = "topside"`) served by `host-sim
//! vehicle` (the topside MCU's App with its node behind the node link) and flown through
//! `rov-topside --tcp` from a MAVLink ground station (the `mavlink` crate), as any vehicle; the
//! same flight of the onboard layout is the comparison. With `--qemu` the two images
//! (`topside-emu`, `node-emu`) are served in QEMU (SKIPPED without QEMU or the thumbv7em
//! target).

use mavlink::dialects::ardupilotmega::{
    MavCmd, MavFrame, MavMessage, MavModeFlag, MavResult, PositionTargetTypemask,
    COMMAND_LONG_DATA, MANUAL_CONTROL_DATA, SET_POSITION_TARGET_LOCAL_NED_DATA,
};
use mavlink::{MavConnection, MavHeader};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

// This file uses the scratch folders only.
#[allow(dead_code)]
use crate::common;
use crate::gcs;
use gcs::{dive, free_udp_port, stop, Dive};

/// The built-in `nav-circle-3d` (the estimator on the full sensor suite: IMU, depth,
/// compass, DVL, USBL) as a scenario file in `dir`, with `extra` appended (its `[expect]`
/// dropped: the ground station flies it, not its reference).
fn scenario(dir: &Path, name: &str, extra: &str) -> PathBuf {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/nav-circle-3d.toml");
    let text = std::fs::read_to_string(src).unwrap();
    let text = text.split("\n[expect]").next().unwrap();
    let p = dir.join(format!("{name}.toml"));
    std::fs::write(&p, format!("{text}\n{extra}")).unwrap();
    p
}

const TOPSIDE: &str = "[deployment]\ncontrol = \"topside\"\n";

/// `host-sim vehicle LAYOUT --qemu`: the two emulated images behind the topside program. The
/// ground station hears the vehicle (HEARTBEAT), its simulated time advances
/// (LOCAL_POSITION_NED), the node is healthy (SYS_STATUS), and the served vehicle exits 0 at
/// its `--duration`. The images run on the host's clock, several times slower than real time
/// on a loaded 2-core machine, so the flight is short.
pub(crate) fn the_topside_program_runs_the_emulated_topside_layout() {
    let Some(_elfs) = host_sim::tether::qemu::layout_images_or_skip().unwrap() else {
        return;
    };
    let dir = common::scratch("topside-layout", "emulated");
    let sc = scenario(&dir, "layout", TOPSIDE);
    let port = free_udp_port();
    let flight = dive(
        &sc,
        port,
        &dir.join("emulated.tlog"),
        &dir.join("params.json"),
        &["--qemu", "--vehicle-duration", "2"],
    );
    let gcs = Station(mavlink::connect::<MavMessage>(&format!("udpin:127.0.0.1:{port}")).unwrap());
    let heartbeat = gcs.wait(Duration::from_secs(120), |m| match m {
        MavMessage::HEARTBEAT(h) => Some(h.clone()),
        _ => None,
    });
    assert!(heartbeat.is_some(), "no HEARTBEAT from the emulated layout");
    let healthy = gcs.wait(Duration::from_secs(120), |m| match m {
        MavMessage::SYS_STATUS(s) => Some(s.onboard_control_sensors_health),
        _ => None,
    });
    assert!(healthy.is_some(), "no SYS_STATUS from the emulated layout");
    let t_s = gcs
        .wait(Duration::from_secs(300), |m| match m {
            MavMessage::LOCAL_POSITION_NED(p) if p.time_boot_ms >= 1_000 => {
                Some(f64::from(p.time_boot_ms) * 1e-3)
            }
            _ => None,
        })
        .expect("the emulated layout's time did not reach 1 s");
    println!("emulated topside layout: LOCAL_POSITION_NED at {t_s:.2} s");
    vehicle_ends(flight, Duration::from_secs(600));
}

/// Wait up to `timeout` for the served vehicle to stop at its `--duration` and exit 0, then
/// stop the surface; past the timeout the dive is stopped and the test fails. Returns the
/// vehicle's truth log.
fn vehicle_ends(mut d: Dive, timeout: Duration) -> PathBuf {
    let end = Instant::now() + timeout;
    let status = loop {
        if let Some(s) = d.vehicle.try_wait().unwrap() {
            break s;
        }
        if Instant::now() > end {
            stop(d);
            panic!("the served vehicle did not stop at its --duration within {timeout:?}");
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let truth = d.truth();
    stop(d);
    assert!(status.success(), "served vehicle exit {status:?}");
    truth
}

/// A truth log's column names and its complete rows (a text column reads as NaN).
fn truth_rows(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let cols: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .map(|l| {
            l.split(',')
                .map(|v| v.parse().unwrap_or(f64::NAN))
                .collect::<Vec<f64>>()
        })
        .filter(|r| r.len() == cols.len())
        .collect();
    (cols, rows)
}

/// The ground station's end: `udpin` on the port the topside sends to.
struct Station(mavlink::Connection<MavMessage>);

impl Station {
    fn send(&self, msg: &MavMessage) {
        let h = MavHeader {
            system_id: 255,
            component_id: 190,
            sequence: 0,
        };
        self.0.send(&h, msg).unwrap();
    }

    /// The first message `pick` takes within `timeout` (wall clock).
    fn wait<T>(
        &self,
        timeout: Duration,
        mut pick: impl FnMut(&MavMessage) -> Option<T>,
    ) -> Option<T> {
        let end = Instant::now() + timeout;
        while Instant::now() < end {
            match self.0.try_recv() {
                Ok((_, m)) => {
                    if let Some(t) = pick(&m) {
                        return Some(t);
                    }
                }
                Err(_) => std::thread::sleep(Duration::from_millis(1)),
            }
        }
        None
    }

    /// `COMMAND_LONG` `command` with `param1`, `param2`: its `COMMAND_ACK`'s result.
    fn command(&self, command: MavCmd, param1: f32, param2: f32) -> Option<MavResult> {
        self.send(&MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            param1,
            param2,
            command,
            target_system: 1,
            target_component: 1,
            ..Default::default()
        }));
        self.wait(Duration::from_secs(5), |m| match m {
            MavMessage::COMMAND_ACK(a) if a.command == command => Some(a.result),
            _ => None,
        })
    }

    fn set_mode(&self, custom: u32) -> Option<MavResult> {
        let flag = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED.bits() as f32;
        self.command(MavCmd::MAV_CMD_DO_SET_MODE, flag, custom as f32)
    }
}

const POSHOLD: u32 = 16;
const GUIDED: u32 = 4;
/// The GUIDED target (NED, m): 3 m north and 2 m east of the launch point (0, 0, 2 m deep),
/// 0.5 m deeper.
const TARGET_M: [f64; 3] = [3.0, 2.0, 2.5];
/// Simulated time of the flight (s): the target is given within the first 20 s.
const FLIGHT_S: f64 = 80.0;
/// The last this many seconds are scored.
const SCORED_S: f64 = 20.0;

/// What one flight measured.
struct Flight {
    /// When POSHOLD was accepted (the estimate ready), simulated s.
    ready_s: f64,
    /// True distance to the target: RMS and largest over the last [`SCORED_S`] (m).
    rms_m: f64,
    max_m: f64,
    /// The estimate against the truth over the same span, RMS (m).
    est_rms_m: f64,
}

/// Fly `scenario` from a ground station: POSHOLD as soon as the vehicle accepts it (its
/// estimate ready: before that it refuses with `NavNotReady`; the scenario's launch point is
/// told to the estimator, so it is ready at once here), arm, GUIDED, the target; then score
/// the truth log.
fn fly(scenario: &Path, dir: &Path) -> Flight {
    let port = free_udp_port();
    // Both layouts served by `host-sim vehicle` behind `rov-topside --tcp`, the path of a
    // real dive.
    let flight = dive(
        scenario,
        port,
        &dir.join("fly.tlog"),
        &dir.join("params.json"),
        &[
            "--vehicle-duration",
            &FLIGHT_S.to_string(),
            // 2x: the vehicle's link failsafe disarms it after 1 s of its time without the
            // surface's heartbeat, 0.5 s of wall time; at 4x a loaded machine stalled the
            // surface for 0.33 s (both ways in its tether log) and the vehicle disarmed.
            "--speedup",
            "2",
            "--start-nav",
            // The vehicle's clock starts when the surface connects, not when the process
            // does: the go-to starts at the same time of the vehicle's clock, whatever the
            // load when the two programs start.
            "--wait-surface",
        ],
    );
    let gcs = Station(mavlink::connect::<MavMessage>(&format!("udpin:127.0.0.1:{port}")).unwrap());
    let sim_s = |gcs: &Station| {
        gcs.wait(Duration::from_secs(20), |m| match m {
            MavMessage::LOCAL_POSITION_NED(p) => Some(f64::from(p.time_boot_ms) * 1e-3),
            _ => None,
        })
        .expect("LOCAL_POSITION_NED from the topside")
    };
    let mut ready_s = None;
    let mut refusals = 0;
    while ready_s.is_none() {
        let t = sim_s(&gcs);
        assert!(
            t < 20.0,
            "POSHOLD still refused at {t:.1} s ({refusals} refusals)"
        );
        match gcs.set_mode(POSHOLD) {
            Some(MavResult::MAV_RESULT_ACCEPTED) => ready_s = Some(t),
            Some(_) => refusals += 1,
            None => panic!("no answer to DO_SET_MODE"),
        }
    }
    assert_eq!(
        gcs.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, 1.0, 0.0),
        Some(MavResult::MAV_RESULT_ACCEPTED),
        "arm"
    );
    assert_eq!(
        gcs.set_mode(GUIDED),
        Some(MavResult::MAV_RESULT_ACCEPTED),
        "GUIDED"
    );
    gcs.send(&MavMessage::SET_POSITION_TARGET_LOCAL_NED(
        SET_POSITION_TARGET_LOCAL_NED_DATA {
            x: TARGET_M[0] as f32,
            y: TARGET_M[1] as f32,
            z: TARGET_M[2] as f32,
            target_system: 1,
            target_component: 1,
            coordinate_frame: MavFrame::MAV_FRAME_LOCAL_NED,
            type_mask: PositionTargetTypemask::empty(),
            ..Default::default()
        },
    ));
    // The flight ends at the served vehicle's duration.
    let truth = vehicle_ends(flight, Duration::from_secs(300));
    // Both truth logs by their columns' names.
    let (cols, rows) = truth_rows(&truth);
    let c = |name: &str| cols.iter().position(|x| x == name).unwrap();
    let (t, armed) = (c("t_s"), c("armed"));
    let (x, nx) = (
        [c("x_m"), c("y_m"), c("z_m")],
        [c("nav_x_m"), c("nav_y_m"), c("nav_z_m")],
    );
    let last_s = rows.last().unwrap()[t];
    assert!(last_s > FLIGHT_S - 0.1, "the truth log ends at {last_s} s");
    let (mut sq, mut max, mut est, mut n) = (0.0, 0.0f64, 0.0, 0usize);
    for r in rows.iter().filter(|r| r[t] >= last_s - SCORED_S) {
        assert_eq!(r[armed], 1.0, "{}: armed at {} s", dir.display(), r[t]);
        let d2: f64 = (0..3).map(|k| (r[x[k]] - TARGET_M[k]).powi(2)).sum();
        sq += d2;
        max = max.max(d2.sqrt());
        est += (0..3).map(|k| (r[nx[k]] - r[x[k]]).powi(2)).sum::<f64>();
        n += 1;
    }
    Flight {
        ready_s: ready_s.unwrap(),
        rms_m: (sq / n as f64).sqrt(),
        max_m: max,
        est_rms_m: (est / n as f64).sqrt(),
    }
}

/// A served topside-layout scenario is flown from a ground station like any vehicle: the position modes wait for the topside's estimate, the
/// vehicle is armed, goes to a GUIDED target and holds it. Its true position over the last
/// 20 s is held against the target, and against the same flight of the onboard layout.
pub(crate) fn a_ground_station_flies_the_topside_layout_to_a_guided_target() {
    if !crate::long_test(
        "topside_layout::a_ground_station_flies_the_topside_layout_to_a_guided_target",
        80,
    ) {
        return;
    }
    let dir = common::scratch("topside-layout", "fly");
    let layout_dir = dir.join("layout");
    let onboard_dir = dir.join("onboard");
    std::fs::create_dir_all(&layout_dir).unwrap();
    std::fs::create_dir_all(&onboard_dir).unwrap();
    let layout = fly(&scenario(&dir, "layout", TOPSIDE), &layout_dir);
    let onboard = fly(&scenario(&dir, "onboard", ""), &onboard_dir);
    for (name, f) in [("topside layout", &layout), ("onboard layout", &onboard)] {
        println!(
            "{name}: POSHOLD accepted at {:.1} s; true distance to the target over the last \
             {SCORED_S} s: RMS {:.2} cm, largest {:.2} cm; estimate against the truth RMS {:.2} cm",
            f.ready_s,
            f.rms_m * 100.0,
            f.max_m * 100.0,
            f.est_rms_m * 100.0
        );
    }
    assert!(
        layout.rms_m <= 0.10,
        "topside layout: RMS {:.3} m from the target",
        layout.rms_m
    );
    assert!(
        layout.rms_m <= 1.1 * onboard.rms_m + 0.01,
        "topside layout {:.4} m, onboard {:.4} m: not within 10 % + 1 cm",
        layout.rms_m,
        onboard.rms_m
    );
}

const MANUAL: u32 = 19;

/// The pilot's sticks reach the topside layout's thrusters: in MANUAL, half surge ahead
/// streamed at 50 Hz makes both horizontal pulses rise above 1550 us (`SERVO_OUTPUT_RAW`,
/// the pulses the topside sends the node) and the vehicle move ahead (the truth log); when
/// the stream stops, the topside App's `MANUAL_STALE` failsafe is shown.
pub(crate) fn a_pilot_drives_the_topside_layout_in_manual() {
    let dir = common::scratch("topside-layout", "manual");
    let sc = scenario(&dir, "layout", TOPSIDE);
    let port = free_udp_port();
    let flight = dive(
        &sc,
        port,
        &dir.join("manual.tlog"),
        &dir.join("params.json"),
        // The layout starts its estimator at the launch point, as the vehicle is configured.
        &["--speedup", "2", "--start-nav"],
    );
    let gcs = Station(mavlink::connect::<MavMessage>(&format!("udpin:127.0.0.1:{port}")).unwrap());
    let started = gcs.wait(Duration::from_secs(20), |m| {
        matches!(m, MavMessage::HEARTBEAT(_)).then_some(())
    });
    assert!(started.is_some(), "no HEARTBEAT from the topside");
    assert_eq!(
        gcs.set_mode(MANUAL),
        Some(MavResult::MAV_RESULT_ACCEPTED),
        "MANUAL"
    );
    assert_eq!(
        gcs.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, 1.0, 0.0),
        Some(MavResult::MAV_RESULT_ACCEPTED),
        "arm"
    );
    // The sticks seen at centre first: after an arming a stick acts only once the vehicle
    // has seen the sticks centred.
    for _ in 0..10 {
        gcs.send(&MavMessage::MANUAL_CONTROL(MANUAL_CONTROL_DATA {
            x: 0,
            y: 0,
            z: 500,
            r: 0,
            buttons: 0,
            target: 1,
        }));
        std::thread::sleep(Duration::from_millis(20));
    }
    let (mut samples, mut ahead) = (0, 0);
    let start = Instant::now();
    let end = start + Duration::from_secs(2);
    while Instant::now() < end {
        gcs.send(&MavMessage::MANUAL_CONTROL(MANUAL_CONTROL_DATA {
            // At rest for 0.2 s first: thrust follows a stick seen at centre.
            x: if start.elapsed() < Duration::from_millis(200) {
                0
            } else {
                500
            },
            y: 0,
            z: 500,
            r: 0,
            buttons: 0,
            target: 1,
        }));
        let step_end = Instant::now() + Duration::from_millis(20);
        while let Some(p) = gcs.wait(
            step_end.saturating_duration_since(Instant::now()),
            |m| match m {
                MavMessage::SERVO_OUTPUT_RAW(p) => Some((p.servo1_raw, p.servo2_raw)),
                _ => None,
            },
        ) {
            samples += 1;
            if p.0 > 1550 && p.1 > 1550 {
                ahead += 1;
            }
        }
    }
    let stale = gcs.wait(Duration::from_secs(5), |m| match m {
        MavMessage::STATUSTEXT(t) => {
            let s = t.text.to_str().unwrap_or("").to_string();
            s.contains("pilot input lost").then_some(s)
        }
        _ => None,
    });
    let truth = flight.truth();
    stop(flight);
    println!(
        "SERVO_OUTPUT_RAW: {ahead} of {samples} samples with both horizontal pulses > 1550 us"
    );
    assert!(
        samples >= 20,
        "{samples} SERVO_OUTPUT_RAW in 2 s (10 Hz at --speedup 2)"
    );
    assert!(ahead >= samples / 2, "{ahead} of {samples} ahead");
    assert_eq!(
        stale.as_deref(),
        Some("Failsafe: pilot input lost: thrusters neutral")
    );
    let (cols, rows) = truth_rows(&truth);
    let x = cols.iter().position(|c| c == "x_m").unwrap();
    let moved_m = rows.last().unwrap()[x] - rows[0][x];
    println!("moved {moved_m:.2} m north");
    assert!(moved_m > 0.2, "the vehicle moved {moved_m:.3} m ahead");
}

/// The node link cut (`[deployment] tether_cut_s`) reaches the ground station through the
/// topside program: "Failsafe: node link lost" within the 250 ms of the cut (by the
/// simulated time of the state messages around it, 10 Hz), and `SYS_STATUS` shows the
/// node's sensors and motors unhealthy.
pub(crate) fn the_ground_station_sees_the_node_link_cut_within_250_ms() {
    use mavlink::dialects::ardupilotmega::MavSysStatusSensor as S;
    let dir = common::scratch("topside-layout", "cut");
    let cut_s = 5.0;
    let sc = scenario(
        &dir,
        "layout",
        &format!("{TOPSIDE}tether_cut_s = {cut_s}\n"),
    );
    let port = free_udp_port();
    let flight = dive(
        &sc,
        port,
        &dir.join("cut.tlog"),
        &dir.join("params.json"),
        // The layout starts its estimator at the launch point, as the vehicle is configured.
        &["--speedup", "2", "--start-nav"],
    );
    let gcs = Station(mavlink::connect::<MavMessage>(&format!("udpin:127.0.0.1:{port}")).unwrap());
    let node = S::MAV_SYS_STATUS_SENSOR_3D_GYRO
        | S::MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
        | S::MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS;
    // The simulated time of the latest state message, the loss's `STATUSTEXT` between two of
    // them, the node's health before and after.
    let (mut now_s, mut shown) = (0.0f64, None);
    let (mut healthy_before, mut unhealthy_after) = (false, false);
    let end = Instant::now() + Duration::from_secs(30);
    while Instant::now() < end && !(shown.is_some() && unhealthy_after) {
        let Some(m) = gcs.wait(Duration::from_millis(100), |m| Some(m.clone())) else {
            continue;
        };
        match m {
            MavMessage::LOCAL_POSITION_NED(p) => now_s = f64::from(p.time_boot_ms) * 1e-3,
            MavMessage::STATUSTEXT(t) => {
                let s = t.text.to_str().unwrap_or("").to_string();
                if s.starts_with("Failsafe: node link lost") && now_s > 1.0 && shown.is_none() {
                    shown = Some(now_s);
                }
            }
            MavMessage::SYS_STATUS(st) => {
                let ok = st.onboard_control_sensors_health.contains(node);
                if ok && now_s > 1.0 && now_s < cut_s {
                    healthy_before = true;
                }
                if !ok && shown.is_some() {
                    unhealthy_after = true;
                }
            }
            _ => {}
        }
    }
    stop(flight);
    // The state messages come every 0.1 s and the `STATUSTEXT` before the next one: the
    // loss was told after `shown` and at most 0.1 s later.
    let shown = shown.expect("no \"Failsafe: node link lost\" after the cut");
    println!(
        "node link cut at {cut_s} s: the ground station told between {shown:.1} and {:.1} s",
        shown + 0.1
    );
    assert!(
        healthy_before,
        "SYS_STATUS never showed the node healthy before the cut"
    );
    assert!(
        unhealthy_after,
        "SYS_STATUS never showed the node unhealthy after the cut"
    );
    assert!(
        shown + 0.1 >= cut_s,
        "told by {shown} + 0.1 s, before the cut"
    );
    assert!(
        shown + 0.1 <= cut_s + 0.25,
        "told after {shown} s, possibly more than 250 ms after the cut"
    );
}
