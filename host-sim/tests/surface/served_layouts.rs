//! `host-sim vehicle` serving what the surface program's `--sim` path used to fly: a
//! topside-layout scenario (the topside MCU's App and its node behind the node link) and,
//! with `--qemu`, the firmware image in QEMU. Each is reached as a real vehicle is, through
//! the served tether, by a surface written with the protocol crate's sans-IO `Client` over a
//! `TcpStream` (no surface program): a session opened, armed, a mode, then Hold, the
//! telemetry read; the truth log shows the vehicle held within a bound. For the layout, the
//! node link is cut mid-dive and the topside's `Status` shows the node's fault.

use host_sim::tether::qemu::{image_or_skip, layout_images_or_skip};
use protocol::{fault, Answer, Client, Command, Event, Mode, NackReason, Reply, Status, Telemetry};
use std::collections::HashMap;
use std::io::{BufRead, BufReader, ErrorKind, Read, Write};
use std::net::TcpStream;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

/// How far the true position may wander horizontally from where it was when Hold was
/// taken, while held (m). Hold holds the vehicle's estimate at its entry, and a few seconds
/// into the dive that estimate rests on a few USBL fixes of 0.3 m (1 sigma): the truth moves
/// by the estimate's error then (0.15 to 0.23 m measured), within about two of its sigmas.
const HELD_HORIZONTAL_M: f64 = 0.4;

/// How far it may wander vertically (m): the depth is measured to millimetres (0.010 to
/// 0.011 m measured).
const HELD_VERTICAL_M: f64 = 0.03;

fn dir(name: &str) -> PathBuf {
    crate::gcs::scratch_dir(&format!("served-layouts-{name}"))
}

/// `nav-circle-3d` with `extra` appended (a `[deployment]` table).
fn scenario(d: &Path, extra: &str) -> String {
    let base = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenarios/nav-circle-3d.toml"
    ))
    .unwrap();
    let p = d.join("vehicle.toml");
    std::fs::write(&p, format!("{base}\n{extra}\n")).unwrap();
    p.to_string_lossy().into_owned()
}

/// The served vehicle, killed when dropped with its process group (its QEMU children: a
/// killed `host-sim` cannot stop them itself).
struct Vehicle {
    child: Child,
    port: u16,
}

impl Drop for Vehicle {
    fn drop(&mut self) {
        let _ = std::process::Command::new("kill")
            .args(["-KILL", "--", &format!("-{}", self.child.id())])
            .status();
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// `host-sim vehicle SCENARIO` on a free port, its output in `out`.
fn vehicle(scenario: &str, out: &Path, extra: &[&str]) -> Vehicle {
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["vehicle", scenario, "--listen", "tcp:127.0.0.1:0", "--out"])
        .arg(out)
        .args(extra)
        .stdout(Stdio::piped())
        .process_group(0)
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.as_mut().unwrap())
        .read_line(&mut line)
        .unwrap();
    eprintln!("{}", line.trim());
    let port = line
        .split("tcp:127.0.0.1:")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|p| p.parse().ok())
        .unwrap_or_else(|| panic!("no port in {line:?}"));
    Vehicle { child, port }
}

/// The surface's end of the served tether: the protocol's `Client` over a `TcpStream`, a
/// heartbeat every 100 ms of wall time once the session is open.
struct Surface {
    stream: TcpStream,
    client: Client,
    t0: Instant,
    next_heartbeat: Instant,
    answers: HashMap<u16, Result<(), NackReason>>,
    session: Option<u32>,
    telemetry: Vec<Telemetry>,
    status: Vec<Status>,
}

impl Surface {
    fn connect(port: u16) -> Self {
        let stream = TcpStream::connect(("127.0.0.1", port)).unwrap();
        stream
            .set_read_timeout(Some(Duration::from_millis(10)))
            .unwrap();
        stream.set_nodelay(true).unwrap();
        let now = Instant::now();
        Self {
            stream,
            client: Client::default(),
            t0: now,
            next_heartbeat: now,
            answers: HashMap::new(),
            session: None,
            telemetry: Vec::new(),
            status: Vec::new(),
        }
    }

