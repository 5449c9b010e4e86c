//! The emulated boards of the paper's layout: boots the `node-emu` image
//! (crate `node-firmware`) and the `topside-emu` image (this crate, `topside-board`) each
//! in `qemu-system-arm -M netduinoplus2`, and drives them through their harness UART
//! (`firmware::harness`): the node samples the host's IMU at the host's time, sends its
//! uplinks and applies the pulses of the downlinks the test sends; the topside greets the
//! PC on the tether, answers it, and steps on an uplink with a downlink.
//!
//! Builds the images from the current sources into `<target>/hil-firmware` (shared with the
//! host-sim HIL tests). Without `qemu-system-arm` or the thumbv7em target it prints
//! `SKIPPED` with the fix and passes (`ROV_REQUIRE_QEMU` makes that a failure, as in CI).

// Test code: a failed expectation should stop the test.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use controller_core::state::NavState;
use firmware::harness::{
    seal, HarnessDecoder, HarnessImu, HarnessRefusal, NodeReport, NodeStep, TopsideReport,
    TopsideStep,
};
use firmware::node_link::{
    self, status, ArmCommand, Downlink, LinkDecoder, LinkFrame, NodeCounters, Uplink,
};
use firmware::protocol::{
    encode, Board, Command, Decoded, FrameDecoder, NavSample, Reply, MAX_FRAME_LEN,
};
use serde::de::DeserializeOwned;
use serde::Serialize;
use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command as Proc, Stdio};
use std::time::{Duration, Instant};

const TARGET: &str = "thumbv7em-none-eabihf";

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// `why` when the emulator or the target is missing (the test then passes as SKIPPED,
/// unless `ROV_REQUIRE_QEMU` is set).
fn skip(why: &str) -> Option<PathBuf> {
    assert!(
        std::env::var_os("ROV_REQUIRE_QEMU").is_none(),
        "ROV_REQUIRE_QEMU is set, but the emulated layout cannot run: {why}"
    );
    println!("SKIPPED: {why}");
    eprintln!("SKIPPED: {why}");
    None
}

/// Build `bin` of `package` (with `features`) from the current sources; `None` after
/// `SKIPPED` without QEMU or the target.
fn image(package: &str, bin: &str, features: &[&str]) -> Option<PathBuf> {
    let ok = Proc::new("qemu-system-arm")
        .arg("--version")
        .stdout(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        return skip("qemu-system-arm not found; fix: apt-get install -y qemu-system-arm");
    }
    let rustc = std::env::var_os("RUSTC").unwrap_or_else(|| "rustc".into());
    let sysroot = Proc::new(rustc)
        .args(["--print", "sysroot"])
        .current_dir(root())
        .output()
        .unwrap();
    let sysroot = PathBuf::from(String::from_utf8_lossy(&sysroot.stdout).trim());
    if !sysroot.join("lib/rustlib").join(TARGET).is_dir() {
        return skip(&format!(
            "the Rust target {TARGET} is not installed; fix: rustup target add {TARGET}"
        ));
    }
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join("target"));
    let dir = if target.is_absolute() {
        target.join("hil-firmware")
    } else {
        root().join(target).join("hil-firmware")
    };
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = Proc::new(cargo);
    cmd.current_dir(root())
        .args(["build", "-q", "-p", package, "--bin", bin])
        .args(["--profile", "hil", "--target", TARGET, "--target-dir"])
        .arg(&dir);
    if !features.is_empty() {
        cmd.args(["--features", &features.join(",")]);
    }
    let st = cmd.status().unwrap();
    assert!(st.success(), "building {package} --bin {bin} failed ({st})");
    Some(dir.join(TARGET).join("hil").join(bin))
}

/// QEMU with `serials` UARTs connected to sockets of this test; killed on drop.
struct Board2 {
    child: Child,
    serials: Vec<TcpStream>,
}

