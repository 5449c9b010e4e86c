//! The surface program's safety: nothing a ground station sends surprises the vehicle with
//! thrust or locks it out, and nothing the vehicle sends is believed unchecked.
//!
//! Each test drives `host-sim topside` as an operator's ground station would (pymavlink,
//! `clients/pymavlink_surface_safety.py`, or the `mavlink` crate here) and asserts the figures:
//! commands addressed to another system change nothing; arming with a stick held, a takeover
//! and a mode change give 0 pulses away from neutral within 1 s unless a centred stick was seen
//! first; control changes hands only with the passkey, one grant at a time; fence and rally
//! never touch the mission and every item is answered; a restart mid-dive with the saved file
//! flies again within 5 s; a quiet vehicle does not end the surface program; vehicle frames
//! out of range are refused and counted.

use crate::gcs;

use firmware::protocol::{
    decode_frame, encode, Command as Cmd, Decoded, Mode, Reply, MAX_FRAME_LEN,
};
use firmware::Config;
use gcs::{dive as fly_dive, free_udp_port, pymavlink_or_skip, stop, wait};
use host_sim::tether::in_process::InProcessFirmware;
use mavlink::dialects::ardupilotmega::{MavCmd, MavMessage, MavModeFlag, COMMAND_LONG_DATA};
use mavlink::{MavConnection, MavHeader};
use serialport::{SerialPort, TTYPort};
use std::io::{Read, Write};
use std::path::PathBuf;
use std::process::Command;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

