//! Hardware in the loop with the firmware's `qemu` image on an emulated STM32F405
//! (`qemu-system-arm -M netduinoplus2`, on the host's clock: the instruction counts are
//! `scripts/mcu-cost.sh`'s), lock-step in simulated time.
//!
//! Skipped, with a message, when `qemu-system-arm` is not installed (CI installs it). The
//! image is built once per test binary into `<target>/hil-firmware` (or taken from
//! `HIL_FIRMWARE_ELF`).
//!
//! Everywhere: the link-loss failsafes and the estimator on the board over 20 s. Where
//! `ROV_LONG` is set (CI): the whole `paper-xy-saturated` (flown once: its first 30 s are
//! also the clean reference of the corrupted-bytes run), the corrupted-bytes run and the
//! estimator over 60 s (`long_emulated`).

use crate::long_emulated;

use firmware::protocol::fault;
use host_sim::closed_loop::runner::{run, RunOptions};
use host_sim::commands::hil::{run_hil, write_hil, HilOptions, HilOutput, HilTarget};
use host_sim::tether::link::NoiseSpec;
use host_sim::tether::qemu::image_or_skip;
use sim_scenario::Scenario;
use std::path::PathBuf;
use std::sync::OnceLock;
use std::time::Duration;

/// The firmware image, or `None` (test skipped, with the reason and the fix) without QEMU
/// or the thumbv7em target; built once per test binary.
fn firmware_elf() -> Option<PathBuf> {
    static ELF: OnceLock<Option<PathBuf>> = OnceLock::new();
    ELF.get_or_init(|| image_or_skip().expect("the firmware's qemu image"))
        .clone()
}

fn out_dir(name: &str) -> PathBuf {
    let d = std::env::var_os("CARGO_TARGET_TMPDIR")
        .map(PathBuf::from)
        .unwrap_or_else(std::env::temp_dir)
        .join(name);
    std::fs::create_dir_all(&d).expect("out dir");
    d
}

fn hil(sc: &Scenario, f: impl FnOnce(&mut HilOptions), name: &str) -> Option<HilOutput> {
    let elf = firmware_elf()?;
    let mut o = HilOptions::new(HilTarget::Qemu { elf });
    // A guard against a hung emulator, not a speed figure: four of these runs share two
    // cores with the rest of `cargo test`, and one took over 300 s on a loaded machine.
    o.wall_limit = Duration::from_secs(900);
    f(&mut o);
    let dir = out_dir(name);
    let out = run_hil(
        &sc.resolve().unwrap(),
        &o,
        Some(&dir.join("qemu-stdout.bin")),
    )
    .unwrap_or_else(|e| panic!("HIL run {name}: {e:#}"));
    write_hil(&dir, &out).expect("write outputs");
    eprintln!(
        "{name}: {}\n  link: {}",
        out.run.summary.verdict,
        serde_json::to_string(&out.report).unwrap()
    );
    Some(out)
}

/// The whole `paper-xy-saturated` on the emulated board, flown once per test binary: the
/// comparison with software and the clean reference of the corrupted-bytes run (its first
/// [`NOISE_RUN_S`]) are both taken from it.
fn whole_paper_xy_on_the_board() -> Option<&'static HilOutput> {
    static RUN: OnceLock<Option<HilOutput>> = OnceLock::new();
    RUN.get_or_init(|| {
        let sc = Scenario::load("paper-xy-saturated").unwrap();
        hil(&sc, |_| {}, "hil-paper-xy")
    })
    .as_ref()
}

/// Simulated time of the corrupted-bytes run (s).
const NOISE_RUN_S: f64 = 30.0;

