//! The numbers for the topside layout, measured with the firmware library's topside
//! App and node in process over the byte-level tether model (`host-sim deployment` prints
//! the same figures; docs/deployment.md keeps them with their date).
//!
//! The bounds are the issue's: tracking within 10 % + 1 cm of the onboard layout; p99 of the
//! sensor-to-thruster latency <= 10 ms at 115,200 Bd and at 1 Mbd; told the delay, within
//! 5 cm of the zero-latency run up to 100 ms one-way; after a cut, the node neutral within
//! 100 ms of its last good frame and latched at 1 s, the ground station told within 250 ms,
//! re-arming explicit; byte corruption at 1e-3 and 1e-2 applies no wrong command.

use crate::common;

use common::{host_sim, scratch};
use firmware::protocol::Command;
use firmware::topside_link::fault;
use host_sim::closed_loop::estimator_nav::VehicleNav;
use host_sim::closed_loop::{ClosedLoop, RunOptions};
use host_sim::commands::deployment::{self, bound};
use host_sim::tether::topside_layout::{layout_scenario, TopsideLayout};
use sim_scenario::Scenario;

#[test]
fn the_topside_layout_tracks_within_10_percent_plus_1_cm_of_the_onboard_one() {
    for name in deployment::TRACKING_SCENARIOS {
        let r = deployment::tracking(name, 115_200, None).unwrap();
        println!(
            "{name}: onboard {:.4} m, topside {:.4} m, bound {:.4} m",
            r.onboard_rms_last80_m, r.topside_rms_last80_m, r.bound_m
        );
        assert!(r.met, "{r:?}");
    }
}

#[test]
fn sensor_to_thruster_latency_p99_is_within_10_ms_at_115200_and_1_mbd() {
    let slow = deployment::latency(115_200, Some(60.0)).unwrap();
    let fast = deployment::latency(1_000_000, Some(60.0)).unwrap();
    for l in [&slow, &fast] {
        println!(
            "{} Bd: n {} p50 {} ms p99 {} ms max {} ms; from the oldest sample p99 {} ms",
            l.baud, l.n, l.p50_ms, l.p99_ms, l.max_ms, l.p99_oldest_ms
        );
        // A pulse every uplink, for 60 s at 50 Hz.
        assert!(l.n >= 2_900, "{l:?}");
        assert!(l.p99_ms <= bound::LATENCY_P99_MS, "{l:?}");
    }
    // No faster than the wire: the uplink (at least 40 bytes) and the downlink (at least 20)
    // at 86.8 us a byte at 115,200 Bd.
    assert!(slow.p50_ms >= 60.0 * 0.0868, "{slow:?}");
    assert!(fast.p50_ms < slow.p50_ms / 4.0, "{fast:?} vs {slow:?}");
    // The increments cover one link period: their oldest sample is 20 ms older.
    assert!(
        (slow.p99_oldest_ms - slow.p99_ms - 20.0).abs() < 0.5,
        "{slow:?}"
    );
}

/// The "told the delay, within 5 cm up to at least 100 ms", as it is judged here:
/// within 5 cm of the zero-latency told run (`deployment::delay_met`). The absolute 5 cm is
/// not reached at any latency (6.8 cm at 0 ms: the estimate's own error), as
/// README's table says.
#[test]
fn told_the_delay_the_error_grows_by_at_most_5_cm_up_to_100_ms_one_way() {
    let rows: Vec<_> = [0.0, 0.05, 0.1]
        .iter()
        .map(|&l| deployment::delay(l, 115_200, None).unwrap())
        .collect();
    for r in &rows {
        println!(
            "{} ms one-way: not told {:.4} m, told {:?} m ({} s told)",
            r.latency_s * 1e3,
            r.rms_not_told_m,
            r.rms_told_m,
            r.told_delay_s
        );
    }
    assert!(deployment::delay_met(&rows), "{rows:?}");
    // The delay told grows with the latency: twice the one-way latency and the wire times.
    assert!((rows[2].told_delay_s - rows[0].told_delay_s - 0.2).abs() < 1e-9);
}