impl Drop for Board2 {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn start(elf: &Path, serials: usize) -> Board2 {
    let listeners: Vec<TcpListener> = (0..serials)
        .map(|_| TcpListener::bind("127.0.0.1:0").unwrap())
        .collect();
    // QEMU itself is the child, not `timeout`: killing it on drop must end it, or the
    // guest outlives the test. No `-icount`: these flights read no instruction counts, and
    // QEMU's instruction accounting slows them (docs/testing.md).
    let mut q = Proc::new("qemu-system-arm");
    q.args(["-M", "netduinoplus2", "-nographic"]).args([
        "-monitor",
        "none",
        "-semihosting-config",
        "enable=on,target=native",
    ]);
    for l in &listeners {
        let port = l.local_addr().unwrap().port();
        q.args(["-serial", &format!("tcp:127.0.0.1:{port},nodelay=on")]);
    }
    let child = q
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let mut board = Board2 {
        child,
        serials: Vec::new(),
    };
    for l in &listeners {
        let (s, _) = l.accept().unwrap();
        s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
        s.set_nodelay(true).unwrap();
        board.serials.push(s);
    }
    board
}

/// Read frames of `M` from `s` until one decodes (skipping nothing: a dropped frame fails).
fn recv_frame<M: DeserializeOwned, const V: u8>(s: &mut TcpStream, d: &mut LinkDecoder<M, V>) -> M {
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut b = [0u8; 1];
    loop {
        assert!(
            Instant::now() < deadline,
            "no frame from the emulated board"
        );
        assert_eq!(s.read(&mut b).unwrap(), 1, "QEMU closed the serial link");
        match d.push(b[0]) {
            Some(LinkFrame::Frame { msg, .. }) => return msg,
            Some(LinkFrame::Dropped(r)) => panic!("bad frame: {r:?}"),
            None => {}
        }
    }
}

fn send_harness<M: Serialize>(s: &mut TcpStream, seq: u16, msg: &M) {
    let mut out = [0u8; MAX_FRAME_LEN];
    s.write_all(seal(seq, msg, &mut out).unwrap()).unwrap();
}

/// Exactly `n` bytes from `s`.
fn take(s: &mut TcpStream, n: u32) -> Vec<u8> {
    let mut v = vec![0u8; n as usize];
    s.read_exact(&mut v).unwrap();
    v
}

#[test]
fn the_emulated_node_samples_the_hosts_imu_and_applies_the_downlinks() {
    let Some(elf) = image("node-firmware", "node-emu", &[]) else {
        return;
    };
    let mut board = start(&elf, 2);
    let (link, harness) = board.serials.split_at_mut(1);
    let (link, harness) = (&mut link[0], &mut harness[0]);
    let mut reports = HarnessDecoder::<NodeReport>::new();
    let hello = recv_frame(harness, &mut reports);
    assert_eq!(hello.t_us, 0);
    assert_eq!(hello.pulse_us, [1500; 3], "boots neutral");
    assert_ne!(hello.status & status::LATCHED, 0, "boots latched");
    let imu = HarnessImu {
        gyro_rad_s: [0.1, -0.2, 0.3],
        accel_m_s2: [0.0, 0.5, -9.81],
    };
    let session = 0x2570_0001;
    let (mut delivered, mut received, mut seq) = (0u32, 0u32, 0u16);
    let mut ups = LinkDecoder::<Uplink>::new();
    let mut uplinks = Vec::new();
    let mut last = hello;
    let t0 = Instant::now();
    // 100 ms at 400 Hz; the host disarms the node, then arms it at 1650 us from 50 ms.
    for k in 0..=40u64 {
        let t_us = k * 2_500;
        if k % 8 == 4 {
            seq += 1;
            let arm = if t_us < 50_000 {
                ArmCommand::Disarmed
            } else {
                ArmCommand::Armed
            };
            let cmd = Downlink {
                session,
                seq: u64::from(seq),
                pulse_us: [1650, 1650, 1350],
                ttl_ms: 100,
                arm,
                t_us: 0,
            };
            let mut out = [0u8; MAX_FRAME_LEN];
            let f = node_link::seal(seq, &cmd, &mut out).unwrap();
            delivered += f.len() as u32;
            link.write_all(f).unwrap();
        }
        let step = NodeStep {
            t_us,
            link_rx_bytes: delivered,
            imu: Some(imu),
            pressure_pa: Some(120_000.0),
        };
        send_harness(harness, k as u16, &step);
        let r = recv_frame(harness, &mut reports);
        assert_eq!(r.refused, None, "{r:?}");
        assert_eq!((r.t_us, r.link_rx_bytes), (t_us, delivered));
        let bytes = take(link, r.link_tx_bytes - received);
        received = r.link_tx_bytes;
        uplinks.extend(bytes.iter().filter_map(|&b| ups.push(b)));
        let armed = t_us >= 50_000;
        let expect = if armed { [1650, 1650, 1350] } else { [1500; 3] };
        assert_eq!(r.pulse_us, expect, "at {t_us} us: {r:?}");
        last = r;
    }
    println!("node: 41 steps in {:?}", t0.elapsed());
    assert_eq!(last.accepted, 5);
    // An uplink every 20 ms of the host's time, 8 IMU intervals of its samples in each.
    assert_eq!(uplinks.len(), 5, "{uplinks:?}");
    let LinkFrame::Frame { msg: up, .. } = uplinks[3] else {
        panic!("{uplinks:?}")
    };
    assert_eq!((up.session, up.samples, up.dt_us), (session, 8, 20_000));
    assert!((up.delta_angle_rad[2] - 0.3 * 0.02).abs() < 1e-6, "{up:?}");
    assert_eq!(up.pressure_pa, 120_000.0);
    assert_eq!(
        up.counters,
        NodeCounters {
            accepted: up.counters.accepted,
            ..Default::default()
        }
    );
    // Time never goes back: refused, nothing changed.
    send_harness(
        harness,
        100,
        &NodeStep {
            t_us: 5,
            link_rx_bytes: delivered,
            imu: None,
            pressure_pa: None,
        },
    );
    let r = recv_frame(harness, &mut reports);
    assert_eq!(r.refused, Some(HarnessRefusal::TimeBack));
    assert_eq!((r.t_us, r.pulse_us), (100_000, [1650, 1650, 1350]));
}

#[test]
fn the_emulated_topside_greets_the_pc_and_steps_on_an_uplink() {
    let Some(elf) = image("firmware", "topside-emu", &["topside-board"]) else {
        return;
    };
    let mut board = start(&elf, 3);
    let [tether, link, harness] = &mut board.serials[..] else {
        unreachable!()
    };
    let mut replies = FrameDecoder::<Reply>::new();
    let mut pc_recv = |s: &mut TcpStream, n: u32| -> Vec<Reply> {
        take(s, n)
            .into_iter()
            .filter_map(|b| match replies.push(b) {
                Some(Decoded::Frame { msg, .. }) => Some(msg),
                Some(Decoded::Dropped { reason, .. }) => panic!("bad reply: {reason:?}"),
                None => None,
            })
            .collect()
    };
    let mut reports = HarnessDecoder::<TopsideReport>::new();
    let hello = recv_frame(harness, &mut reports);
    let got = pc_recv(tether, hello.tether_tx_bytes);
    assert!(
        matches!(
            got[..],
            [Reply::Hello {
                board: Board::QemuNetduinoPlus2,
                ..
            }]
        ),
        "{got:?}"
    );
    let mut tx = hello.tether_tx_bytes;
    // The PC opens its session at 10 ms of the host's time.
    let mut buf = [0u8; MAX_FRAME_LEN];
    let f = encode(0, 0, &Command::OpenSession { nonce: 0x25 }, &mut buf).unwrap();
    let tether_in = f.len() as u32;
    tether.write_all(f).unwrap();
    let step = TopsideStep {
        t_us: 10_000,
        tether_rx_bytes: tether_in,
        link_rx_bytes: 0,
    };
    send_harness(harness, 0, &step);
    let r = recv_frame(harness, &mut reports);
    assert_eq!(
        (r.refused, r.t_us, r.tether_rx_bytes),
        (None, 10_000, tether_in)
    );
    let got = pc_recv(tether, r.tether_tx_bytes - tx);
    tx = r.tether_tx_bytes;
    assert!(
        got.iter()
            .any(|m| matches!(m, Reply::Session { nonce: 0x25, .. })),
        "{got:?}"
    );
    let mut downs = LinkDecoder::<Downlink>::new();
    let first_downs: Vec<_> = take(link, r.link_tx_bytes)
        .into_iter()
        .filter_map(|b| downs.push(b))
        .collect();
    let session = match first_downs.last() {
        Some(LinkFrame::Frame { msg, .. }) => msg.session,
        _ => panic!("no downlink at the first step: {first_downs:?}"),
    };
    assert_ne!(session, 0);
    let mut link_tx = r.link_tx_bytes;
    // An uplink at 15 ms: the step runs at once and a downlink answers, neutral, disarmed.
    let up = Uplink {
        session,
        echo_seq: 0,
        echo_t_us: 0,
        imu_age_us: 0,
        dt_us: 20_000,
        samples: 8,
        delta_angle_rad: [0.0; 3],
        delta_velocity_m_s: [0.0, 0.0, -9.81 * 0.02],
        pressure_pa: 150_000.0,
        pressure_count: 1,
        status: status::LATCHED,
        counters: NodeCounters::default(),
        dvl: None,
    };
    let mut out = [0u8; MAX_FRAME_LEN];
    let f = node_link::seal(1, &up, &mut out).unwrap();
    let link_in = f.len() as u32;
    link.write_all(f).unwrap();
    let step = TopsideStep {
        t_us: 15_000,
        tether_rx_bytes: tether_in,
        link_rx_bytes: link_in,
    };
    send_harness(harness, 1, &step);
    let r = recv_frame(harness, &mut reports);
    assert_eq!(
        (r.refused, r.uplink_steps, r.link_rx_bytes),
        (None, 1, link_in),
        "{r:?}"
    );
    assert!(
        r.link_tx_bytes > link_tx,
        "a downlink after the step: {r:?}"
    );
    let got: Vec<_> = take(link, r.link_tx_bytes - link_tx)
        .into_iter()
        .filter_map(|b| downs.push(b))
        .collect();
    match got.last() {
        Some(LinkFrame::Frame { msg, .. }) => {
            assert_eq!(
                (msg.session, msg.arm, msg.pulse_us),
                (session, ArmCommand::Disarmed, [1500; 3])
            );
        }
        other => panic!("{other:?}"),
    }
    link_tx = r.link_tx_bytes;
    // Bytes the step counts that never come: refused after the board's wait, nothing run.
    let step = TopsideStep {
        t_us: 20_000,
        tether_rx_bytes: tether_in,
        link_rx_bytes: link_in + 3,
    };
    send_harness(harness, 2, &step);
    let r = recv_frame(harness, &mut reports);
    assert_eq!(
        (r.refused, r.t_us, r.link_tx_bytes, r.tether_tx_bytes),
        (Some(HarnessRefusal::BytesMissing), 15_000, link_tx, tx)
    );
}

/// Both boards, joined by the host (an instant wire here: the bytes one board wrote before a
/// step are the other's at the same time): the PC opens a session and arms the topside at
/// 200 ms; the topside steps on the node's uplinks and the node follows its arm transition.
#[test]
fn the_two_emulated_boards_joined_step_on_the_nodes_uplinks_and_arm() {
    let Some(node_elf) = image("node-firmware", "node-emu", &[]) else {
        return;
    };
    let Some(top_elf) = image("firmware", "topside-emu", &["topside-board"]) else {
        return;
    };
    let mut node = start(&node_elf, 2);
    let mut top = start(&top_elf, 3);
    let [n_link, n_h] = &mut node.serials[..] else {
        unreachable!()
    };
    let [tether, t_link, t_h] = &mut top.serials[..] else {
        unreachable!()
    };
    let (mut nrep, mut trep) = (
        HarnessDecoder::<NodeReport>::new(),
        HarnessDecoder::<TopsideReport>::new(),
    );
    let _ = recv_frame(n_h, &mut nrep);
    let th = recv_frame(t_h, &mut trep);
    let mut replies = FrameDecoder::<Reply>::new();
    let mut pc_in = Vec::new();
    for b in take(tether, th.tether_tx_bytes) {
        if let Some(Decoded::Frame { msg, .. }) = replies.push(b) {
            pc_in.push(msg);
        }
    }
    let (mut node_in, mut node_seen) = (0u32, 0u32);
    let (mut top_in, mut top_seen, mut tether_in, mut tether_seen) =
        (0u32, 0u32, 0u32, th.tether_tx_bytes);
    let (mut session, mut seq, mut arm_seq) = (0u32, 0u16, None);
    let (mut n_last, mut t_last) = (None, None);
    let t0 = Instant::now();
    for k in 0..=240u64 {
        let t_us = k * 2_500;
        let cmd = match k {
            1 => Some(Command::OpenSession { nonce: 0x25 }),
            // Arming needs a fresh navigation sample from the surface (no estimator here).
            79 => Some(Command::Nav(NavSample {
                t_us,
                state: Default::default(),
            })),
            80 => Some(Command::Arm),
            _ if k % 40 == 2 => Some(Command::Heartbeat { t_us }),
            _ => None,
        };
        if let Some(cmd) = cmd {
            let mut buf = [0u8; MAX_FRAME_LEN];
            let f = encode(session, seq, &cmd, &mut buf).unwrap();
            if matches!(cmd, Command::Arm) {
                arm_seq = Some(seq);
            }
            seq += 1;
            tether_in += f.len() as u32;
            tether.write_all(f).unwrap();
        }
        let step = NodeStep {
            t_us,
            link_rx_bytes: node_in,
            imu: Some(HarnessImu {
                gyro_rad_s: [0.0; 3],
                accel_m_s2: [0.0, 0.0, -9.81],
            }),
            pressure_pa: (k % 8 == 0).then_some(150_000.0),
        };
        send_harness(n_h, k as u16, &step);
        let r = recv_frame(n_h, &mut nrep);
        assert_eq!(r.refused, None, "{r:?}");
        let up = take(n_link, r.link_tx_bytes - node_seen);
        node_seen = r.link_tx_bytes;
        top_in += up.len() as u32;
        t_link.write_all(&up).unwrap();
        n_last = Some(r);
        let step = TopsideStep {
            t_us,
            tether_rx_bytes: tether_in,
            link_rx_bytes: top_in,
        };
        send_harness(t_h, k as u16, &step);
        let r = recv_frame(t_h, &mut trep);
        assert_eq!(r.refused, None, "{r:?}");
        for b in take(tether, r.tether_tx_bytes - tether_seen) {
            if let Some(Decoded::Frame { msg, .. }) = replies.push(b) {
                if let Reply::Session { session: s, .. } = msg {
                    session = s;
                }
                pc_in.push(msg);
            }
        }
        tether_seen = r.tether_tx_bytes;
        let down = take(t_link, r.link_tx_bytes - top_seen);
        top_seen = r.link_tx_bytes;
        node_in += down.len() as u32;
        n_link.write_all(&down).unwrap();
        t_last = Some(r);
    }
    let (n, t) = (n_last.unwrap(), t_last.unwrap());
    println!(
        "600 ms of host time in {:?}: topside {t:?}, node {n:?}",
        t0.elapsed()
    );
    assert!(
        pc_in
            .iter()
            .any(|m| matches!(m, Reply::Ack { seq } if Some(*seq) == arm_seq)),
        "the topside acknowledged Arm: {pc_in:?}"
    );
    // An uplink every 20 ms from 20 ms, each a step at once.
    assert!(t.uplink_steps >= 29, "{t:?}");
    assert!(n.accepted >= 29, "{n:?}");
    assert_ne!(
        n.status & status::ARMED,
        0,
        "the node followed the arm: {n:?}"
    );
}

#[path = "emulated_layout/dvl_flight.rs"]
mod dvl_flight;