fn session_dir(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("safety-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A topside on `circle-3d` (real time) for `check`, with one station per port.
fn simulated_session(name: &str, check: &str, ports: &[u16], extra: &[&str]) -> String {
    let dir = session_dir(name);
    let mut args: Vec<String> = vec!["--duration".into(), "300".into()];
    for p in ports.iter().skip(1) {
        args.push("--mavlink".into());
        args.push(format!("udpout:127.0.0.1:{p}"));
    }
    args.extend(extra.iter().map(|s| s.to_string()));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let topside = fly_dive(
        "circle-3d",
        ports[0],
        &dir.join(format!("{name}.tlog")),
        &dir.join("params.json"),
        &args,
    );
    let ports: Vec<String> = ports.iter().map(u16::to_string).collect();
    let ports: Vec<&str> = ports.iter().map(String::as_str).collect();
    let out = Command::new("python3")
        .arg(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/clients/pymavlink_surface_safety.py"
        ))
        .arg(check)
        .args(&ports)
        .output()
        .unwrap();
    stop(topside);
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    println!("{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "check {check} failed");
    stdout
}

/// `DO_SET_MODE`, `ARM`, `PARAM_SET`, `SET_MODE` and `MANUAL_CONTROL` addressed to system 2 or
/// to component 5 of system 1 are not answered and change nothing; broadcast (0) is obeyed.
pub(crate) fn commands_addressed_to_another_system_or_component_change_nothing() {
    if !pymavlink_or_skip() {
        return;
    }
    let out = simulated_session("target", "target", &[free_udp_port()], &[]);
    assert!(out.contains("PASS: disarmed"), "the session ran to its end");
}

/// Arming in MANUAL with the stick held full ahead for 1 s: refused with the reason in
/// words, 0 pulses away from neutral within 1 s; a mode change with the stick held: 0 pulses
/// away from neutral within 1 s until the stick is seen at centre.
pub(crate) fn arming_or_changing_mode_with_a_stick_held_gives_no_thrust() {
    if !pymavlink_or_skip() {
        return;
    }
    let out = simulated_session("sticks", "sticks", &[free_udp_port()], &[]);
    assert!(out.contains("PASS: disarmed"), "the session ran to its end");
}

/// CHANGE_OPERATOR_CONTROL with the passkey only; the holder told; the new commander's
/// stick full astern gives 0 pulses away from neutral within 1 s of the grant; two stations
/// asking at once: one grant; 100 swaps in 2 s: no reversal; anyone may disarm.
pub(crate) fn control_changes_hands_with_the_passkey_one_grant_at_a_time_and_without_a_thrust_jump()
{
    if !pymavlink_or_skip() {
        return;
    }
    let out = simulated_session(
        "handover",
        "handover",
        &[free_udp_port(), free_udp_port()],
        &[],
    );
    assert!(out.contains("PASS: disarmed"), "the session ran to its end");
}

/// FENCE, RALLY and ALL uploads are refused with `MAV_MISSION_UNSUPPORTED`, a FENCE
/// `MISSION_CLEAR_ALL` leaves the mission; an item past the count, with an unknown command or
/// an unknown frame gets its `MISSION_ACK` within 1 s.
pub(crate) fn fence_and_rally_leave_the_mission_and_every_item_is_answered() {
    if !pymavlink_or_skip() {
        return;
    }
    let out = simulated_session("missions", "missions", &[free_udp_port()], &[]);
    assert!(
        out.contains("PASS: clears the mission"),
        "the session ran to its end"
    );
}

/// The surface program killed (SIGKILL) mid-dive on a vehicle with its own estimator, started
/// and fed from the surface, after a parameter was saved; the vehicle dives on, and the
/// surface restarted with the saved file in front of it flies again (heartbeat, the saved
/// parameter, MANUAL and arming accepted) within 5 s, with no thrust before a stick asks.
pub(crate) fn a_restart_mid_dive_with_the_saved_file_flies_again_within_5_s() {
    if !pymavlink_or_skip() {
        return;
    }
    let dir = session_dir("restart");
    let params = dir.join("params.json");
    let port = free_udp_port();
    let first = fly_dive(
        "nav-circle-3d",
        port,
        &dir.join("dive.tlog"),
        &params,
        &["--duration", "300", "--surface-nav"],
    );
    let mut dive = Command::new("python3")
        .arg(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/clients/pymavlink_surface_safety.py"
        ))
        .args(["dive", &port.to_string()])
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Until the client says it is diving, then the surface program is killed.
    let mut out = String::new();
    let mut stdout = dive.stdout.take().unwrap();
    let end = Instant::now() + Duration::from_secs(90);
    let mut buf = [0u8; 256];
    while !out.contains("DIVING") && Instant::now() < end {
        let n = stdout.read(&mut buf).unwrap();
        if n == 0 {
            break;
        }
        out.push_str(&String::from_utf8_lossy(&buf[..n]));
    }
    // Only the surface program dies: the vehicle dives on.
    let gcs::Dive {
        topside: first_surface,
        vehicle,
        tcp,
        surface_args,
        ..
    } = first;
    stop(first_surface);
    let _ = dive.kill();
    let _ = dive.wait();
    println!("{out}");
    assert!(out.contains("DIVING"), "the first session dived");
    let kp = out
        .lines()
        .find_map(|l| l.strip_prefix("KP="))
        .expect("the client printed the gain it set")
        .to_string();
    assert!(params.exists(), "the accepted change was saved");

    // The ground station is there before the restart, as an operator's is.
    let port = free_udp_port();
    let mut resume = Command::new("python3")
        .arg(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/clients/pymavlink_surface_safety.py"
        ))
        .args(["resume", &port.to_string(), &kp])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdout = resume.stdout.take().unwrap();
    let mut ready = String::new();
    let end = Instant::now() + Duration::from_secs(60);
    while !ready.contains("READY") && Instant::now() < end {
        let n = stdout.read(&mut buf).unwrap();
        if n == 0 {
            break;
        }
        ready.push_str(&String::from_utf8_lossy(&buf[..n]));
    }
    assert!(
        ready.contains("READY"),
        "the resuming station did not start: {ready}"
    );
    let t0 = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_secs_f64();
    let second = gcs::surface(
        tcp,
        port,
        &dir.join("resume.tlog"),
        &params,
        &surface_args,
        &["--duration", "300"],
    );
    resume
        .stdin
        .take()
        .unwrap()
        .write_all(format!("{t0}\n").as_bytes())
        .unwrap();
    let mut rest = String::new();
    stdout.read_to_string(&mut rest).unwrap();
    let out = resume.wait_with_output().unwrap();
    let out = std::process::Output {
        stdout: (ready + &rest).into_bytes(),
        ..out
    };
    stop(second);
    stop(vehicle);
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    println!("{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "the resumed session failed");
}

/// The vehicle at the end of a pseudo-terminal: the firmware library, fixed-rate on the
/// host's clock, whose replies pass through `tamper`; while `silent` it hears and says
/// nothing. Counts the tether heartbeats it hears while silent.
struct SerialVehicle {
    device: String,
    silent: Arc<AtomicBool>,
    tamper: Arc<AtomicBool>,
    heard_while_silent: Arc<AtomicU32>,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

/// What a tampered telemetry frame says: AUTO with 65,535 waypoints reached, a NaN position
/// and 65,535 us pulses.
fn tampered(mut t: firmware::protocol::Telemetry) -> firmware::protocol::Telemetry {
    t.mode = Mode::Auto;
    t.mission_reached = u16::MAX;
    t.nav.x_m = f32::NAN;
    t.pulse_us = [u16::MAX; 3];
    t
}

impl SerialVehicle {
    fn start() -> Self {
        let (mut master, slave) = TTYPort::pair().expect("a pseudo-terminal pair");
        let device = slave.name().expect("the pty's name");
        drop(slave);
        master.set_timeout(Duration::from_millis(1)).unwrap();
        let silent = Arc::new(AtomicBool::new(false));
        let tamper = Arc::new(AtomicBool::new(false));
        let heard = Arc::new(AtomicU32::new(0));
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (silent, tamper, heard, stop) =
                (silent.clone(), tamper.clone(), heard.clone(), stop.clone());
            std::thread::spawn(move || {
                let mut fw = InProcessFirmware::with_config(Config::fixed_rate(
                    firmware::protocol::Board::Host,
                ))
                .unwrap();
                let mut buf = [0u8; 256];
                let mut inbox: Vec<u8> = Vec::new();
                while !stop.load(Ordering::Relaxed) {
                    let n = master.read(&mut buf).unwrap_or_else(|_| {
                        std::thread::sleep(Duration::from_millis(1));
                        0
                    });
                    if silent.load(Ordering::Relaxed) {
                        inbox.extend_from_slice(&buf[..n]);
                        while let Some(end) = inbox.iter().position(|&b| b == 0) {
                            let frame: Vec<u8> = inbox.drain(..=end).collect();
                            if let Some(Decoded::Frame {
                                msg: Cmd::Heartbeat { .. },
                                ..
                            }) = decode_frame::<Cmd>(&frame)
                            {
                                heard.fetch_add(1, Ordering::Relaxed);
                            }
                        }
                        let _ = fw.pass(&[]);
                        continue;
                    }
                    inbox.clear();
                    let out = fw.pass(&buf[..n]);
                    if out.is_empty() {
                        continue;
                    }
                    if !tamper.load(Ordering::Relaxed) {
                        let _ = master.write_all(&out);
                        continue;
                    }
                    // Each frame (ending at its delimiter) re-encoded with its telemetry
                    // tampered, under the same session and sequence number.
                    for frame in out.split_inclusive(|&b| b == 0) {
                        match decode_frame::<Reply>(frame) {
                            Some(Decoded::Frame {
                                seq,
                                session,
                                msg: Reply::Telemetry(t),
                            }) => {
                                let mut enc = [0u8; MAX_FRAME_LEN];
                                let f =
                                    encode(session, seq, &Reply::Telemetry(tampered(t)), &mut enc)
                                        .unwrap();
                                let _ = master.write_all(f);
                            }
                            _ => {
                                let _ = master.write_all(frame);
                            }
                        }
                    }
                }
            })
        };
        Self {
            device,
            silent,
            tamper,
            heard_while_silent: heard,
            stop,
            thread: Some(thread),
        }
    }
}

impl Drop for SerialVehicle {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn send(gcs: &mavlink::Connection<MavMessage>, msg: &MavMessage) {
    let h = MavHeader {
        system_id: 255,
        component_id: 190,
        sequence: 0,
    };
    gcs.send(&h, msg).unwrap();
}

fn set_mode(custom: u32) -> MavMessage {
    MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
        param1: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED.bits() as f32,
        param2: custom as f32,
        command: MavCmd::MAV_CMD_DO_SET_MODE,
        target_system: 1,
        target_component: 1,
        ..Default::default()
    })
}

