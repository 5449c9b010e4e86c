//! The surface program against a ground station's raw bytes: garbage, two commanders, two
//! uploads, a parameter it must not move, a TCP station that comes back, two starts.

use super::*;

/// A ground station's raw bytes to a topside on `udpout:127.0.0.1:PORT`: the test binds PORT,
/// learns the topside's address from its first datagram and answers it.
struct RawStation {
    socket: UdpSocket,
    topside: std::net::SocketAddr,
}

impl RawStation {
    /// Bound to `port`, waiting up to 60 s for the topside's first datagram.
    fn new(port: u16) -> Self {
        let socket = UdpSocket::bind(("127.0.0.1", port)).unwrap();
        socket
            .set_read_timeout(Some(Duration::from_millis(100)))
            .unwrap();
        let end = Instant::now() + Duration::from_secs(60);
        let mut buf = [0u8; 600];
        loop {
            assert!(Instant::now() < end, "no datagram from the topside in 60 s");
            if let Ok((_, from)) = socket.recv_from(&mut buf) {
                return Self {
                    socket,
                    topside: from,
                };
            }
        }
    }

    fn send_raw(&self, bytes: &[u8]) {
        self.socket.send_to(bytes, self.topside).unwrap();
    }

    fn send(&self, msg: &mavlink::dialects::ardupilotmega::MavMessage) {
        let mut frame = Vec::new();
        let header = mavlink::MavHeader {
            system_id: 255,
            component_id: 190,
            sequence: 0,
        };
        mavlink::write_v2_msg(&mut frame, header, msg).unwrap();
        self.send_raw(&frame);
    }

    /// The first message `pick` takes within `timeout` (polled, not slept).
    fn wait<T>(
        &self,
        timeout: Duration,
        mut pick: impl FnMut(&mavlink::dialects::ardupilotmega::MavMessage) -> Option<T>,
    ) -> Option<T> {
        let end = Instant::now() + timeout;
        let mut buf = [0u8; 2048];
        while Instant::now() < end {
            let Ok((n, _)) = self.socket.recv_from(&mut buf) else {
                continue;
            };
            let mut reader = mavlink::MavlinkReader::new(&buf[..n]);
            while let Ok((_, m)) =
                reader.read_any_message::<mavlink::dialects::ardupilotmega::MavMessage>()
            {
                if let Some(t) = pick(&m) {
                    return Some(t);
                }
            }
        }
        None
    }

    /// The topside answers a parameter read within `timeout`: it is alive and listening.
    fn answers(&self, timeout: Duration) -> bool {
        use mavlink::dialects::ardupilotmega::{MavMessage, PARAM_REQUEST_READ_DATA};
        let end = Instant::now() + timeout;
        while Instant::now() < end {
            self.send(&MavMessage::PARAM_REQUEST_READ(PARAM_REQUEST_READ_DATA {
                param_index: 0,
                target_system: 1,
                target_component: 1,
                param_id: "".into(),
            }));
            let got = self.wait(Duration::from_millis(500), |m| {
                matches!(m, MavMessage::PARAM_VALUE(p) if p.param_index == 0).then_some(())
            });
            if got.is_some() {
                return true;
            }
        }
        false
    }
}

/// An empty UDP datagram, garbage bytes and a truncated frame from a ground
/// station are logged and dropped; the topside lives on and answers the next request.
pub(crate) fn an_empty_datagram_and_garbage_do_not_end_the_topside() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("topside-empty-datagram");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let port = free_udp_port();
    let mut child = dive(
        "circle-3d",
        port,
        &dir.join("e.tlog"),
        &dir.join("params.json"),
        &["--duration", "300"],
    );
    let station = RawStation::new(port);
    assert!(station.answers(Duration::from_secs(20)), "alive at first");
    station.send_raw(&[]);
    station.send_raw(&[0xFD, 0x09, 0, 0]);
    station.send_raw(&[0x55; 300]);
    station.send_raw(&[]);
    let alive = station.answers(Duration::from_secs(20));
    let exited = child.topside.try_wait().unwrap();
    stop(child);
    assert!(exited.is_none(), "the topside ended: {exited:?}");
    assert!(alive, "the topside answers after the empty datagram");
}

/// The MAVLink probes: station B's sticks do not override A's (B is
/// told why), B's commands are refused until it takes control with CHANGE_OPERATOR_CONTROL;
/// ARM_DISARM with NaN does not disarm, DO_SET_MODE with NaN or -5 does not give STABILIZE,
/// a GUIDED target 50 m above the surface is refused; anyone may disarm.
pub(crate) fn one_commander_at_a_time_and_bad_commands_change_nothing() {
    if !pymavlink_or_skip() {
        return;
    }
    let (a, b) = (free_udp_port(), free_udp_port());
    let second = format!("udpout:127.0.0.1:{b}");
    let out = client_session(
        "commander",
        "pymavlink_commander.py",
        a,
        &["--mavlink", &second],
        &[&b.to_string()],
    );
    assert!(out.contains("PASS: disarmed"), "the session ran to its end");
}

/// Interleaved uploads from two stations: the second refused, the mission
/// is the first station's; an upload that stops is abandoned; a new mission in AUTO refused.
pub(crate) fn a_mission_upload_is_one_stations_transaction_and_auto_keeps_its_mission() {
    if !pymavlink_or_skip() {
        return;
    }
    let (a, b) = (free_udp_port(), free_udp_port());
    let second = format!("udpout:127.0.0.1:{b}");
    let out = client_session(
        "two-uploads",
        "pymavlink_two_uploads.py",
        a,
        &["--mavlink", &second, "--speedup", "4"],
        &[&b.to_string()],
    );
    assert!(out.contains("PASS: disarmed"), "the session ran to its end");
}

