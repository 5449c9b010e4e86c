//! The surface console (`rov-topside console`) against the firmware's QEMU image: a scripted console session arms,
//! holds a point in 3-D, switches mode, disarms, and streams telemetry to CSV.
//! Skipped, with a message, when `qemu-system-arm` is not installed.

use firmware::protocol::Reply;
use host_sim::tether::link::Link;
use host_sim::tether::qemu::{image_or_skip, start_qemu_link};
use std::path::PathBuf;
use std::time::Duration;
use topside::console::console;

fn firmware_elf() -> Option<PathBuf> {
    image_or_skip().expect("the firmware's qemu image")
}

#[test]
fn hil_link_console_arms_streams_and_disarms() {
    let Some(elf) = firmware_elf() else {
        return;
    };
    let (_qemu, port) = start_qemu_link("qemu-system-arm", &elf, None, false).unwrap();
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
    for c in [
        "nav 0 0 1 0 auto",
        "ref hold 0.5 0 1",
        "mode track-3d",
        "arm",
        "wait 1",
        "mode paper-xy",
        "disarm",
        "wait 0.3",
    ] {
        tx.send(c.to_string()).unwrap();
    }
    drop(tx);
    let mut csv = Vec::new();
    let rep = console(&mut link, Duration::from_millis(50), rx, &mut csv, false).unwrap();
    let text = String::from_utf8(csv).unwrap();
    let rows: Vec<&str> = text.lines().skip(1).collect();
    eprintln!(
        "{} rows, {} armed, {} acks, nacks {:?}",
        rep.telemetry_rows, rep.armed_rows, rep.acks, rep.nacks
    );
    assert!(rep.nacks.is_empty(), "refused: {:?}", rep.nacks);
    assert_eq!(rep.acks, 5);
    assert!(rep.armed_rows >= 5, "armed rows {}", rep.armed_rows);
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