/// Every message for `span`, with its arrival time.
fn gather(gcs: &mavlink::Connection<MavMessage>, span: Duration) -> Vec<(Instant, MavMessage)> {
    let end = Instant::now() + span;
    let mut out = Vec::new();
    while Instant::now() < end {
        match gcs.try_recv() {
            Ok((_, m)) => out.push((Instant::now(), m)),
            Err(_) => std::thread::sleep(Duration::from_millis(2)),
        }
    }
    out
}

/// The status texts among `msgs`, the first 20 (a flood would fill the output).
fn texts(msgs: &[(Instant, MavMessage)]) -> Vec<String> {
    msgs.iter()
        .filter_map(|(_, m)| match m {
            MavMessage::STATUSTEXT(t) => Some(t.text.to_str().unwrap_or("").to_string()),
            _ => None,
        })
        .take(20)
        .collect()
}

/// The vehicle on the serial line goes quiet for 4 s: the surface program does not end; it
/// answers a command at once (refused, the vehicle silent) and says the vehicle is silent;
/// its heartbeats go on, to the ground station (>= 3) and to the vehicle (>= 20 at 10 Hz);
/// when the vehicle answers again it says so and a mode change is accepted.
pub(crate) fn a_quiet_vehicle_does_not_end_the_surface_program() {
    let vehicle = SerialVehicle::start();
    let dir = session_dir("quiet");
    let port = free_udp_port();
    let mut topside = gcs::topside_serial(&vehicle.device, port, &dir, 60);
    let gcs = mavlink::connect::<MavMessage>(&format!("udpin:127.0.0.1:{port}")).unwrap();
    let hb = wait(&gcs, Duration::from_secs(20), |m| {
        matches!(m, MavMessage::HEARTBEAT(_)).then_some(())
    });
    assert!(hb.is_some(), "a HEARTBEAT through the serial line");

    vehicle.silent.store(true, Ordering::Relaxed);
    let t_silent = Instant::now();
    std::thread::sleep(Duration::from_millis(1500));
    send(&gcs, &set_mode(19));
    let sent = Instant::now();
    let msgs = gather(&gcs, Duration::from_millis(2500));
    let heard = vehicle.heard_while_silent.load(Ordering::Relaxed);
    vehicle.silent.store(false, Ordering::Relaxed);
    let silent_for = t_silent.elapsed();
    let alive = topside.try_wait().unwrap().is_none();
    let ack = msgs.iter().find_map(|(t, m)| match m {
        MavMessage::COMMAND_ACK(a) if a.command == MavCmd::MAV_CMD_DO_SET_MODE => {
            Some((t.duration_since(sent), a.result))
        }
        _ => None,
    });
    let beats = msgs
        .iter()
        .filter(|(_, m)| matches!(m, MavMessage::HEARTBEAT(_)))
        .count();
    let said = texts(&msgs);
    println!(
        "silent {silent_for:?}: ack {ack:?}, {beats} MAVLink heartbeats in 2.5 s, {heard} tether \
         heartbeats heard by the vehicle, texts {said:?}"
    );
    assert!(alive, "the surface program ended on a quiet vehicle");
    let (dt, _) = ack.expect("the mode change is answered");
    assert!(dt < Duration::from_millis(500), "answered after {dt:?}");
    assert!(
        beats >= 2,
        "{beats} heartbeats to the ground station in 2.5 s"
    );
    assert!(heard >= 20, "{heard} tether heartbeats in 4 s");
    assert!(
        said.iter().any(|t| t.contains("silent")),
        "the operator is told: {said:?}"
    );

    // Back: said, and once the vehicle has cleared the failsafe its silence set (its own
    // tether heartbeat loss), commands go through again.
    let msgs = gather_until(&gcs, Duration::from_secs(10), |said| {
        said.iter().any(|t| t.contains("answers again"))
            && said
                .iter()
                .any(|t| t.starts_with("Cleared: tether heartbeat lost"))
    });
    send(&gcs, &set_mode(19));
    let after = gather_until(&gcs, Duration::from_secs(3), |_| false);
    let ack = after.iter().find_map(|(_, m)| match m {
        MavMessage::COMMAND_ACK(a) if a.command == MavCmd::MAV_CMD_DO_SET_MODE => Some(a.result),
        _ => None,
    });
    let alive = topside.try_wait().unwrap().is_none();
    stop(topside);
    let (said, said_after) = (texts(&msgs), texts(&after));
    println!("back: {said:?}, ack {ack:?}, then {said_after:?}");
    assert!(alive);
    assert!(said.iter().any(|t| t.contains("answers again")), "{said:?}");
    assert_eq!(
        ack,
        Some(mavlink::dialects::ardupilotmega::MavResult::MAV_RESULT_ACCEPTED),
        "the mode change after the vehicle answers again; said {said_after:?}"
    );
}