#[test]
fn a_cut_node_link_goes_neutral_latches_and_is_reported() {
    let c = deployment::cut(20.0, 115_200).unwrap();
    println!("{c:?}");
    assert!(c.met, "{c:?}");
    // The last good frame came from before the cut.
    let last = c.last_good_frame_s.unwrap();
    assert!((19.9..20.0).contains(&last), "{c:?}");
}

/// Step the loop to `t_s`.
fn run_to<N: host_sim::closed_loop::Navigation>(run: &mut ClosedLoop<N, TopsideLayout>, t_s: f64) {
    while run.t_s() < t_s {
        assert!(
            run.step().unwrap(),
            "the run stopped: {}",
            run.stop_reason()
        );
    }
}

#[test]
fn after_a_cut_the_node_arms_again_only_when_the_surface_disarms_and_arms() {
    let sc = deployment::topside(deployment::PROBE_SCENARIO, 115_200).unwrap();
    let sc = layout_scenario(&sc).resolve().unwrap();
    let endpoint = TopsideLayout::for_scenario(&sc).unwrap();
    let nav = VehicleNav::for_scenario(&sc, 1);
    let opts = RunOptions {
        duration_s: Some(30.0),
        ..RunOptions::default()
    };
    let mut run = ClosedLoop::new(&sc, &opts, nav, endpoint).unwrap();
    run_to(&mut run, 5.0);
    assert!(run.endpoint().node().armed());
    // Cut for 2 s, then mended.
    run.endpoint_mut().wire_mut().set_cut(Some(5.0));
    run_to(&mut run, 7.0);
    assert!(!run.endpoint().node().armed(), "latched after 1 s");
    run.endpoint_mut().wire_mut().set_cut(None);
    run_to(&mut run, 9.0);
    // The link is back and the topside is still armed, but the node stays latched and
    // neutral, and says so.
    let e = run.endpoint();
    assert!(e.topside_armed());
    assert!(!e.node().armed());
    assert_eq!(e.node().output_us(), [1500; 3]);
    assert_eq!(e.link_faults() & fault::NODE_LINK_LOST, 0);
    assert_ne!(e.link_faults() & fault::NODE_NOT_ARMED, 0);
    let tel = e.latest_telemetry().unwrap();
    assert_ne!(
        tel.faults & fault::NODE_NOT_ARMED,
        0,
        "the ground station is told"
    );
    // The explicit arm transition: disarm, then arm (a tracking mode needs its reference
    // again after a disarm: the ground station holds here).
    run.endpoint_mut().queue_command(Command::Disarm);
    run_to(&mut run, 9.2);
    assert!(!run.endpoint().node().armed());
    let here = run.sample().state.eta;
    run.endpoint_mut().queue_command(Command::SetReference {
        reference: controller_core::reference::Reference::Hold {
            pos_m: [here[0] as f32, here[1] as f32, here[2] as f32],
        },
        start_us: None,
    });
    run.endpoint_mut().queue_command(Command::Arm);
    run_to(&mut run, 9.5);
    let e = run.endpoint();
    assert!(e.node().armed(), "armed again after Disarm, Arm");
    assert_eq!(e.link_faults(), 0);
    assert_ne!(e.node().output_us(), [1500; 3], "flying again");
}

#[test]
fn byte_corruption_never_applies_a_wrong_command() {
    for rate in [1e-3, 1e-2] {
        let k = deployment::corruption(rate, 115_200, Some(60.0)).unwrap();
        println!("{k:?}");
        assert_eq!(k.wrong, 0, "{k:?}");
        // The corruption was there, and the link kept working through it.
        assert!(k.node_refused > 0 && k.topside_refused > 0, "{k:?}");
        assert!(k.applied > 2_500, "{k:?}");
        assert!(k.rms_last80_m < 0.2, "{k:?}");
    }
}

