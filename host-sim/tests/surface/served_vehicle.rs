//! `host-sim vehicle`: the simulator serves a vehicle's tether on a TCP port (SITL), and a
//! surface program reaches it as a real one (`rov-topside --tcp`).
//!
//! Without pymavlink: the refusals (exit 2), a busy port (exit 3), the end at `--duration`
//! (exit 0), a session opened through the served tether by the host's own `Link`, the
//! vehicle's failsafe acting while the tether is cut, a second surface refused while one is
//! served and a new one served after a disconnect. With pymavlink
//! (`clients/pymavlink_served.py`): the parameters read, ALT_HOLD and POSHOLD armed, GUIDED to
//! a point and disarmed through `rov-topside --tcp`, held against the served vehicle's truth
//! log and against the same session through the former lock-step surface.

use crate::gcs;

use firmware::protocol::{Command as Cmd, Reply};
use gcs::{free_udp_port, pymavlink_or_skip, rov_topside, serve_vehicle as vehicle, stop};
use host_sim::tether::link::{tcp_port, Link};
use std::collections::HashMap;
use std::net::{TcpListener, TcpStream};
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// Simulated time per wall time of the pymavlink sessions (the surface runs at the same; at 4x
/// the vehicle saw the debug topside's heartbeats more than 0.5 s apart on this machine: its
/// failsafe flickered and arming was refused `NoHeartbeat`).
const SPEEDUP: &str = "2";

fn dir(name: &str) -> PathBuf {
    crate::gcs::scratch_dir(&format!("served-{name}"))
}

fn host_sim(args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_host-sim"));
    c.args(args);
    c
}

/// The truth log's columns by name, and its complete rows.
fn read_csv(path: &Path) -> (HashMap<String, usize>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let cols: HashMap<String, usize> = lines
        .next()
        .unwrap()
        .split(',')
        .enumerate()
        .map(|(i, c)| (c.to_string(), i))
        .collect();
    // A killed process may leave its last line unfinished.
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

pub(crate) fn refused_before_start_and_a_busy_port() {
    let d = dir("refused");
    let out = d.to_string_lossy().to_string();
    for (args, why) in [
        (vec!["--speedup", "0.5"], "--speedup must be >= 1"),
        (vec!["--qemu", "/nonexistent.elf"], "no such file"),
        (vec!["--usbl-to", "127.0.0.1:9", "--qemu"], "--usbl-to"),
        (vec!["--listen", "udp:127.0.0.1:5"], "tcp:HOST:PORT"),
        (vec!["--duration=-1"], "--duration"),
    ] {
        let o = host_sim(&["vehicle", "circle-3d", "--out", &out])
            .args(&args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(why), "{args:?}: {err}");
    }
    let o = host_sim(&["vehicle", "no-such-scenario", "--out", &out])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    // A scenario of the topside layout is two images: one ELF is refused.
    let layout = d.join("layout.toml");
    let base = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenarios/nav-circle-3d.toml"
    ))
    .unwrap();
    std::fs::write(
        &layout,
        format!("{base}\n[deployment]\ncontrol = \"topside\"\n"),
    )
    .unwrap();
    let o = host_sim(&["vehicle", &layout.to_string_lossy(), "--out", &out])
        .args(["--qemu", "some.elf"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("two images"), "{err}");
    // A port in use: could not complete.
    let busy = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = format!("tcp:{}", busy.local_addr().unwrap());
    let o = host_sim(&["vehicle", "circle-3d", "--listen", &addr, "--out", &out])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(err.contains("cannot listen"), "{err}");
    assert!(
        !d.join("circle-3d.truth.csv").exists(),
        "nothing written before the start"
    );
}