/// What arrives for up to `span`, until `done` holds for the status texts so far (then
/// 0.5 s more: what a command's answer brings with it).
fn gather_until(
    gcs: &mavlink::Connection<MavMessage>,
    span: Duration,
    done: impl Fn(&[String]) -> bool,
) -> Vec<(Instant, MavMessage)> {
    let end = Instant::now() + span;
    let mut out = Vec::new();
    let mut said = Vec::new();
    while Instant::now() < end {
        match gcs.try_recv() {
            Ok((_, m)) => {
                if let MavMessage::STATUSTEXT(t) = &m {
                    said.push(t.text.to_str().unwrap_or("").to_string());
                }
                out.push((Instant::now(), m));
                if done(&said) {
                    out.extend(gather(gcs, Duration::from_millis(500)));
                    break;
                }
            }
            Err(_) => std::thread::sleep(Duration::from_millis(2)),
        }
    }
    out
}

/// The vehicle's telemetry tampered for 5 s (AUTO, 65,535 waypoints reached, a NaN position,
/// 65,535 us pulses; CRC-valid frames): the surface program believes none of it: at most 32
/// `MISSION_ITEM_REACHED` (the most a mission holds), no NaN position and no pulse outside
/// 800-2200 us forwarded, its heartbeat at 1 Hz (>= 4 in 5 s), the refusals counted in
/// `SYS_STATUS` (`errors_count1`) and said.
pub(crate) fn vehicle_frames_out_of_range_are_refused_and_counted() {
    let vehicle = SerialVehicle::start();
    let dir = session_dir("frames");
    let port = free_udp_port();
    let topside = gcs::topside_serial(&vehicle.device, port, &dir, 60);
    let gcs = mavlink::connect::<MavMessage>(&format!("udpin:127.0.0.1:{port}")).unwrap();
    let hb = wait(&gcs, Duration::from_secs(20), |m| {
        matches!(m, MavMessage::HEARTBEAT(_)).then_some(())
    });
    assert!(hb.is_some(), "a HEARTBEAT through the serial line");
    vehicle.tamper.store(true, Ordering::Relaxed);
    let msgs = gather(&gcs, Duration::from_secs(5));
    vehicle.tamper.store(false, Ordering::Relaxed);
    stop(topside);
    let count = |f: &dyn Fn(&MavMessage) -> bool| msgs.iter().filter(|(_, m)| f(m)).count();
    let reached = count(&|m| matches!(m, MavMessage::MISSION_ITEM_REACHED(_)));
    let beats = count(&|m| matches!(m, MavMessage::HEARTBEAT(_)));
    let nan = count(&|m| matches!(m, MavMessage::LOCAL_POSITION_NED(p) if !p.x.is_finite()));
    let wild = count(&|m| {
        matches!(m, MavMessage::SERVO_OUTPUT_RAW(s)
            if [s.servo1_raw, s.servo2_raw, s.servo3_raw].iter().any(|&p| p != 0 && !(800..=2200).contains(&p)))
    });
    let refused = msgs
        .iter()
        .filter_map(|(_, m)| match m {
            MavMessage::SYS_STATUS(s) => Some(s.errors_count1),
            _ => None,
        })
        .max()
        .unwrap_or(0);
    let said = texts(&msgs);
    println!(
        "tampered 5 s: {} messages, {reached} MISSION_ITEM_REACHED, {beats} heartbeats, {nan} NaN \
         positions, {wild} wild pulses, {refused} frames refused (SYS_STATUS), texts {said:?}",
        msgs.len()
    );
    assert!(reached <= 32, "{reached} MISSION_ITEM_REACHED");
    assert!(beats >= 4, "{beats} heartbeats in 5 s");
    assert_eq!(nan, 0, "NaN positions forwarded");
    assert_eq!(wild, 0, "pulses outside 800-2200 us forwarded");
    assert!(refused >= 25, "{refused} frames refused in SYS_STATUS");
    assert!(
        said.iter().any(|t| t.contains("refused")),
        "the operator is told: {said:?}"
    );
}
