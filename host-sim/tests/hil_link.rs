//! The surface console (`rov-topside console`) against the firmware's QEMU image: a scripted console session arms,
//! holds a point in 3-D, switches mode, disarms, and streams telemetry to CSV.
//! Skipped, with a message, when `qemu-system-arm` is not installed.
//!
//! The console runs on the host's clock, the emulated board on its own: on a loaded machine
//! a wall-clock `wait` may see few telemetry frames, and answers may come after the
//! console's 2 s for the last ones. So the script is paced by the telemetry the console
//! writes (the next commands once the board reports what the previous ones asked for), not
//! by wall time; a minute without that telemetry fails the test.

use firmware::protocol::Reply;
use host_sim::tether::link::Link;
use host_sim::tether::qemu::{image_or_skip, start_qemu_link, QemuClock};
use std::io::Write;
use std::path::PathBuf;
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use topside::console::console;

fn firmware_elf() -> Option<PathBuf> {
    image_or_skip().expect("the firmware's qemu image")
}

/// The console's telemetry CSV, readable by the thread that feeds the script.
#[derive(Clone, Default)]
struct SharedCsv(Arc<Mutex<Vec<u8>>>);

impl Write for SharedCsv {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl SharedCsv {
    /// The `armed` column (0/1) of every complete telemetry row so far.
    fn armed_column(&self) -> Vec<bool> {
        let bytes = self.0.lock().unwrap().clone();
        let text = String::from_utf8_lossy(&bytes);
        let complete = text.rsplit_once('\n').map_or("", |(rows, _)| rows);
        complete
            .lines()
            .skip(1)
            .filter_map(|r| r.split(',').nth(3).map(|a| a == "1"))
            .collect()
    }

    /// Wait until `done` holds for the armed column; false after `limit` without it.
    fn wait_for(&self, limit: Duration, done: impl Fn(&[bool]) -> bool) -> bool {
        let t0 = Instant::now();
        while t0.elapsed() < limit {
            if done(&self.armed_column()) {
                return true;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        false
    }
}

/// Armed telemetry rows wanted before the mode switch and the disarm.
const ARMED_ROWS: usize = 5;
/// Disarmed rows wanted after the disarm before the script ends.
const NEUTRAL_ROWS: usize = 3;
/// A guard against a hung emulator, not a speed figure.
const STALL_LIMIT: Duration = Duration::from_secs(60);

/// The script, each part sent once the board's telemetry shows the previous one's effect;
/// the channel closes (the console's end of input) only then.
fn feed(tx: Sender<String>, csv: SharedCsv) {
    let send = |c: &str| tx.send(c.to_string()).unwrap();
    for c in [
        "nav 0 0 1 0 auto",
        "ref hold 0.5 0 1",
        "mode track-3d",
        "arm",
    ] {
        send(c);
    }
    let armed = csv.wait_for(STALL_LIMIT, |a| {
        a.iter().filter(|&&armed| armed).count() >= ARMED_ROWS
    });
    assert!(
        armed,
        "fewer than {ARMED_ROWS} armed rows in {STALL_LIMIT:?}"
    );
    send("mode paper-xy");
    send("disarm");
    let disarmed = csv.wait_for(STALL_LIMIT, |a| {
        a.iter()
            .rposition(|&armed| armed)
            .is_some_and(|last_armed| a.len() - last_armed > NEUTRAL_ROWS)
    });
    assert!(disarmed, "not disarmed within {STALL_LIMIT:?}");
}

#[test]
fn hil_link_console_arms_streams_and_disarms() {
    let Some(elf) = firmware_elf() else {
        return;
    };
    let (_qemu, port) =
        start_qemu_link("qemu-system-arm", &elf, None, false, QemuClock::Host).unwrap();
    let mut link = Link::new(port, None);
    let hello = link
        .wait_for(
            Duration::from_secs(30),
            |r| matches!(r, Reply::Hello { .. }).then_some(()),
            |_| {},
        )
        .unwrap();
    assert!(hello.is_some(), "no Hello");
    let (tx, rx) = std::sync::mpsc::channel();
    let csv = SharedCsv::default();
    let feeder = {
        let csv = csv.clone();
        std::thread::spawn(move || feed(tx, csv))
    };
    let mut out = csv.clone();
    let rep = console(&mut link, Duration::from_millis(50), rx, &mut out, false).unwrap();
    feeder.join().expect("the script's pacing");
    let text = String::from_utf8(csv.0.lock().unwrap().clone()).unwrap();
    let rows: Vec<&str> = text.lines().skip(1).collect();
    eprintln!(
        "{} rows, {} armed, {} acks, nacks {:?}",
        rep.telemetry_rows, rep.armed_rows, rep.acks, rep.nacks
    );
    assert!(rep.nacks.is_empty(), "refused: {:?}", rep.nacks);
    assert_eq!(rep.acks, 5);
    assert!(
        rep.armed_rows >= ARMED_ROWS as u64,
        "armed rows {}",
        rep.armed_rows
    );
    assert_eq!(rows.len() as u64, rep.telemetry_rows);
    // Armed and holding 0.5 m away: the 3-D law pushes (some pulse off neutral).
    let armed_pushing = rows.iter().any(|r| {
        let f: Vec<&str> = r.split(',').collect();
        f[3] == "1" && f[16..19].iter().any(|p| *p != "1500")
    });
    assert!(armed_pushing, "no thrust while armed:\n{text}");
    // Ends disarmed with neutral pulses.
    let last: Vec<&str> = rows.last().unwrap().split(',').collect();
    assert_eq!(last[3], "0");
    assert_eq!(&last[16..19], &["1500", "1500", "1500"]);
}
