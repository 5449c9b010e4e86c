//! `host-sim hil` of a scenario with `[deployment] control = "topside"`
//! flies the two emulated images (`topside-emu`, `node-emu`, each in QEMU `netduinoplus2`,
//! stepped through their harness UARTs) in host-sim's closed loop, with the tether model
//! between them, and they fly as the firmware library's two roles do in process.
//!
//! One navigation scenario, `nav-circle-3d` in the topside layout, for [`DURATION_S`] of
//! simulated time (each simulated second costs about 450 node and 200 topside exchanges with
//! QEMU: seconds of wall time on loaded cores). Builds both images into
//! `<target>/hil-firmware`; without `qemu-system-arm` or the thumbv7em target it prints
//! `SKIPPED` with the fix and passes (`ROV_REQUIRE_QEMU` makes that a failure, as in CI). A
//! hung emulator fails the run: every read from a board times out after 30 s. The flown
//! comparison runs where `ROV_LONG` is set (CI; `long_emulated`), the cut node link
//! (2.5 s simulated) everywhere.

use crate::common;
use crate::long_emulated;

use common::{host_sim, scratch};
use host_sim::closed_loop::RunOptions;
use host_sim::tether::qemu::layout_images_or_skip;
use host_sim::tether::topside_layout::{
    run_layout_dvl, run_layout_on, Control, DvlPath, LayoutOutput, LayoutTarget,
};
use sim_scenario::Scenario;
use std::time::Instant;

/// Simulated time flown each way (s).
const DURATION_S: f64 = 10.0;

fn json(path: &std::path::Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap()
}

