//! The emulated board: boots the `qemu` firmware image in `qemu-system-arm -M netduinoplus2`,
//! waits for its Hello frame on a loopback TCP socket and drives it in lock-step: arm,
//! manual thrust, nav -> telemetry, then heartbeat loss in emulated (host) time.
//!
//! Builds the image from the current sources (`<target>/hil-firmware`, shared with the
//! host-sim HIL tests) and needs `qemu-system-arm` and the thumbv7em target; without them it
//! prints `SKIPPED` with the fix and passes (`ROV_REQUIRE_QEMU` makes that a failure, as in CI). `ROV_QEMU_ELF` overrides the image.

// Test code: a failed expectation should stop the test.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use firmware::protocol::{
    Answer, Board, Client, Command, Event, Law, ManualThrust, Mode, NavSample, Plane, Reply,
    Status, Telemetry,
};
use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::PathBuf;
use std::process::{Child, Command as Proc, Stdio};
use std::time::{Duration, Instant};

/// The firmware's `qemu` image, built from the current sources (so a protocol change can
/// never be tested against a stale image) by the helper the host-sim HIL tests use.
/// `None` (after `SKIPPED: <reason>; fix: <command>`) without QEMU or the thumbv7em target.
fn image() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("ROV_QEMU_ELF") {
        return Some(PathBuf::from(p));
    }
    host_sim::tether::qemu::image_or_skip().expect("the firmware's qemu image")
}

/// Kills QEMU when the test ends, also on a panic.
struct Qemu(Child);

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// The protocol's session client on the emulated board's serial port (blocking reads).
struct Link {
    stream: TcpStream,
    client: Client,
}

impl Link {
    /// Send `cmd` in the session, opening it first (on the first send).
    fn send(&mut self, cmd: &Command) -> u16 {
        if self.client.needs_session() {
            let f = self.client.open(0x0E_0E0E, 0).unwrap();
            self.stream.write_all(f.bytes()).unwrap();
            while self.client.session() == 0 {
                self.recv();
            }
        }
        let sent = self.client.send(cmd, 0).unwrap();
        self.stream.write_all(sent.frame.bytes()).unwrap();
        sent.seq
    }

    /// The next reply, and what it answered in the session.
    fn recv_answer(&mut self) -> (Reply, Option<Answer>) {
        let deadline = Instant::now() + Duration::from_secs(10);
        let mut b = [0u8; 1];
        loop {
            assert!(
                Instant::now() < deadline,
                "no reply from the emulated board"
            );
            match self.stream.read(&mut b) {
                Ok(0) => panic!("QEMU closed the serial link"),
                Ok(_) => match self.client.receive(&mut &b[..]) {
                    Some(Event::Reply { reply, answer, .. }) => return (reply, answer),
                    Some(Event::Dropped { reason, .. }) => panic!("bad reply frame {reason:?}"),
                    Some(Event::TimedOut { .. } | Event::OpenTimedOut { .. }) | None => {}
                },
                Err(e) => panic!("serial read: {e}"),
            }
        }
    }

    fn recv(&mut self) -> Reply {
        self.recv_answer().0
    }

    fn expect_ack(&mut self, cmd: &Command) {
        let seq = self.send(cmd);
        let answer = self.recv_answer().1;
        let acked = Answer::Command {
            seq,
            result: Ok(()),
        };
        assert_eq!(answer, Some(acked), "{cmd:?}");
    }

    /// Send a heartbeat; the answer is the firmware's `Status`.
    fn heartbeat(&mut self, t_us: u64) -> Status {
        let seq = self.send(&Command::Heartbeat { t_us });
        match self.recv() {
            Reply::Status(st) if st.heartbeat_seq == seq => st,
            other => panic!("expected the status for heartbeat {seq}, got {other:?}"),
        }
    }

    fn nav(&mut self, t_us: u64) -> (u16, Telemetry) {
        let seq = self.send(&Command::Nav(NavSample {
            t_us,
            state: Default::default(),
        }));
        match self.recv() {
            Reply::Telemetry(t) => (seq, t),
            other => panic!("expected telemetry, got {other:?}"),
        }
    }
}

