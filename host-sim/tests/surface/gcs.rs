//! What the tests that fly the surface program from a real ground station (pymavlink,
//! MAVProxy) share: the check that pymavlink is there (SKIPPED with the fix, or a failure with
//! `ROV_REQUIRE_PYMAVLINK=1` as `.ci/run` sets it), a free UDP port, a simulated dive started
//! the way a real one is (`host-sim vehicle` serving the vehicle, `rov-topside --tcp` at the
//! surface), stopping it.

// Each test binary that includes this module uses a part of it.
#![allow(dead_code)]

use std::ffi::OsStr;
use std::io::{BufRead, BufReader};
use std::net::UdpSocket;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::OnceLock;

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

/// A fresh scratch folder `name` under the test target's temporary folder (what an earlier
/// run left there is removed first).
pub fn scratch_dir(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Run the ground-station client `tests/clients/<script>` under python3 with `args`, to its
/// end: whether it exited 0, and its standard output (both of its streams are printed, for
/// the test's log).
pub fn run_client<S: AsRef<OsStr>>(script: &str, args: &[S]) -> (bool, String) {
    let out = Command::new("python3")
        .arg(
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("tests/clients")
                .join(script),
        )
        .args(args)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    println!("{stdout}{}", String::from_utf8_lossy(&out.stderr));
    (out.status.success(), stdout)
}

/// A UDP port nobody listens on now.
pub fn free_udp_port() -> u16 {
    UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// What a test stops: a process and what it started, or a whole simulated dive.
pub trait Stop {
    /// Stop it (its process groups: a killed process runs no destructors).
    fn stop(self);
}

impl Stop for Child {
    fn stop(mut self) {
        let _ = Command::new("kill")
            .args(["-KILL", "--", &format!("-{}", self.id())])
            .status();
        let _ = self.kill();
        let _ = self.wait();
    }
}

/// A simulated dive as a real one is flown: the vehicle served by `host-sim vehicle` on a TCP
/// port, the surface program `rov-topside --tcp` in front of it.
pub struct Dive {
    /// The surface program.
    pub topside: Child,
    /// The served vehicle.
    pub vehicle: Child,
    /// Where the served vehicle writes its truth log.
    pub out: PathBuf,
    /// The served vehicle's TCP port.
    pub tcp: u16,
    /// The surface's navigation arguments (`--usbl`, `--launch`, `--nav-config`) and its
    /// tether heartbeat rate, for another surface program in front of the same vehicle.
    pub surface_args: Vec<String>,
}

impl Dive {
    /// The served vehicle's truth log (the true state beside what the vehicle believes): the
    /// newest `.truth.csv` in its folder.
    pub fn truth(&self) -> PathBuf {
        std::fs::read_dir(&self.out)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.to_string_lossy().ends_with(".truth.csv"))
            .max_by_key(|p| std::fs::metadata(p).and_then(|m| m.modified()).unwrap())
            .expect("the served vehicle's truth log")
    }
}

impl Stop for Dive {
    fn stop(self) {
        self.topside.stop();
        self.vehicle.stop();
    }
}

/// Stop a process (its group, started with `process_group(0)`) or a dive.
pub fn stop(s: impl Stop) {
    s.stop();
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

/// The `rov-topside` binary of this build profile, as `cargo test --workspace` builds it.
///
/// The binary is built by cargo for the topside package's own integration test
/// (`conventions`); asking for that test with `--workspace` resolves the dependencies'
/// features across the whole workspace, as the README's `cargo test --workspace` does, so the
/// binary that command built is found current and nothing is rebuilt. (`cargo build -p
/// topside` resolves them for that package alone: other features of `num-traits`, `serde`
/// and `serde_json`, a second build of MAVLink's dialect and the surface program, ~130
/// CPU-seconds on a fresh clone.) A test run alone with `-p host-sim` gets it built here,
/// once.
pub fn rov_topside() -> PathBuf {
    static BIN: OnceLock<PathBuf> = OnceLock::new();
    BIN.get_or_init(|| {
        let exe = std::env::current_exe().unwrap();
        // <target>/<profile>/deps/<test binary>
        let profile_dir = exe.parent().and_then(Path::parent).unwrap().to_path_buf();
        let mut cargo = Command::new(env!("CARGO"));
        cargo.args([
            "test",
            "-q",
            "--workspace",
            "--no-run",
            "--test",
            "conventions",
        ]);
        // The test profile's folder is `debug`; `release` when the tests run with `--release`.
        if profile_dir.file_name().is_some_and(|n| n == "release") {
            cargo.arg("--release");
        }
        let ok = cargo
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .stdout(std::process::Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        assert!(
            ok,
            "cargo test --workspace --no-run --test conventions (builds rov-topside) failed"
        );
        profile_dir.join("rov-topside")
    })
    .clone()
}

/// `host-sim vehicle SCENARIO` serving on a free port, its truth log in `out`, with `extra`
/// arguments (`--speedup`, `--duration`): the process (in a group of its own) and the port.
pub fn serve_vehicle(scenario: impl AsRef<OsStr>, out: &Path, extra: &[&str]) -> (Child, u16) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .arg("vehicle")
        .arg(scenario)
        .args(["--listen", "tcp:127.0.0.1:0", "--out"])
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
    let port = line
        .split("tcp:127.0.0.1:")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|p| p.parse().ok())
        .unwrap_or_else(|| panic!("no port in the served vehicle's first line {line:?}"));
    (child, port)
}

/// A simulated dive flown the way a real one is: `host-sim vehicle SCENARIO` served on a free
/// port, and `rov-topside --tcp` sending MAVLink to `udpout:127.0.0.1:PORT`, its tlog and
/// parameters file where the test says. Of `extra`, `--speedup K`, `--start-nav`,
/// `--wait-surface` and `--vehicle-duration S` (its `--duration`) go to the vehicle, everything else to the
/// surface (`--duration`, `--mavlink`, `--vehicle`); `--qemu` or `--qemu=ELF` serves the
/// firmware image in QEMU (a topside-layout scenario: its two images). With
/// `--speedup K` the surface's tether heartbeat goes K times faster (at most 50 Hz), so that
/// the vehicle sees one every 0.1 s of its own time.
pub fn dive(
    scenario: impl AsRef<OsStr>,
    port: u16,
    tlog: &Path,
    params: &Path,
    extra: &[&str],
) -> Dive {
    let (mut vehicle_args, mut surface_args) = (Vec::new(), Vec::new());
    let mut speedup = 1.0f64;
    let mut surface_nav = false;
    let mut it = extra.iter();
    while let Some(&a) = it.next() {
        match a {
            "--speedup" => {
                let k = *it.next().unwrap();
                speedup = k.parse().unwrap();
                vehicle_args.extend(["--speedup", k]);
            }
            "--start-nav" | "--wait-surface" => vehicle_args.push(a),
            // The firmware image in QEMU (`--qemu` or `--qemu=ELF`): the vehicle's.
            _ if a == "--qemu" || a.starts_with("--qemu=") => vehicle_args.push(a),
            // The USBL at the surface: the served vehicle's as NMEA to the surface program,
            // which starts the vehicle's estimator at the dive's launch point and relays the
            // fixes.
            "--surface-nav" => surface_nav = true,
            // The served vehicle's own end (simulated time), not the surface's.
            "--vehicle-duration" => vehicle_args.extend(["--duration", *it.next().unwrap()]),
            _ => surface_args.push(a),
        }
    }
    let out = tlog.parent().unwrap().to_path_buf();
    let usbl_port = free_udp_port().to_string();
    let usbl_to = format!("127.0.0.1:{usbl_port}");
    if surface_nav {
        vehicle_args.extend(["--usbl-to", usbl_to.as_str()]);
    }
    let (vehicle, tcp) = serve_vehicle(&scenario, &out, &vehicle_args);
    let mut nav_args: Vec<String> = Vec::new();
    if surface_nav {
        // What the operator knows of the dive, written by the served vehicle at its start.
        let newest = |ext: &str| {
            let end = std::time::Instant::now() + std::time::Duration::from_secs(10);
            loop {
                let found = std::fs::read_dir(&out)
                    .unwrap()
                    .map(|e| e.unwrap().path())
                    .filter(|p| p.to_string_lossy().ends_with(ext))
                    .max_by_key(|p| std::fs::metadata(p).and_then(|m| m.modified()).unwrap());
                if let Some(p) = found {
                    return p;
                }
                assert!(
                    std::time::Instant::now() < end,
                    "no {ext} from the served vehicle"
                );
                std::thread::sleep(std::time::Duration::from_millis(50));
            }
        };
        let launch = std::fs::read_to_string(newest(".launch")).unwrap();
        nav_args.extend([
            "--usbl".into(),
            format!("udpin:{usbl_to}"),
            "--launch".into(),
            launch.trim().to_string(),
            "--nav-config".into(),
            newest(".nav-config.json").to_string_lossy().to_string(),
        ]);
    }
    let heartbeat_hz = (10.0 * speedup).clamp(10.0, 50.0).round().to_string();
    nav_args.extend(["--heartbeat-hz".into(), heartbeat_hz]);
    let topside = surface(tcp, port, tlog, params, &nav_args, &surface_args);
    Dive {
        topside,
        vehicle,
        out,
        tcp,
        surface_args: nav_args,
    }
}

/// `rov-topside --tcp 127.0.0.1:TCP` sending MAVLink to `udpout:127.0.0.1:PORT`, its tlog and
/// parameters where the test says, with `fixed` and `extra` arguments.
pub fn surface(
    tcp: u16,
    port: u16,
    tlog: &Path,
    params: &Path,
    fixed: &[String],
    extra: &[&str],
) -> Child {
    Command::new(rov_topside())
        .args(["--tcp", &format!("127.0.0.1:{tcp}")])
        .args(["--mavlink", &format!("udpout:127.0.0.1:{port}")])
        .arg("--tlog")
        .arg(tlog)
        .arg("--params")
        .arg(params)
        .args(fixed)
        .args(extra)
        .process_group(0)
        .spawn()
        .unwrap()
}

/// `rov-topside --serial DEVICE` (115,200 Bd) sending MAVLink to
/// `udpout:127.0.0.1:PORT`, its tlog and parameters in `dir`, stopping after `duration_s`
/// of its own time.
pub fn topside_serial(device: &str, port: u16, dir: &Path, duration_s: u32) -> Child {
    Command::new(rov_topside())
        .args(["--serial", device, "--baud", "115200", "--mavlink"])
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

/// The served vehicle's truth log (`host-sim vehicle`'s CSV) as rows of the columns `names`;
/// a row cut short (a killed process's last line) or with one of them not a number is left
/// out.
pub fn truth_columns<const N: usize>(path: &Path, names: [&str; N]) -> Vec<[f64; N]> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let cols = names.map(|n| {
        head.iter()
            .position(|c| *c == n)
            .unwrap_or_else(|| panic!("no column {n} in {}", path.display()))
    });
    lines
        .filter_map(|l| {
            let v: Vec<&str> = l.split(',').collect();
            if v.len() != head.len() {
                return None;
            }
            let row = cols.map(|c| v[c].parse::<f64>().ok());
            row.iter()
                .all(Option::is_some)
                .then(|| row.map(|x| x.unwrap_or(f64::NAN)))
        })
        .collect()
}