    fn now_us(&self) -> u64 {
        self.t0.elapsed().as_micros() as u64
    }

    /// Heartbeats when due, and everything the vehicle sent.
    fn pump(&mut self) {
        if self.session.is_some() && Instant::now() >= self.next_heartbeat {
            self.next_heartbeat += Duration::from_millis(100);
            let t_us = self.now_us();
            let sent = self
                .client
                .send(&Command::Heartbeat { t_us }, t_us)
                .unwrap();
            self.stream.write_all(sent.frame.bytes()).unwrap();
        }
        let mut buf = [0u8; 4096];
        let n = match self.stream.read(&mut buf) {
            Ok(0) => panic!("the vehicle closed the tether"),
            Ok(n) => n,
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => 0,
            Err(e) => panic!("{e}"),
        };
        let mut rest = &buf[..n];
        while let Some(e) = self.client.receive(&mut rest) {
            if let Event::Reply { reply, answer, .. } = e {
                match answer {
                    Some(Answer::Session { session }) => self.session = Some(session),
                    Some(Answer::Command { seq, result }) => {
                        self.answers.insert(seq, result);
                    }
                    _ => {}
                }
                match reply {
                    Reply::Telemetry(t) => self.telemetry.push(t),
                    Reply::Status(s) => self.status.push(s),
                    _ => {}
                }
            }
        }
    }

    fn open(&mut self) {
        let f = self.client.open(0x5E55_1011, self.now_us()).unwrap();
        self.stream.write_all(f.bytes()).unwrap();
        let deadline = Instant::now() + Duration::from_secs(10);
        while self.session.is_none() {
            assert!(Instant::now() < deadline, "no session within 10 s");
            self.pump();
        }
    }

    /// Send `cmd`, its answer.
    fn command(&mut self, cmd: &Command) -> Result<(), NackReason> {
        let now = self.now_us();
        let sent = self.client.send(cmd, now).unwrap();
        self.stream.write_all(sent.frame.bytes()).unwrap();
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            if let Some(r) = self.answers.remove(&sent.seq) {
                return r;
            }
            assert!(
                Instant::now() < deadline,
                "{cmd:?} not answered within 10 s"
            );
            self.pump();
        }
    }

    /// The vehicle's time (s): its latest telemetry's.
    fn vehicle_s(&self) -> f64 {
        self.telemetry.last().map_or(0.0, |t| t.t_us as f64 * 1e-6)
    }

    /// Pump until the vehicle's time reaches `t_s` (or `wall` passes: a failure).
    fn until_vehicle_s(&mut self, t_s: f64, wall: Duration) {
        let deadline = Instant::now() + wall;
        while self.vehicle_s() < t_s {
            assert!(
                Instant::now() < deadline,
                "the vehicle's time did not reach {t_s} s within {wall:?} (at {} s)",
                self.vehicle_s()
            );
            self.pump();
        }
    }

    /// Hold, asked again while the estimate is not ready; the vehicle's time it was taken.
    fn hold(&mut self) -> f64 {
        let deadline = Instant::now() + Duration::from_secs(60);
        loop {
            match self.command(&Command::SetMode(Mode::Hold)) {
                Ok(()) => return self.vehicle_s(),
                Err(NackReason::NavNotReady(_)) if Instant::now() < deadline => {
                    let until = Instant::now() + Duration::from_millis(500);
                    while Instant::now() < until {
                        self.pump();
                    }
                }
                Err(r) => panic!("Hold refused: {r:?}"),
            }
        }
    }
}