#[test]
fn bad_deployment_keys_are_refused_naming_the_key() {
    let base = "name = \"t\"\nplane = \"3d\"\ncontroller = \"tracking\"\nduration_s = 5.0\n\
        [reference]\nkind = \"hold\"\n[navigation]\nsource = \"estimator\"\n\
        [sensors.imu]\n[sensors.depth]\n[sensors.compass]\n[sensors.usbl]\n";
    let ok = Scenario::from_toml(
        &format!("{base}[deployment]\ncontrol = \"topside\"\ntether_baud = 1000000\n"),
        "ok",
    );
    assert!(ok.is_ok(), "{ok:?}");
    for (extra, key) in [
        ("control = \"sideways\"", "control"),
        ("tether_baud = 0", "tether_baud"),
        ("tether_latency_s = -0.1", "tether_latency_s"),
        ("tether_latency_s = nan", "tether_latency_s"),
        ("tether_jitter_s = -1.0", "tether_jitter_s"),
        ("tether_corruption = 2.0", "tether_corruption"),
        ("tether_cut_s = -3.0", "tether_cut_s"),
        ("told_delay_s = 0.9", "told_delay_s"),
        ("tether_latency_s = 0.3\ntell_delay = true", "tell_delay"),
        ("tether_wet = true", "tether_wet"),
    ] {
        let e = Scenario::from_toml(&format!("{base}[deployment]\n{extra}\n"), "bad")
            .map(|_| ())
            .unwrap_err();
        let msg = format!("{e:#}");
        assert!(msg.contains(key), "{extra}: {msg}");
    }
    // The topside layout needs the estimator: the node's sensors feed it.
    let truth = base.replace("source = \"estimator\"", "source = \"truth\"");
    let e = Scenario::from_toml(
        &format!("{truth}[deployment]\ncontrol = \"topside\"\n"),
        "t",
    )
    .map(|_| ())
    .unwrap_err();
    assert!(format!("{e:#}").contains("deployment.control"), "{e:#}");
}

#[test]
fn run_and_hil_fly_the_topside_layout_and_deployment_refuses_bad_arguments() {
    let dir = scratch("deployment", "run");
    let src = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/nav-circle-3d.toml"),
    )
    .unwrap();
    let text = src
        .split("\n[expect]")
        .next()
        .unwrap()
        .replace("name = \"nav-circle-3d\"", "name = \"topside-circle\"\n");
    let text = text.replace("duration_s = 150.0", "duration_s = 10.0");
    let f = dir.join("topside-circle.toml");
    std::fs::write(&f, format!("{text}\n[deployment]\ncontrol = \"topside\"\n")).unwrap();
    let o = host_sim(&dir, &["run", f.to_str().unwrap(), "--out", "o"]);
    assert_eq!(o.status.code(), Some(0), "{o:?}");
    let summary = std::fs::read_to_string(dir.join("o/summary.json")).unwrap();
    assert!(summary.contains("estimator on the vehicle"), "{summary}");
    // `hil` flies it in process (emulated: tests/deployment_qemu.rs), and refuses one board.
    let o = host_sim(
        &dir,
        &["hil", f.to_str().unwrap(), "--in-process", "--out", "h"],
    );
    assert_eq!(o.status.code(), Some(0), "{o:?}");
    assert!(dir.join("h/layout.json").exists());
    let o = host_sim(
        &dir,
        &[
            "hil",
            f.to_str().unwrap(),
            "--tcp",
            "127.0.0.1:1",
            "--out",
            "q",
        ],
    );
    assert_eq!(o.status.code(), Some(2), "{o:?}");
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("--in-process"),
        "{o:?}"
    );
    for args in [
        &["deployment", "--baud", "0"][..],
        &["deployment", "--duration", "-1"],
        &["deployment", "--cut-at", "nan"],
    ] {
        let o = host_sim(&dir, args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {o:?}");
    }
}

