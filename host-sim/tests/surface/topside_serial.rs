//! `host-sim topside --serial DEV`: the surface side to a real vehicle on a serial line. The
//! vehicle here is the firmware library running fixed-rate on the host's clock (as a board
//! runs) behind a pseudo-terminal made by the `serialport` crate; the topside opens the
//! terminal's other end as it would a USB-serial adapter, and a MAVLink ground station (the
//! `mavlink` crate) talks to the topside. The vehicle has no navigation here (no sensors, no
//! fixes), so it refuses to arm, and says why.

use firmware::protocol::{fault, Command as Cmd, Reply};
use firmware::Config;
use host_sim::tether::in_process::InProcessFirmware;
use host_sim::tether::tether_log;
use mavlink::dialects::ardupilotmega::{
    MavCmd, MavMessage, MavModeFlag, MavParamType, MavResult, MavType, COMMAND_LONG_DATA,
    PARAM_SET_DATA,
};
use mavlink::{MavConnection, MavHeader};
use serialport::{SerialPort, TTYPort};
use std::io::{Read, Write};
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::gcs;
use gcs::{free_udp_port, wait};

fn send(gcs: &mavlink::Connection<MavMessage>, msg: &MavMessage) {
    let h = MavHeader {
        system_id: 255,
        component_id: 190,
        sequence: 0,
    };
    gcs.send(&h, msg).unwrap();
}