/// The truth log's rows as (t_s, true position, mode).
fn truth(path: &Path) -> Vec<(f64, [f64; 3], String)> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let cols: Vec<&str> = lines.next().unwrap().split(',').collect();
    let at = |name: &str| cols.iter().position(|c| *c == name).unwrap();
    let (t, x, y, z, mode) = (at("t_s"), at("x_m"), at("y_m"), at("z_m"), at("mode"));
    lines
        .filter_map(|l| {
            let v: Vec<&str> = l.split(',').collect();
            if v.len() != cols.len() {
                return None;
            }
            let f = |i: usize| v[i].parse::<f64>().ok();
            Some((f(t)?, [f(x)?, f(y)?, f(z)?], v[mode].to_string()))
        })
        .collect()
}

/// The largest horizontal and vertical distance of the true position, in `[from_s, to_s]`,
/// from where it was at `from_s`; every row there in Hold.
fn wander_m(rows: &[(f64, [f64; 3], String)], from_s: f64, to_s: f64) -> (f64, f64, usize) {
    let held: Vec<_> = rows
        .iter()
        .filter(|(t, _, _)| *t >= from_s && *t <= to_s)
        .collect();
    let p0 = held.first().expect("no truth rows while held").1;
    let (mut h, mut v) = (0.0f64, 0.0f64);
    for (t, p, mode) in &held {
        assert_eq!(mode, "Hold", "at {t} s");
        h = h.max((p[0] - p0[0]).hypot(p[1] - p0[1]));
        v = v.max((p[2] - p0[2]).abs());
    }
    (h, v, held.len())
}

/// The session every served kind flies: armed, DepthHold, then Hold; its telemetry read.
/// Returns the vehicle's time Hold was taken.
fn arm_and_hold(s: &mut Surface) -> f64 {
    s.open();
    s.until_vehicle_s(0.5, Duration::from_secs(120));
    assert_eq!(s.command(&Command::Arm), Ok(()));
    assert_eq!(s.command(&Command::SetMode(Mode::DepthHold)), Ok(()));
    let t = s.vehicle_s();
    s.until_vehicle_s(t + 2.0, Duration::from_secs(120));
    let last = *s.telemetry.last().unwrap();
    assert!(last.armed && last.mode == Mode::DepthHold, "{last:?}");
    let hold_s = s.hold();
    s.until_vehicle_s(hold_s + 1.0, Duration::from_secs(120));
    let last = *s.telemetry.last().unwrap();
    assert!(last.armed && last.mode == Mode::Hold, "{last:?}");
    hold_s
}

/// The vehicle's process ends at its `--duration` with exit 0.
fn ends(mut v: Vehicle, wall: Duration) {
    let deadline = Instant::now() + wall;
    loop {
        if let Some(st) = v.child.try_wait().unwrap() {
            assert_eq!(st.code(), Some(0));
            return;
        }
        assert!(
            Instant::now() < deadline,
            "the vehicle did not end in {wall:?}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn check_held(out: &Path, hold_s: f64, to_s: f64) {
    let rows = truth(&out.join("nav-circle-3d.truth.csv"));
    // The first second after the mode change: the law takes the point over.
    let (h, v, n) = wander_m(&rows, hold_s + 1.0, to_s);
    eprintln!(
        "held from {:.2} s to {to_s} s ({n} rows): true position within {h:.3} m horizontally, \
         {v:.3} m vertically",
        hold_s + 1.0
    );
    assert!(n > 100, "{n} rows");
    assert!(
        rows.last().is_some_and(|r| r.0 >= to_s),
        "the truth log ends before {to_s} s"
    );
    assert!(
        h <= HELD_HORIZONTAL_M && v <= HELD_VERTICAL_M,
        "{h} m, {v} m"
    );
}

pub(crate) fn the_topside_layout_served_in_process() {
    let d = dir("in-process");
    let sc = scenario(
        &d,
        "[deployment]\ncontrol = \"topside\"\ntether_cut_s = 40.0",
    );
    // An ELF names one image; the layout is two: refused before any work.
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["vehicle", &sc, "--qemu", "some.elf", "--out"])
        .arg(&d)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("two images"), "{err}");

    let v = vehicle(
        &sc,
        &d,
        &["--speedup", "2", "--duration", "50", "--start-nav"],
    );
    let mut s = Surface::connect(v.port);
    let hold_s = arm_and_hold(&mut s);
    s.until_vehicle_s(39.0, Duration::from_secs(60));
    // Held, before the cut: no node fault (arming has settled by then).
    let before: Vec<u16> = s
        .status
        .iter()
        .filter(|st| st.t_us as f64 * 1e-6 >= hold_s)
        .map(|st| st.faults)
        .collect();
    assert!(
        before.len() > 50,
        "{} Status frames while held",
        before.len()
    );
    assert!(
        before
            .iter()
            .all(|f| f & (fault::NODE_LINK_LOST | fault::NODE_NOT_ARMED) == 0),
        "node faults before the cut: {before:?}"
    );
    // The node link is cut at 40 s: the topside's Status says so.
    s.until_vehicle_s(42.0, Duration::from_secs(30));
    let lost = s
        .status
        .iter()
        .find(|st| st.t_us >= 40_000_000 && st.faults & fault::NODE_LINK_LOST != 0)
        .map(|st| st.t_us as f64 * 1e-6);
    eprintln!("node link lost in the topside's Status at {lost:?} s");
    assert!(lost.is_some_and(|t| t <= 40.5), "{lost:?}");
    let health = s.status.last().unwrap().nav_health;
    eprintln!("estimator: {health:?}");
    drop(s);
    ends(v, Duration::from_secs(60));
    check_held(&d, hold_s, 39.5);
}