#[test]
fn jitter_delays_the_pulses_but_never_reorders_or_corrupts_them() {
    let mut sc = deployment::topside(deployment::PROBE_SCENARIO, 115_200).unwrap();
    sc.deployment.tether_jitter_s = 0.005;
    let out = deployment::fly(&sc, Some(30.0)).unwrap();
    let r = &out.report;
    let p50 = r.latency.quantile_ms(0.5).unwrap();
    let p99 = r.latency.quantile_ms(0.99).unwrap();
    let max = r.latency.quantile_ms(1.0).unwrap();
    println!(
        "jitter 5 ms: p50 {p50} ms p99 {p99} ms max {max} ms, {} applied",
        r.downlinks_applied
    );
    // Up to 5 ms on each of the two frames, on top of the 7.4 ms of the clean wire; and a
    // late uplink can find the line taken by the topside's periodic downlink (sent 20 ms
    // after the last one), so the step's downlink waits one downlink's wire time (<= 2.8 ms).
    assert!(p99 > 7.5 && p99 <= 7.4 + 10.0 + 2.8, "{p99}");
    assert_eq!(r.wrong_commands_applied, 0);
    assert_eq!(
        r.node_counters.corrupt, 0,
        "bytes are delayed, never reordered"
    );
    assert_eq!(r.topside_counters.corrupt, 0);
    assert!(out.run.summary.rms_position_error_last80_m < 0.12);
}

#[test]
fn the_link_period_follows_the_rate_so_the_oldest_sample_at_1_mbd_is_within_10_ms() {
    // 1 Mbd: the default link period is 5 ms (the uplink keeps the link 20 % busy), so the
    // oldest sample of the increments is 5 ms older than the newest, not 20.
    let fast = deployment::latency(1_000_000, Some(30.0)).unwrap();
    // 115,200 Bd: the half-busy rule allows 18.75 ms at the shortest (the node link's
    // version 4 uplink, with the DVL: 108 B), 20 ms in whole IMU periods.
    let shortest = deployment::shortest_link_period_us(115_200);
    assert_eq!(shortest, 20_000);
    let slow = deployment::latency_at(115_200, Some(0.02), Some(30.0)).unwrap();
    for l in [&fast, &slow] {
        println!(
            "{} Bd, period {} us: n {} p99 {} ms, from the oldest sample p99 {} ms",
            l.baud, l.link_period_us, l.n, l.p99_ms, l.p99_oldest_ms
        );
        let period_ms = f64::from(l.link_period_us) * 1e-3;
        assert!(
            (l.p99_oldest_ms - l.p99_ms - period_ms).abs() < 0.5,
            "{l:?}"
        );
        assert!(l.p99_ms <= bound::LATENCY_P99_MS, "{l:?}");
        // A pulse every uplink.
        assert!(l.n as f64 >= 0.95 * 30.0 / (period_ms * 1e-3), "{l:?}");
    }
    assert_eq!(fast.link_period_us, 5_000);
    assert!(fast.p99_oldest_ms <= bound::LATENCY_P99_MS, "{fast:?}");
    assert_eq!(slow.link_period_us, 20_000);
    // The oldest sample at most 9 ms beyond the link period (the margin held at 17.5 ms).
    assert!(slow.p99_oldest_ms < 20.0 + 9.0, "{slow:?}");
}

#[test]
fn the_round_trip_is_measured_at_any_latency_of_the_sweep() {
    // The topside kept the send times of 8 downlinks (160 ms) before the node link's
    // version 2, and read no round trip beyond; the echoed send time has no such limit.
    for latency_s in [0.2, 0.5] {
        let mut sc = deployment::topside(deployment::PROBE_SCENARIO, 115_200).unwrap();
        sc.deployment.tether_latency_s = latency_s;
        let out = deployment::fly(&sc, Some(5.0)).unwrap();
        let rt_ms = f64::from(out.report.round_trip_us.unwrap()) * 1e-3;
        // Twice the latency, the two frames' wire times (33 + 92 B at most, 86.8 us a
        // byte) and the passes.
        let wires_ms = 125.0 * 0.0868;
        println!("{} ms one-way: round trip {rt_ms} ms", latency_s * 1e3);
        assert!(rt_ms >= 2e3 * latency_s, "{rt_ms}");
        assert!(rt_ms <= 2e3 * latency_s + wires_ms + 0.5, "{rt_ms}");
    }
}