pub(crate) fn the_topside_drives_a_vehicle_on_a_serial_line() {
    let (mut master, slave) = TTYPort::pair().expect("a pseudo-terminal pair");
    // The topside opens the slave end by its name, as its own (exclusive) user.
    let device = slave.name().expect("the pty's name");
    drop(slave);
    master.set_timeout(Duration::from_millis(1)).unwrap();

    // The vehicle: the firmware library, fixed-rate on the host's clock.
    let stop = Arc::new(AtomicBool::new(false));
    let vehicle = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            let mut fw =
                InProcessFirmware::with_config(Config::fixed_rate(firmware::protocol::Board::Host))
                    .unwrap();
            let mut buf = [0u8; 256];
            while !stop.load(Ordering::Relaxed) {
                // Until the topside opens its end, the pty reads and writes fail: a UART
                // with nobody listening, its bytes lost.
                let n = master.read(&mut buf).unwrap_or_else(|_| {
                    std::thread::sleep(Duration::from_millis(1));
                    0
                });
                let out = fw.pass(&buf[..n]);
                if !out.is_empty() {
                    let _ = master.write_all(&out);
                }
            }
            fw.app().autopilot().controller().gains().tracking.xy_kp
        })
    };

    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("topside-serial");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let port = free_udp_port();
    let mut topside = gcs::topside_serial(&device, port, &dir, 30);

    let gcs = mavlink::connect::<MavMessage>(&format!("udpin:127.0.0.1:{port}")).unwrap();
    let hb = wait(&gcs, Duration::from_secs(10), |m| match m {
        MavMessage::HEARTBEAT(h) => Some(h.clone()),
        _ => None,
    })
    .expect("a HEARTBEAT through the serial line");
    assert_eq!(hb.mavtype, MavType::MAV_TYPE_SUBMARINE);

    // A parameter change goes down the serial line and is acknowledged by the vehicle.
    send(
        &gcs,
        &MavMessage::PARAM_SET(PARAM_SET_DATA {
            param_value: 1.5,
            target_system: 1,
            target_component: 1,
            param_id: "TRK_XY_KP".into(),
            param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
        }),
    );
    let v = wait(&gcs, Duration::from_secs(5), |m| match m {
        MavMessage::PARAM_VALUE(p) if p.param_id.to_str().ok() == Some("TRK_XY_KP") => {
            Some(p.param_value)
        }
        _ => None,
    });
    assert_eq!(v, Some(1.5));

    // MANUAL is accepted; arming is refused with the vehicle's reason: no navigation.
    send(
        &gcs,
        &MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            param1: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED.bits() as f32,
            param2: 19.0,
            command: MavCmd::MAV_CMD_DO_SET_MODE,
            target_system: 1,
            target_component: 1,
            ..Default::default()
        }),
    );
    send(
        &gcs,
        &MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            param1: 1.0,
            command: MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            target_system: 1,
            target_component: 1,
            ..Default::default()
        }),
    );
    let mut refused = (None, None);
    let end = Instant::now() + Duration::from_secs(5);
    while Instant::now() < end && (refused.0.is_none() || refused.1.is_none()) {
        if let Some(m) = wait(&gcs, Duration::from_millis(100), |m| Some(m.clone())) {
            match m {
                MavMessage::COMMAND_ACK(a) if a.command == MavCmd::MAV_CMD_COMPONENT_ARM_DISARM => {
                    refused.0 = Some(a.result)
                }
                MavMessage::STATUSTEXT(t)
                    if t.text.to_str().unwrap_or("").contains("Arming refused") =>
                {
                    refused.1 = Some(t.text.to_str().unwrap_or("").to_string())
                }
                _ => {}
            }
        }
    }
    assert_eq!(refused.0, Some(MavResult::MAV_RESULT_DENIED));
    // The reason in words (a STATUSTEXT holds 50 characters: its first piece).
    assert_eq!(
        refused.1.as_deref(),
        Some("Arming refused: the vehicle has no fresh")
    );

    // A few seconds on the vehicle's own clock: the heartbeats keep its link failsafe quiet.
    std::thread::sleep(Duration::from_secs(3));
    let _ = topside.kill();
    let _ = topside.wait();
    stop.store(true, Ordering::Relaxed);
    let gain = vehicle.join().unwrap();
    assert_eq!(
        gain, 1.5,
        "the vehicle holds the gain set over the serial line"
    );

    // The tether log of this start, under its time-stamped name.
    let tether: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "tether"))
        .collect();
    assert_eq!(tether.len(), 1, "{tether:?}");
    let frames = tether_log::decode(&tether_log::read(&tether[0]).unwrap());
    let heartbeats = frames
        .commands
        .iter()
        .filter(|c| matches!(c.2, Cmd::Heartbeat { .. }))
        .count();
    let tel: Vec<_> = frames
        .replies
        .iter()
        .filter_map(|r| match r.2 {
            Reply::Telemetry(t) => Some(t),
            _ => None,
        })
        .collect();
    println!(
        "serial tether: {} commands ({heartbeats} heartbeats), {} replies ({} telemetry), {} dropped",
        frames.commands.len(),
        frames.replies.len(),
        tel.len(),
        frames.dropped
    );
    assert_eq!(frames.dropped, 0);
    assert!(heartbeats >= 25, "10 Hz heartbeats for more than 3 s");
    assert!(
        tel.len() >= 25,
        "the vehicle's 10 Hz telemetry for more than 3 s"
    );
    // Before the surface's first heartbeat the vehicle has had none, and says so; every
    // telemetry frame that left the vehicle after that heartbeat reached it (one telemetry
    // period, 100 ms, later in the surface's log) says the failsafe is quiet.
    let first_heartbeat_us = frames
        .commands
        .iter()
        .find(|c| matches!(c.2, Cmd::Heartbeat { .. }))
        .map(|c| c.0)
        .expect("a heartbeat in the tether log");
    let after: Vec<u16> = frames
        .replies
        .iter()
        .filter(|r| r.0 > first_heartbeat_us + 100_000)
        .filter_map(|r| match r.2 {
            Reply::Telemetry(t) => Some(t.faults),
            _ => None,
        })
        .collect();
    assert!(after.len() >= 25, "telemetry after the first heartbeat");
    assert!(
        after.iter().all(|f| f & fault::HEARTBEAT_LOST == 0),
        "no heartbeat lost on the vehicle once the surface's heartbeats flow"
    );
}

pub(crate) fn a_serial_device_that_is_not_there_is_a_clear_error() {
    let out = Command::new(gcs::rov_topside())
        .args([
            "--serial",
            "/dev/no-such-tty",
            "--mavlink",
            "udpout:127.0.0.1:9",
        ])
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("cannot open serial port /dev/no-such-tty"),
        "{err}"
    );
}