pub(crate) fn the_onboard_image_served_in_qemu() {
    let Some(elf) = image_or_skip().unwrap() else {
        return;
    };
    let d = dir("qemu");
    let sc = scenario(&d, "");
    let elf = elf.to_string_lossy().into_owned();
    let v = vehicle(
        &sc,
        &d,
        &["--qemu", &elf, "--duration", "12", "--start-nav"],
    );
    let mut s = Surface::connect(v.port);
    let hold_s = arm_and_hold(&mut s);
    s.until_vehicle_s(11.0, Duration::from_secs(300));
    // A board's telemetry period, not one per lock-step.
    let n = s.telemetry.len();
    let span = s.vehicle_s() - s.telemetry[0].t_us as f64 * 1e-6;
    eprintln!("{n} telemetry frames over {span:.1} s");
    assert!((n as f64) <= span / 0.1 + 2.0, "{n} over {span} s");
    // Held, the surface's heartbeats reach the image on its clock.
    let held: Vec<u16> = s
        .status
        .iter()
        .filter(|st| st.t_us as f64 * 1e-6 >= hold_s)
        .map(|st| st.faults)
        .collect();
    assert!(held.len() > 20, "{} Status frames while held", held.len());
    assert!(
        held.iter().all(|f| f & fault::HEARTBEAT_LOST == 0),
        "heartbeat lost while held: {held:?}"
    );
    drop(s);
    ends(v, Duration::from_secs(300));
    check_held(&d, hold_s, 10.5);
}

/// The topside layout's two images served in real time: a hold, as in process. A long test
/// (two emulators and the plant in real time; its time in docs/testing.md).
pub(crate) fn the_topside_layout_served_in_qemu() {
    if !crate::long_test("served_layouts::the_topside_layout_served_in_qemu", 25) {
        return;
    }
    let Some(_) = layout_images_or_skip().unwrap() else {
        return;
    };
    let d = dir("layout-qemu");
    let sc = scenario(&d, "[deployment]\ncontrol = \"topside\"");
    let v = vehicle(&sc, &d, &["--qemu", "--duration", "10", "--start-nav"]);
    let mut s = Surface::connect(v.port);
    let hold_s = arm_and_hold(&mut s);
    s.until_vehicle_s(9.0, Duration::from_secs(600));
    drop(s);
    ends(v, Duration::from_secs(600));
    check_held(&d, hold_s, 8.5);
}