/// RMS of the position error over the steps before `until_s`, as a run of that length
/// reports it (`rms_position_error_m`: every step's error).
fn rms_position_error_before(h: &HilOutput, until_s: f64) -> f64 {
    let errors: Vec<f64> = h
        .run
        .log
        .iter()
        .filter(|x| x.t_s < until_s)
        .map(|x| x.pos_err_norm_m)
        .collect();
    assert!(!errors.is_empty(), "no recorded step before {until_s} s");
    (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt()
}

/// The paper's XY scenario with the real thruster limits (`paper-xy-saturated`): the
/// firmware always applies the vehicle's limits (+20 N / -15 N), so the software run it is
/// compared with must too (`paper-xy` itself lets the software ask for 425 N).
#[test]
fn hil_paper_xy_tracks_within_2x_of_software() {
    if !long_emulated::long_test("hil_qemu", "hil_paper_xy_tracks_within_2x_of_software", 95) {
        return;
    }
    let sc = Scenario::load("paper-xy-saturated").unwrap();
    let Some(h) = whole_paper_xy_on_the_board() else {
        return;
    };
    let sw = run(&sc.resolve().unwrap(), &RunOptions::default()).unwrap();
    let (hs, ss) = (&h.run.summary, &sw.summary);
    eprintln!(
        "paper-xy RMS error: HIL {:.4} m, software {:.4} m; final: HIL {:.4} m, software {:.4} m",
        hs.rms_position_error_m,
        ss.rms_position_error_m,
        hs.final_position_error_m,
        ss.final_position_error_m,
    );
    assert!(!hs.nan_detected && !hs.diverged, "{}", hs.stop_reason);
    assert_eq!(h.report.steps_disarmed, 0, "the firmware disarmed");
    assert_eq!(h.report.steps_failsafe, 0, "a failsafe fired");
    // Within 2x of software (a 1 mm floor so a perfect software run does not make the bound 0).
    assert!(
        hs.rms_position_error_m <= 2.0 * ss.rms_position_error_m.max(1e-3),
        "HIL RMS {} vs software {}",
        hs.rms_position_error_m,
        ss.rms_position_error_m
    );
    assert!(
        hs.max_position_error_after_10s_m <= 2.0 * ss.max_position_error_after_10s_m.max(1e-3),
        "HIL max after 10 s {} vs software {}",
        hs.max_position_error_after_10s_m,
        ss.max_position_error_after_10s_m
    );
}

#[test]
fn hil_link_loss_goes_neutral_then_disarms() {
    // The paper XY law with real limits: it commands thrust all along the reference.
    let sc = Scenario::load("paper-xy-saturated").unwrap();
    // Where `ROV_LONG` is set (CI) 20 s of tracking before the stop, elsewhere 5 s: the same
    // comparisons (the thrusters work from the first second of this scenario).
    let stop = if long_emulated::long_runs_wanted() {
        20.0
    } else {
        5.0
    };
    let Some(h) = hil(
        &sc,
        |o| {
            o.heartbeat_stop_s = Some(stop);
            o.duration_s = Some(stop + 3.0);
        },
        "hil-link-loss",
    ) else {
        return;
    };
    let r = &h.report;
    let neutral = r.neutral_after_s.expect("never went neutral");
    let disarmed = r.disarmed_after_s.expect("never disarmed");
    eprintln!("heartbeats stopped at {stop} s: neutral after {neutral:.3} s, disarmed after {disarmed:.3} s");
    assert!(neutral <= 0.5 + 1e-9, "neutral after {neutral} s");
    assert!(disarmed <= 1.0 + 1e-9, "disarmed after {disarmed} s");
    // Before the stop it was armed and tracking, with thrust applied.
    let before: Vec<_> = h.telemetry.iter().filter(|t| t.t_s < stop).collect();
    assert!(before.iter().all(|t| t.armed));
    assert!(before.iter().any(|t| t.pulse_us.iter().any(|&p| p != 1500)));
    assert!(before
        .iter()
        .all(|t| t.faults & (fault::HEARTBEAT_LOST | fault::LINK_DISARMED) == 0));
    // Once neutral, it stays neutral: every output at 1500 us until the end.
    for t in h.telemetry.iter().filter(|t| t.t_s >= stop + neutral) {
        assert_eq!(t.pulse_us, [1500; 3], "not neutral at {} s", t.t_s);
    }
}

#[test]
fn hil_corrupted_bytes_do_not_lose_control() {
    if !long_emulated::long_test("hil_qemu", "hil_corrupted_bytes_do_not_lose_control", 40) {
        return;
    }
    let sc = Scenario::load("paper-xy-saturated").unwrap();
    let dur = NOISE_RUN_S;
    let Some(noisy) = hil(
        &sc,
        |o| {
            o.duration_s = Some(dur);
            o.noise = Some(NoiseSpec {
                tx_frame_error_prob: 0.05,
                tx_garbage_prob: 0.05,
                rx_byte_error_prob: 0.0005,
                seed: 7,
            });
            o.reply_timeout = Duration::from_millis(50);
        },
        "hil-noise-30s",
    ) else {
        return;
    };
    // The clean run: the first 30 s of the whole scenario on the board (lock-step and
    // `-icount`: the same steps as a 30 s run of its own).
    let Some(whole) = whole_paper_xy_on_the_board() else {
        return;
    };
    let clean_rms_m = rms_position_error_before(whole, dur);
    let r = &noisy.report;
    eprintln!(
        "noise: {} frames corrupted, {} garbage bytes, {} received bytes corrupted, firmware \
         dropped {}, host dropped {}, {} steps resent; RMS error clean {:.4} m, noisy {:.4} m",
        r.host.frames_corrupted,
        r.host.garbage_bytes,
        r.host.rx_bytes_corrupted,
        r.firmware_dropped_frames,
        r.host.frames_dropped,
        r.steps_resent,
        clean_rms_m,
        noisy.run.summary.rms_position_error_m
    );
    assert!(r.host.frames_corrupted > 0 && r.firmware_dropped_frames > 0);
    assert_eq!(r.steps_disarmed, 0, "disarmed under noise");
    assert_eq!(r.steps_failsafe, 0, "a failsafe fired under noise");
    let s = &noisy.run.summary;
    assert!(!s.nan_detected && !s.diverged, "{}", s.stop_reason);
    assert!(
        s.rms_position_error_m <= 1.5 * clean_rms_m + 1e-3,
        "noisy RMS {} vs clean {clean_rms_m}",
        s.rms_position_error_m,
    );
}

/// The estimator on the emulated Cortex-M4F: `nav-circle-3d` (IMU, depth,
/// compass, DVL and 1 Hz USBL) with the sensor readings and fixes sent over the tether and
/// the firmware estimating, against the same scenario with the estimator in software (the
/// same sensor draws). 60 s of the 300 s scenario where `ROV_LONG` is set (CI), 20 s
/// elsewhere: the same comparisons, the fixes counted at the same rate (25 in 60 s).
#[test]
fn hil_estimator_on_the_mcu_matches_software_within_a_few_percent() {
    let sc = Scenario::load("nav-circle-3d").unwrap();
    let duration: f64 = if long_emulated::long_runs_wanted() {
        60.0
    } else {
        20.0
    };
    let Some(h) = hil(
        &sc,
        |o| {
            o.duration_s = Some(duration);
            // The thrust the law commands, as in software (not that of the ESC pulses).
            o.apply_pulses = false;
            // The DVL's fixes over the tether, as the software run takes them (its wire
            // format on the board's UART is `emulated_instruments.rs`'s).
            o.dvl_on_uart = false;
        },
        "hil-nav-circle-3d",
    ) else {
        return;
    };
    let sw = run(
        &sc.resolve().unwrap(),
        &RunOptions {
            duration_s: Some(duration),
            ..RunOptions::default()
        },
    )
    .unwrap();
    let (hs, ss) = (&h.run.summary, &sw.summary);
    let health = h
        .report
        .nav_health
        .expect("the firmware's estimator counters");
    eprintln!(
        "nav-circle-3d {duration} s: tracking RMS HIL {:.5} m, software {:.5} m; estimation RMS \
         HIL {:.5} m, software {:.5} m; {health:?}",
        hs.rms_position_error_m,
        ss.rms_position_error_m,
        hs.rms_estimation_error_m,
        ss.rms_estimation_error_m,
    );
    assert!(h.report.onboard_estimator);
    assert_eq!(h.report.steps_failsafe, 0, "a failsafe fired");
    assert_eq!(health.imu_samples, (duration * 100.0) as u32);
    let fixes_wanted = (25.0 * duration / 60.0).floor() as u32;
    assert!(health.position_fused >= fixes_wanted, "{health:?}");
    for (name, hil, soft) in [
        (
            "tracking RMS",
            hs.rms_position_error_m,
            ss.rms_position_error_m,
        ),
        (
            "estimation RMS",
            hs.rms_estimation_error_m,
            ss.rms_estimation_error_m,
        ),
        (
            "largest thrust",
            hs.max_abs_thruster_force_n,
            ss.max_abs_thruster_force_n,
        ),
    ] {
        assert!(
            (hil - soft).abs() <= 0.03 * soft,
            "{name}: HIL {hil} vs software {soft} (more than 3 % apart)"
        );
    }
}
