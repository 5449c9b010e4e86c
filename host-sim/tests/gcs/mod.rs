//! What the tests that fly `host-sim topside` from a real ground station (pymavlink, MAVProxy)
//! share: the check that pymavlink is there (SKIPPED with the fix, or a failure with
//! `ROV_REQUIRE_PYMAVLINK=1` as `.ci/run` sets it), a free UDP port, stopping a topside.

// Each test binary that includes this module uses a part of it.
#![allow(dead_code)]

use std::ffi::OsStr;
use std::net::UdpSocket;
use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::{Child, Command, Stdio};

/// Is pymavlink importable? Without it: SKIPPED with the fix, or a panic when CI requires it.
pub fn pymavlink_or_skip() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import pymavlink"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        let why = "python3 with pymavlink not found";
        if std::env::var("ROV_REQUIRE_PYMAVLINK").is_ok_and(|v| v == "1") {
            panic!("{why} and ROV_REQUIRE_PYMAVLINK=1; fix: python3 -m pip install pymavlink");
        }
        println!("SKIPPED: {why}; fix: python3 -m pip install pymavlink");
    }
    ok
}

/// A UDP port nobody listens on now.
pub fn free_udp_port() -> u16 {
    UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Stop a topside and what it started (the emulator of `--emulated`): a killed process runs
/// no destructors, so its whole process group (started with `process_group(0)`) is killed.
pub fn stop(mut child: Child) {
    let _ = Command::new("kill")
        .args(["-KILL", "--", &format!("-{}", child.id())])
        .status();
    let _ = child.kill();
    let _ = child.wait();
}

/// Wait up to `timeout` for a topside started with `--duration` to stop by itself, and
/// assert it exited 0; past the timeout it is stopped (its group) and the test fails.
pub fn exits_at_duration(mut child: Child, timeout: std::time::Duration) {
    let end = std::time::Instant::now() + timeout;
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if std::time::Instant::now() > end {
            stop(child);
            panic!("the topside did not stop at --duration within {timeout:?}");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    assert!(status.success(), "topside exit {status:?}");
}

/// `host-sim topside --sim SCENARIO` sending MAVLink to `udpout:127.0.0.1:PORT`, its tlog and
/// parameters file where the test says, with `extra` arguments (`--duration`, `--speedup`,
/// ...), in a process group of its own so that [`stop`] ends what it starts (QEMU).
pub fn topside_sim(
    scenario: impl AsRef<OsStr>,
    port: u16,
    tlog: &Path,
    params: &Path,
    extra: &[&str],
) -> Child {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .arg("topside")
        .arg("--sim")
        .arg(scenario)
        .args(["--mavlink", &format!("udpout:127.0.0.1:{port}")])
        .arg("--tlog")
        .arg(tlog)
        .arg("--params")
        .arg(params)
        .args(extra)
        .process_group(0)
        .spawn()
        .unwrap()
}

/// `host-sim topside --serial DEVICE` (115,200 Bd) sending MAVLink to
/// `udpout:127.0.0.1:PORT`, its tlog and parameters in `dir`, stopping after `duration_s`
/// of its own time.
pub fn topside_serial(device: &str, port: u16, dir: &Path, duration_s: u32) -> Child {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args([
            "topside",
            "--serial",
            device,
            "--baud",
            "115200",
            "--mavlink",
        ])
        .arg(format!("udpout:127.0.0.1:{port}"))
        .arg("--tlog")
        .arg(dir.join("serial.tlog"))
        .arg("--params")
        .arg(dir.join("params.json"))
        .args(["--duration", &duration_s.to_string()])
        .spawn()
        .unwrap()
}

/// The next message from a `mavlink`-crate ground station that `pick` takes, within
/// `timeout`.
pub fn wait<T>(
    gcs: &mavlink::Connection<mavlink::dialects::ardupilotmega::MavMessage>,
    timeout: std::time::Duration,
    mut pick: impl FnMut(&mavlink::dialects::ardupilotmega::MavMessage) -> Option<T>,
) -> Option<T> {
    use mavlink::MavConnection;
    let end = std::time::Instant::now() + timeout;
    while std::time::Instant::now() < end {
        match gcs.try_recv() {
            Ok((_, m)) => {
                if let Some(t) = pick(&m) {
                    return Some(t);
                }
            }
            Err(_) => std::thread::sleep(std::time::Duration::from_millis(2)),
        }
    }
    None
}