#[test]
fn emulated_board_boots_and_answers_in_lockstep() {
    let Some(elf) = image() else {
        return;
    };
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let log = std::env::temp_dir().join(format!("rov-qemu-{port}.defmt"));
    // QEMU is spawned directly (not under `timeout`: killing a wrapper would orphan QEMU)
    // and killed by `Qemu::drop`, also when the test panics.
    let child = Proc::new("qemu-system-arm")
        .args(["-M", "netduinoplus2", "-nographic"])
        .args([
            "-monitor",
            "none",
            "-semihosting-config",
            "enable=on,target=native",
        ])
        .args(["-icount", "shift=0,align=off,sleep=off"])
        .arg("-serial")
        .arg(format!("tcp:127.0.0.1:{port},nodelay=on"))
        .arg("-kernel")
        .arg(&elf)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&log).unwrap())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let _qemu = Qemu(child);
    listener.set_nonblocking(true).unwrap();
    let deadline = Instant::now() + Duration::from_secs(20);
    let stream = loop {
        match listener.accept() {
            Ok((s, _)) => break s,
            Err(_) if Instant::now() < deadline => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => panic!("QEMU did not connect: {e}"),
        }
    };
    stream.set_nonblocking(false).unwrap();
    stream.set_nodelay(true).unwrap();
    stream
        .set_read_timeout(Some(Duration::from_secs(10)))
        .unwrap();
    let mut link = Link {
        stream,
        client: Client::default(),
    };
    let t0 = Instant::now();
    match link.recv() {
        Reply::Hello {
            protocol,
            board,
            lockstep,
            pwm_hz,
            ..
        } => {
            assert_eq!(protocol, firmware::protocol::PROTOCOL_VERSION);
            assert_eq!(board, Board::QemuNetduinoPlus2);
            assert!(lockstep);
            assert_eq!(pwm_hz, 50);
        }
        other => panic!("expected Hello, got {other:?}"),
    }
    println!("hello after {:?}", t0.elapsed());

    // Boots disarmed and neutral.
    let mut t_us = 1_000_000u64;
    link.heartbeat(t_us);
    let (seq, tel) = link.nav(t_us);
    assert_eq!(tel.nav_seq, seq);
    assert!(!tel.armed);
    assert_eq!(tel.pulse_us, [1500; 3]);

    link.expect_ack(&Command::Arm);
    link.expect_ack(&Command::SetMode(Mode::Manual));
    // The sticks seen at centre since the change of mode: the push acts.
    link.send(&Command::ManualThrust(ManualThrust::default()));
    let push = ManualThrust {
        surge: 0.5,
        yaw: 0.2,
        heave: -0.4,
    };
    let hb_at = t_us;
    let mut frames = 0u32;
    let t1 = Instant::now();
    for _ in 0..75 {
        t_us += 20_000;
        link.send(&Command::ManualThrust(push));
        let (seq, tel) = link.nav(t_us);
        frames += 1;
        assert_eq!(tel.nav_seq, seq);
        assert_eq!(tel.t_us, t_us);
        let age = t_us - hb_at;
        assert_eq!(tel.armed, age < 1_000_000, "age {age}: {tel:?}");
        if age < 500_000 {
            assert!(tel.pulse_us[0] > 1500 && tel.pulse_us[1] > 1500 && tel.pulse_us[2] < 1500);
        } else {
            assert_eq!(tel.pulse_us, [1500; 3], "age {age}");
        }
    }
    // Noise on the link: two broken frames, then a good one still answers.
    link.stream
        .write_all(&[1, 2, 3, 0, 0xFF, 0x55, 0x13, 0])
        .unwrap();
    let (seq, tel) = link.nav(t_us + 20_000);
    assert_eq!(tel.nav_seq, seq);
    assert!(!tel.armed);
    let st = link.heartbeat(t_us + 20_000);
    assert_eq!(st.link.dropped.total(), 2, "{:?}", st.link);
    assert_eq!(st.nav_t_us, t_us + 20_000);

    // Re-arm explicitly and track with each law; report the step's instruction count
    // (TIM2 at prescaler 0 under -icount shift=0).
    t_us += 40_000;
    link.heartbeat(t_us);
    link.nav(t_us);
    // Still in MANUAL with the push 60 ms old: the pilot centres the sticks first
    // (no arming in a stick mode with a fresh stick off centre).
    link.send(&Command::ManualThrust(ManualThrust::default()));
    link.expect_ack(&Command::Arm);
    link.expect_ack(&Command::SetReference {
        reference: controller_core::reference::Reference::Paper(
            controller_core::reference::PaperPolynomial::PAPER,
        ),
        start_us: Some(t_us),
    });
    for (plane, law) in [
        (Plane::Xy, Law::Paper),
        (Plane::Xz, Law::Paper),
        (Plane::Xy, Law::Tracking),
        (Plane::Xz, Law::Tracking),
        (Plane::ThreeD, Law::Tracking),
    ] {
        link.expect_ack(&Command::SetMode(Mode::Track { plane, law }));
        let mut ticks = Vec::new();
        for _ in 0..10 {
            t_us += 20_000;
            link.heartbeat(t_us);
            let (_, tel) = link.nav(t_us);
            assert!(tel.armed);
            assert_eq!(tel.faults & 0b111, 0, "{tel:?}");
            ticks.push(tel.loop_ticks);
        }
        println!("{plane:?}/{law:?}: control step {ticks:?} instructions");
    }
    println!(
        "{frames} lock-step exchanges in {:?}; link {:?}",
        t1.elapsed(),
        link.recv_stats()
    );
}

impl Link {
    fn recv_stats(&mut self) -> (u32, u32) {
        (self.client.frames_received(), self.client.dropped().total())
    }
}