#[test]
fn a_bad_link_period_is_refused_naming_the_key() {
    let base = "name = \"t\"\nplane = \"3d\"\ncontroller = \"tracking\"\nduration_s = 5.0\n\
        [reference]\nkind = \"hold\"\n[navigation]\nsource = \"estimator\"\n\
        [sensors.imu]\n[sensors.depth]\n[sensors.compass]\n[sensors.usbl]\n\
        [deployment]\ncontrol = \"topside\"\n";
    for ok in [
        "link_period_s = 0.02",
        "tether_baud = 1000000\nlink_period_s = 0.0025",
    ] {
        let r = Scenario::from_toml(&format!("{base}{ok}\n"), "ok");
        assert!(r.is_ok(), "{ok}: {r:?}");
    }
    for (bad, why) in [
        ("link_period_s = 0.001", "IMU period"),
        ("link_period_s = 0.015", "50 % busy"),
        ("link_period_s = 0.0175", "50 % busy"),
        ("link_period_s = 0.025", "50 Hz"),
        ("link_period_s = nan", "not a number"),
        ("tether_baud = 9600", "50 % busy"),
    ] {
        let e = Scenario::from_toml(&format!("{base}{bad}\n"), "bad")
            .map(|_| ())
            .unwrap_err();
        let msg = format!("{e:#}");
        assert!(
            msg.contains("deployment.link_period_s") && msg.contains(why),
            "{bad}: {msg}"
        );
    }
}

/// The emulated images run the node link at its default 20 ms with arrival stamps: a
/// scenario asking for another period (1 Mbd's default 5 ms) or node-time stamps is refused
/// before any emulator starts, with the keys named, and nothing is flown.
#[test]
fn the_emulated_layout_refuses_link_settings_its_images_do_not_run() {
    use host_sim::tether::qemu::LayoutElfs;
    let base = "name = \"t\"\nplane = \"3d\"\ncontroller = \"tracking\"\nduration_s = 5.0\n\
        [reference]\nkind = \"hold\"\n[navigation]\nsource = \"estimator\"\n\
        [sensors.imu]\n[sensors.depth]\n[sensors.compass]\n[sensors.usbl]\n\
        [deployment]\ncontrol = \"topside\"\n";
    // Paths that do not exist: the refusal must come before any emulator is started.
    let elfs = LayoutElfs {
        topside: "/nonexistent/topside-emu".into(),
        node: "/nonexistent/node-emu".into(),
    };
    for extra in [
        "tether_baud = 1000000",
        "tether_baud = 1000000\nlink_period_s = 0.01",
        "stamp_node_time = true",
    ] {
        let sc = Scenario::from_toml(&format!("{base}{extra}\n"), "t")
            .unwrap()
            .resolve()
            .unwrap();
        let e = TopsideLayout::emulated(&sc, &elfs, "qemu-system-arm-not-started")
            .map(|_| ())
            .unwrap_err();
        let msg = format!("{e:#}");
        assert!(
            msg.contains("deployment.link_period_s") && msg.contains("--in-process"),
            "{extra}: {msg}"
        );
    }
    // The images' own settings pass this check (then the missing images are the error).
    let sc = Scenario::from_toml(
        &format!("{base}tether_baud = 1000000\nlink_period_s = 0.02\n"),
        "t",
    )
    .unwrap()
    .resolve()
    .unwrap();
    let e = TopsideLayout::emulated(&sc, &elfs, "qemu-system-arm-not-started")
        .map(|_| ())
        .unwrap_err();
    assert!(
        !format!("{e:#}").contains("deployment.link_period_s"),
        "{e:#}"
    );
}

/// The bound read as absolute: told the delay, the true-position RMS itself within
/// 5 cm up to 100 ms one-way. Not met: the estimate's own error at 0 ms is above it.
#[test]
#[ignore = "not met: told, 115,200 Bd, nav-circle-3d: 6.8 / 6.2 / 6.5 cm at 0 / 50 / 100 ms one-way (2026-11-26, node link v2); 5 cm is not reached at 0 ms either"]
fn told_the_delay_the_error_stays_within_5_cm_absolute_up_to_100_ms_one_way() {
    for l in [0.0, 0.05, 0.1] {
        let r = deployment::delay(l, 115_200, None).unwrap();
        let m = r.rms_told_m.unwrap();
        println!("{} ms one-way, told: {:.2} cm", l * 1e3, 100.0 * m);
        assert!(m <= 0.05, "{} ms: {:.2} cm", l * 1e3, 100.0 * m);
    }
}