/// `VEH_PWM_NEUTRAL` is shown but not settable: a `PARAM_SET` to 1150 us is refused with
/// the reason, the value in force (1500) is answered and nothing is saved.
pub(crate) fn the_escs_neutral_is_not_a_parameter_a_ground_station_can_move() {
    use mavlink::dialects::ardupilotmega::{MavMessage, MavParamType, PARAM_SET_DATA};
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("topside-neutral");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let port = free_udp_port();
    let params = dir.join("params.json");
    let child = topside(port, &dir.join("n.tlog"), &params, &[]);
    let station = RawStation::new(port);
    assert!(station.answers(Duration::from_secs(20)));
    station.send(&MavMessage::PARAM_SET(PARAM_SET_DATA {
        param_value: 1150.0,
        target_system: 1,
        target_component: 1,
        param_id: "VEH_PWM_NEUTRAL".into(),
        param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
    }));
    // The reason comes in 50-character STATUSTEXT lines, before the value.
    let mut why = String::new();
    let value = station.wait(Duration::from_secs(10), |m| match m {
        MavMessage::STATUSTEXT(s) => {
            let line = String::from_utf8_lossy(&s.text.to_vec()).to_string();
            why.push_str(line.trim_end_matches('\0'));
            why.push(' ');
            None
        }
        MavMessage::PARAM_VALUE(p) if p.param_id.to_str().ok() == Some("VEH_PWM_NEUTRAL") => {
            Some(p.param_value)
        }
        _ => None,
    });
    stop(child);
    println!("answer: {value:?}, {why:?}");
    assert_eq!(value, Some(1500.0), "the neutral in force is answered");
    assert!(why.contains("VEH_PWM_NEUTRAL refused"), "{why}");
    assert!(!params.exists(), "nothing saved");
}

/// A TCP ground station that disconnects does not end the topside, and
/// the listener accepts it again: the reconnected station is answered.
pub(crate) fn a_tcp_ground_station_may_disconnect_and_come_back() {
    use std::io::{Read, Write};
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("topside-tcp");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let tcpin = format!("tcpin:127.0.0.1:{port}");
    let mut child = dive(
        "circle-3d",
        free_udp_port(),
        &dir.join("t.tlog"),
        &dir.join("params.json"),
        &["--duration", "300", "--mavlink", &tcpin],
    );
    let connect = || {
        let end = Instant::now() + Duration::from_secs(60);
        loop {
            if let Ok(s) = std::net::TcpStream::connect(("127.0.0.1", port)) {
                s.set_read_timeout(Some(Duration::from_millis(200)))
                    .unwrap();
                return s;
            }
            assert!(
                Instant::now() < end,
                "the topside does not listen on {port}"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    };
    // Bytes from the topside within `timeout`: it is alive and talks to this station.
    let hears = |s: &mut std::net::TcpStream, timeout: Duration| {
        let end = Instant::now() + timeout;
        let mut buf = [0u8; 1024];
        while Instant::now() < end {
            if let Ok(n) = s.read(&mut buf) {
                if n > 0 && buf[..n].contains(&0xFD) {
                    return true;
                }
            }
        }
        false
    };
    let mut first = connect();
    assert!(
        hears(&mut first, Duration::from_secs(30)),
        "the first connection is served"
    );
    // Garbage, half a frame, then gone.
    first.write_all(&[0x13; 64]).unwrap();
    first.write_all(&[0xFD, 9, 0, 0, 7]).unwrap();
    drop(first);
    std::thread::sleep(Duration::from_millis(300));
    let mut second = connect();
    let mut frame = Vec::new();
    mavlink::write_v2_msg(
        &mut frame,
        mavlink::MavHeader {
            system_id: 255,
            component_id: 190,
            sequence: 0,
        },
        &mavlink::dialects::ardupilotmega::MavMessage::PARAM_REQUEST_LIST(Default::default()),
    )
    .unwrap();
    second.write_all(&frame).unwrap();
    let served = hears(&mut second, Duration::from_secs(30));
    let exited = child.topside.try_wait().unwrap();
    stop(child);
    assert!(exited.is_none(), "the topside ended: {exited:?}");
    assert!(served, "the reconnected station is served");
}

/// Each start writes new, time-stamped logs; the first start's files are
/// still there, byte for byte, after the second.
pub(crate) fn two_starts_write_two_sets_of_logs_and_the_first_is_intact() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("topside-two-starts");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let run = || {
        let mut child = dive(
            "circle-3d",
            free_udp_port(),
            &dir.join("dive.tlog"),
            &dir.join("params.json"),
            &["--duration", "2"],
        );
        let end = Instant::now() + Duration::from_secs(120);
        loop {
            if let Some(status) = child.topside.try_wait().unwrap() {
                stop(child);
                assert!(status.success(), "{status:?}");
                return;
            }
            assert!(
                Instant::now() < end,
                "the topside did not stop at --duration"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    };
    run();
    let first: Vec<(PathBuf, Vec<u8>)> = ["tlog", "tether"]
        .iter()
        .map(|ext| {
            let p = only_file(&dir, ext);
            let bytes = std::fs::read(&p).unwrap();
            (p, bytes)
        })
        .collect();
    assert!(
        first.iter().all(|(_, b)| b.len() > 100),
        "the first start logged"
    );
    run();
    assert_eq!(files(&dir, "tlog").len(), 2);
    assert_eq!(files(&dir, "tether").len(), 2);
    for (p, bytes) in &first {
        assert_eq!(&std::fs::read(p).unwrap(), bytes, "{} intact", p.display());
    }
    let name = first[0]
        .0
        .file_name()
        .unwrap()
        .to_string_lossy()
        .to_string();
    assert!(name.starts_with("dive-20"), "time-stamped: {name}");
}