/// A surface of our own (`tether::Link`) opens a session through the served tether, arms,
/// is cut; the vehicle's failsafe disarms it on its own clock; a second connection while one
/// is served is closed at once; a new surface after the cut is served; exit 0 at
/// `--duration`, the truth log one row per control period.
pub(crate) fn a_session_through_the_served_tether_and_a_cut() {
    let d = dir("session");
    let (mut child, port) = vehicle("circle-3d", &d, &["--speedup", "2", "--duration", "8"]);
    let t0 = Instant::now();
    let connect = || {
        let s = TcpStream::connect(("127.0.0.1", port)).unwrap();
        Link::new(Box::new(tcp_port(s).unwrap()), None)
    };
    let tmo = Duration::from_millis(500);
    let mut link = connect();
    link.open_session().unwrap();
    let hb = link.send(&Cmd::Heartbeat { t_us: 0 }).unwrap();
    let status = link
        .wait_for(
            Duration::from_secs(2),
            |r| match r {
                Reply::Status(st) if st.heartbeat_seq == hb => Some(*st),
                _ => None,
            },
            |_| {},
        )
        .unwrap()
        .expect("a Status answers the heartbeat, under its number");
    assert!(status.t_us > 0, "the vehicle's clock runs: {status:?}");
    assert_eq!(
        link.command(&Cmd::Arm, tmo, 3, |_| {}).unwrap(),
        Ok(()),
        "armed"
    );
    // A second surface meanwhile: closed at once (it reads the end of the stream). The first
    // keeps its heartbeats going while the second waits (at 2x the vehicle's 1 s heartbeat
    // timeout is 0.5 s of wall time, which a loaded machine can take to close the second).
    let mut second = TcpStream::connect(("127.0.0.1", port)).unwrap();
    second
        .set_read_timeout(Some(Duration::from_millis(50)))
        .unwrap();
    let mut b = [0u8; 16];
    let refuse_by = Instant::now() + Duration::from_secs(2);
    let refused = loop {
        link.send(&Cmd::Heartbeat { t_us: 0 }).unwrap();
        match std::io::Read::read(&mut second, &mut b) {
            // The end of the stream: closed.
            Ok(0) => break true,
            Ok(_) => break false,
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                if Instant::now() >= refuse_by {
                    break false;
                }
            }
            // Reset: closed too.
            Err(_) => break true,
        }
    };
    assert!(refused, "a second surface is refused within 2 s");
    // Telemetry flows while the heartbeats come (one every 40 ms of wall time).
    let mut armed_seen = false;
    for _ in 0..10 {
        link.send(&Cmd::Heartbeat { t_us: 0 }).unwrap();
        let next = Instant::now() + Duration::from_millis(40);
        while let Some((_, r)) = link
            .recv(
                next.saturating_duration_since(Instant::now())
                    .max(Duration::from_millis(1)),
            )
            .unwrap()
        {
            if let Reply::Telemetry(t) = r {
                armed_seen |= t.armed;
            }
            if Instant::now() >= next {
                break;
            }
        }
    }
    assert!(armed_seen, "telemetry says armed");
    // The tether is cut: the vehicle disarms itself (heartbeat lost, 1 s).
    drop(link);
    std::thread::sleep(Duration::from_millis(1500));
    let mut link = connect();
    assert_eq!(
        link.command(
            &Cmd::SetMode(firmware::protocol::Mode::Idle),
            tmo,
            3,
            |_| {}
        )
        .unwrap(),
        Ok(()),
        "a new surface after the cut is served"
    );
    let status = child.wait().unwrap();
    assert!(status.success(), "exit 0 at --duration: {status:?}");
    assert!(t0.elapsed() < Duration::from_secs(30));
    let (c, rows) = read_csv(&d.join("circle-3d.truth.csv"));
    let (t, armed, surface) = (c["t_s"], c["armed"], c["surface"]);
    let period = rows[1][t] - rows[0][t];
    assert!(
        (rows.len() as f64 - 8.0 / period).abs() <= 1.0,
        "{} rows",
        rows.len()
    );
    let armed_at = rows.iter().position(|r| r[armed] == 1.0).expect("armed");
    let cut_at = armed_at
        + rows[armed_at..]
            .iter()
            .position(|r| r[surface] == 0.0)
            .expect("the cut");
    let disarmed_at = armed_at
        + rows[armed_at..]
            .iter()
            .position(|r| r[armed] == 0.0)
            .expect("disarmed by the failsafe");
    let after = rows[disarmed_at][t] - rows[cut_at][t];
    println!(
        "armed at {:.2} s, cut at {:.2} s, disarmed at {:.2} s ({after:.2} s after the cut)",
        rows[armed_at][t], rows[cut_at][t], rows[disarmed_at][t]
    );
    // The last heartbeat was at most a few ticks before the cut; the failsafe's 1 s.
    assert!((0.6..=1.3).contains(&after), "{after} s");
}