#[test]
fn hil_flies_the_emulated_topside_layout_as_the_in_process_one() {
    if !long_emulated::long_test(
        "deployment_qemu",
        "hil_flies_the_emulated_topside_layout_as_the_in_process_one",
        60,
    ) {
        return;
    }
    let Some(elfs) = layout_images_or_skip().unwrap() else {
        return;
    };
    println!(
        "images: {} and {}",
        elfs.topside.display(),
        elfs.node.display()
    );
    let dir = scratch("deployment-qemu", "circle");
    let src = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/nav-circle-3d.toml"),
    )
    .unwrap();
    // Its targets are for 150 s; the figures compared here are the layouts' own.
    let text = src
        .split("\n[expect]")
        .next()
        .unwrap()
        .replace("name = \"nav-circle-3d\"", "name = \"topside-circle\"\n");
    let f = dir.join("topside-circle.toml");
    std::fs::write(&f, format!("{text}\n[deployment]\ncontrol = \"topside\"\n")).unwrap();
    let f = f.to_str().unwrap();
    let duration = DURATION_S.to_string();

    let o = host_sim(
        &dir,
        &[
            "hil",
            f,
            "--in-process",
            "--duration",
            &duration,
            "--out",
            "ip",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{o:?}");
    let t0 = Instant::now();
    let o = host_sim(&dir, &["hil", f, "--duration", &duration, "--out", "emu"]);
    let wall = t0.elapsed();
    println!("{}", String::from_utf8_lossy(&o.stdout));
    assert_eq!(o.status.code(), Some(0), "{o:?}");

    let (ip, emu) = (
        json(&dir.join("ip/summary.json")),
        json(&dir.join("emu/summary.json")),
    );
    let (ip_l, emu_l) = (
        json(&dir.join("ip/layout.json")),
        json(&dir.join("emu/layout.json")),
    );
    assert_eq!(ip_l["roles"], "in process");
    assert!(
        emu_l["roles"].as_str().unwrap().starts_with("emulated"),
        "{emu_l}"
    );
    let rms = |s: &serde_json::Value| s["rms_position_error_last80_m"].as_f64().unwrap();
    let f64_of = |l: &serde_json::Value, k: &str| l[k].as_f64().unwrap();
    let (rms_ip, rms_emu) = (rms(&ip), rms(&emu));
    let p = |l: &serde_json::Value| l["latency_p50_p99_max_ms"].clone();
    println!(
        "{DURATION_S} s of nav-circle-3d, topside layout: true-position RMS (last 80 %) in \
         process {rms_ip:.4} m, emulated {rms_emu:.4} m; latency p50/p99/max in process {} \
         ms, emulated {} ms; downlinks applied {} / {}; node IMU {:.1} / {:.1} Hz; emulated \
         run {:.1} s wall",
        p(&ip_l),
        p(&emu_l),
        ip_l["downlinks_applied"],
        emu_l["downlinks_applied"],
        f64_of(&ip_l, "node_imu_hz"),
        f64_of(&emu_l, "node_imu_hz"),
        wall.as_secs_f64()
    );
    // The tracking bound, emulated against in process.
    assert!(
        rms_emu.is_finite() && (rms_emu - rms_ip).abs() <= 0.1 * rms_ip + 0.01,
        "emulated {rms_emu} m vs in process {rms_ip} m"
    );
    assert_eq!(emu_l["wrong_commands_applied"], 0, "{emu_l}");
    assert!(f64_of(&emu_l, "node_imu_hz") >= 400.0 - 1e-6, "{emu_l}");
    // The node applied a downlink per uplink (50 Hz), as in process.
    let applied = emu_l["downlinks_applied"].as_u64().unwrap();
    assert!(applied as f64 >= 0.95 * 50.0 * DURATION_S, "{emu_l}");
    // The sensor-to-thruster latency on the node's own timeline: the p99 <= 10 ms.
    let p99 = emu_l["latency_p50_p99_max_ms"][1].as_f64().unwrap();
    assert!(p99 <= 10.0, "{emu_l}");
    assert!(emu["diverged"] == false, "{emu}");
}

/// The node link cut at 1 s, emulated: the node is neutral 100 ms after its last good frame
/// (its downlink's time to live) and latched at 1 s, the ground station told within 250 ms
/// of the cut (the bounds), and the timings are the node's own (the harness runs the
/// node at its failsafes' times, not only at its IMU times).
#[test]
fn a_cut_node_link_goes_neutral_and_latches_on_the_emulated_node() {
    // Two boards in lock-step: 2.5 s simulated cost ~115 CPU-seconds. The README's command
    // flies the two emulated boards joined (firmware's `emulated_layout`) and the surface
    // program on them (`surface`'s `topside_layout`); the cut on the node's own clock is
    // CI's, and the in-process layout's cut is tested everywhere (`deployment`).
    if !long_emulated::long_test(
        "deployment_qemu",
        "a_cut_node_link_goes_neutral_and_latches_on_the_emulated_node",
        85,
    ) {
        return;
    }
    let Some(elfs) = layout_images_or_skip().unwrap() else {
        return;
    };
    let mut sc = Scenario::load("nav-circle-3d").unwrap();
    sc.deployment.control = Control::Topside;
    sc.deployment.tether_cut_s = Some(1.0);
    let opts = RunOptions {
        duration_s: Some(2.5),
        ..RunOptions::default()
    };
    let target = LayoutTarget::Emulated {
        elfs,
        qemu: "qemu-system-arm".into(),
    };
    let r = run_layout_on(&sc, &opts, &target).unwrap().report;
    println!(
        "cut at 1 s: last good frame {:?} s, neutral {:?} s, latched {:?} s, ground {:?} s",
        r.last_good_frame_s, r.node_neutral_s, r.node_latched_s, r.ground_saw_loss_s
    );
    let last = r.last_good_frame_s.unwrap();
    assert!(last < 1.0, "{r:?}");
    let neutral = r.node_neutral_s.unwrap() - last;
    assert!(neutral > 0.0 && neutral <= 0.1 + 1e-6, "{neutral} s: {r:?}");
    let latched = r.node_latched_s.unwrap() - last;
    assert!((latched - 1.0).abs() <= 1e-6, "{latched} s: {r:?}");
    let ground = r.ground_saw_loss_s.unwrap() - 1.0;
    assert!(ground > 0.0 && ground <= 0.25, "{ground} s: {r:?}");
    assert_eq!(r.wrong_commands_applied, 0);
}

/// The simulated DVL on the real path of the emulated topside layout: its A50 `wrz` reports
/// on the `node-emu`'s DVL UART (USART3), parsed and gated on the node, carried in its
/// uplinks and taken by the `topside-emu`'s estimator, as the in-process layout's node reads
/// them on its DVL port. 5 s of `nav-circle-3d` (the DVL at 5 Hz), each way: every report in
/// an uplink (none refused), the estimator's DVL reading in the ground station's telemetry
/// following them, and the tracking of the two within 10 % + 1 cm.
#[test]
fn the_emulated_topside_layouts_dvl_reaches_the_node_on_its_uart() {
    // The node's DVL on the emulated boards is flown everywhere by firmware's
    // `emulated_layout`; this closed-loop version in CI.
    if !long_emulated::long_test(
        "deployment_qemu",
        "the_emulated_topside_layouts_dvl_reaches_the_node_on_its_uart",
        40,
    ) {
        return;
    }
    let Some(elfs) = layout_images_or_skip().unwrap() else {
        return;
    };
    const DVL_DURATION_S: f64 = 5.0;
    let mut sc = Scenario::load("nav-circle-3d").unwrap();
    sc.deployment.control = Control::Topside;
    let opts = RunOptions {
        duration_s: Some(DVL_DURATION_S),
        ..RunOptions::default()
    };
    let ip = run_layout_dvl(&sc, &opts, &LayoutTarget::InProcess, DvlPath::NodeUart).unwrap();
    let t0 = Instant::now();
    let target = LayoutTarget::Emulated {
        elfs,
        qemu: "qemu-system-arm".into(),
    };
    let emu = run_layout_dvl(&sc, &opts, &target, DvlPath::NodeUart).unwrap();
    let rms = |o: &LayoutOutput| o.run.summary.rms_position_error_last80_m;
    let (ri, re) = (&ip.report, &emu.report);
    println!(
        "{DVL_DURATION_S} s of nav-circle-3d, topside layout, the DVL on the node's UART: \
         uplinks with a DVL velocity in process {} / emulated {}, refused {} / {}, fixes in \
         the ground's telemetry {} / {}; true-position RMS (last 80 %) {:.4} / {:.4} m; \
         latency IMU sample -> pulse p50/p99/max {:?} / {:?} ms; emulated run {:.1} s wall",
        ri.dvl_uplinks,
        re.dvl_uplinks,
        ri.node_counters.dvl_refused,
        re.node_counters.dvl_refused,
        ri.dvl_fixes_on_ground,
        re.dvl_fixes_on_ground,
        rms(&ip),
        rms(&emu),
        ri.latency_p50_p99_max_ms,
        re.latency_p50_p99_max_ms,
        t0.elapsed().as_secs_f64()
    );
    // 5 Hz over 5 s: 25 reports, the last maybe still on its way.
    let reports = (5.0 * DVL_DURATION_S) as u64;
    for r in [ri, re] {
        assert!(r.dvl_uplinks >= reports - 2, "{r:?}");
        assert!(r.dvl_uplinks <= reports + 1, "{r:?}");
        assert_eq!(r.node_counters.dvl_refused, 0, "{r:?}");
        // The telemetry (10 Hz) shows each fix the estimator took.
        assert!(r.dvl_fixes_on_ground >= reports - 3, "{r:?}");
        assert_eq!(r.wrong_commands_applied, 0);
    }
    let (rms_ip, rms_emu) = (rms(&ip), rms(&emu));
    assert!(
        rms_emu.is_finite() && (rms_emu - rms_ip).abs() <= 0.1 * rms_ip + 0.01,
        "emulated {rms_emu} m vs in process {rms_ip} m"
    );
    assert!(!emu.run.summary.diverged, "{:?}", emu.run.summary);
}