/// One pymavlink session through `rov-topside --tcp` against `host-sim vehicle`: the truth
/// log, the client's output.
fn fly(name: &str, target: [f64; 3]) -> (PathBuf, String) {
    let d = dir(name);
    let udp = free_udp_port();
    let tlog = d.join("s.tlog");
    let params = d.join("params.json");
    let (v, port) = vehicle(
        "circle-3d",
        &d,
        &["--speedup", SPEEDUP, "--duration", "600"],
    );
    let top = Command::new(rov_topside())
        .args(["--tcp", &format!("127.0.0.1:{port}")])
        .args(["--heartbeat-hz", "20"])
        .args(["--mavlink", &format!("udpout:127.0.0.1:{udp}")])
        .arg("--tlog")
        .arg(&tlog)
        .arg("--params")
        .arg(&params)
        .process_group(0)
        .spawn()
        .unwrap();
    let mut children = vec![top, v];
    let t: Vec<String> = target.iter().map(|v| v.to_string()).collect();
    let out = Command::new("python3")
        .arg(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/clients/pymavlink_served.py"
        ))
        .arg(udp.to_string())
        .args(&t)
        .output()
        .unwrap();
    for c in children.drain(..) {
        stop(c);
    }
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    println!("{name}:\n{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(
        out.status.success(),
        "the pymavlink session failed ({name})"
    );
    let path = d.join("circle-3d.truth.csv");
    (path, stdout)
}

/// What the truth log says of the GUIDED leg: the true distance to the target a fixed time
/// after the vehicle left the POSHOLD point, and at the disarm.
fn guided_errors(path: &Path, target: [f64; 3], after_s: f64) -> (f64, f64) {
    let (c, rows) = read_csv(path);
    let (t, armed) = (c["t_s"], c["armed"]);
    let pos = |r: &Vec<f64>| [r[c["x_m"]], r[c["y_m"]], r[c["z_m"]]];
    let dist = |a: [f64; 3], b: [f64; 3]| {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    };
    let armed_rows: Vec<&Vec<f64>> = rows.iter().filter(|r| r[armed] == 1.0).collect();
    let last = armed_rows.last().expect("armed rows");
    // The POSHOLD point: where it was when armed; it leaves it for the target.
    let hold = pos(armed_rows[0]);
    let left = armed_rows
        .iter()
        .find(|r| dist(pos(r), hold) > 0.01)
        .expect("the vehicle left the hold point");
    let at = armed_rows
        .iter()
        .find(|r| r[t] >= left[t] + after_s)
        .expect("armed long enough after the GUIDED target");
    (dist(pos(at), target), dist(pos(last), target))
}

pub(crate) fn pymavlink_flies_a_served_vehicle_through_topside_tcp() {
    if !crate::long_test(
        "served_vehicle::pymavlink_flies_a_served_vehicle_through_topside_tcp",
        90,
    ) {
        return;
    }
    if !pymavlink_or_skip() {
        return;
    }
    let target = [2.0, 1.0, 2.5];
    let t0 = Instant::now();
    let (served, out) = fly("tcp", target);
    assert!(
        out.contains("PASS: HEARTBEAT says disarmed"),
        "ran to its end"
    );
    // 15 s after the vehicle left the hold point: well past the first arrival (~10 s).
    let after_s = 15.0;
    let (e_tcp, end_tcp) = guided_errors(&served, target, after_s);
    // The same session through the simulator's former in-process surface (`host-sim topside
    // --sim circle-3d`, lock-step), measured before the surface program became its own: 8.1 mm.
    let e_sim = 0.0081;
    println!(
        "GUIDED to {target:?}: true distance {after_s} s after leaving the hold point: \
         rov-topside --tcp against host-sim vehicle {:.1} mm (lock-step baseline {:.1} mm); at the \
         disarm {:.1} mm; {:.0} s wall",
        e_tcp * 1e3,
        e_sim * 1e3,
        end_tcp * 1e3,
        t0.elapsed().as_secs_f64()
    );
    assert!(
        end_tcp <= 0.3,
        "GUIDED target reached: {end_tcp} m at the disarm"
    );
    assert!(e_tcp <= 0.3, "GUIDED target reached: {e_tcp} m");
    assert!(
        (e_tcp - e_sim).abs() <= 0.1 * e_sim + 0.01,
        "served {e_tcp} m against the lock-step baseline {e_sim} m"
    );
}
