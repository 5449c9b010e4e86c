//! The firmware library's `App` in process as the loop's controller: the same frames, state
//! machine and PWM quantization as the firmware image, through the same closed loop as a
//! software run. No emulator needed, so these run everywhere.

use host_sim::closed_loop::runner::{run, RunOptions};
use host_sim::commands::hil::{run_hil, HilOptions, HilTarget};
use sim_scenario::{ControllerKind, Scenario};
use std::time::Duration;

fn in_process(
    sc: &Scenario,
    f: impl FnOnce(&mut HilOptions),
) -> host_sim::commands::hil::HilOutput {
    let mut o = HilOptions::new(HilTarget::InProcess);
    o.wall_limit = Duration::from_secs(300);
    o.record = false;
    f(&mut o);
    run_hil(&sc.resolve().unwrap(), &o, None).expect("in-process run")
}

/// The tracking law through the firmware library matches the core in process: the only
/// differences are the 1 us PWM quantization and the thrust of the pulse widths.
#[test]
fn in_process_firmware_tracks_like_the_core() {
    let mut sc = Scenario::load("paper-xy-saturated").unwrap();
    sc.controller = ControllerKind::Tracking;
    let fw = in_process(&sc, |_| {});
    let sw = run(&sc.resolve().unwrap(), &RunOptions::default()).unwrap();
    let (f, s) = (&fw.run.summary, &sw.summary);
    eprintln!(
        "in-process firmware: RMS {:.5} m, max after 10 s {:.5} m, final {:.5} m; software: RMS \
         {:.5} m, max after 10 s {:.5} m, final {:.5} m",
        f.rms_position_error_m,
        f.max_position_error_after_10s_m,
        f.final_position_error_m,
        s.rms_position_error_m,
        s.max_position_error_after_10s_m,
        s.final_position_error_m
    );
    assert!(!f.nan_detected && !f.diverged, "{}", f.stop_reason);
    assert_eq!(
        fw.report.steps, f.control_steps,
        "one exchange a control step"
    );
    assert_eq!(fw.report.steps_disarmed, 0);
    assert_eq!(fw.report.steps_failsafe, 0);
    assert_eq!(fw.report.host.frames_dropped, 0);
    // Within 5 % (and 0.5 mm) of the software run on RMS, and 1 cm on the worst error.
    assert!(
        (f.rms_position_error_m - s.rms_position_error_m).abs()
            <= 0.05 * s.rms_position_error_m + 5e-4,
        "RMS {} vs {}",
        f.rms_position_error_m,
        s.rms_position_error_m
    );
    assert!(f.max_position_error_after_10s_m <= s.max_position_error_after_10s_m + 0.01);
    assert!(f.max_abs_thruster_force_n <= 20.0 + 1e-3);
}

/// Heartbeats stop: the firmware library goes neutral within its 0.5 s timeout and disarms
/// within 1 s, exactly as on the emulated board.
#[test]
fn in_process_firmware_link_loss_goes_neutral_then_disarms() {
    let sc = Scenario::load("paper-xy-saturated").unwrap();
    let stop = 20.0;
    let h = in_process(&sc, |o| {
        o.heartbeat_stop_s = Some(stop);
        o.duration_s = Some(stop + 3.0);
    });
    let r = &h.report;
    let neutral = r.neutral_after_s.expect("never went neutral");
    let disarmed = r.disarmed_after_s.expect("never disarmed");
    assert!(neutral <= 0.5 + 1e-9, "neutral after {neutral} s");
    assert!(disarmed <= 1.0 + 1e-9, "disarmed after {disarmed} s");
    for t in h.telemetry.iter().filter(|t| t.t_s >= stop + neutral) {
        assert_eq!(t.pulse_us, [1500; 3], "at {} s", t.t_s);
    }
}

/// The estimator in the firmware library: the whole `nav-circle-3d` run with the
/// sensor readings and fixes over the tether and the firmware estimating matches the
/// software run with the estimator in process (the same core code, the same draws; a depth
/// travels as a pressure and back).
#[test]
fn in_process_estimator_on_the_vehicle_matches_software() {
    let sc = Scenario::load("nav-circle-3d").unwrap();
    let fw = in_process(&sc, |o| o.apply_pulses = false);
    let sw = run(&sc.resolve().unwrap(), &RunOptions::default()).unwrap();
    let (f, s) = (&fw.run.summary, &sw.summary);
    eprintln!(
        "on the vehicle: tracking RMS {:.5} m, estimation RMS {:.5} m; software: {:.5} m, \
         {:.5} m; {:?}",
        f.rms_position_error_m,
        f.rms_estimation_error_m,
        s.rms_position_error_m,
        s.rms_estimation_error_m,
        fw.report.nav_health
    );
    assert!(fw.report.onboard_estimator);
    assert_eq!(fw.report.steps_failsafe, 0);
    for (name, a, b) in [
        (
            "tracking RMS",
            f.rms_position_error_m,
            s.rms_position_error_m,
        ),
        (
            "estimation RMS",
            f.rms_estimation_error_m,
            s.rms_estimation_error_m,
        ),
        (
            "max after 10 s",
            f.max_position_error_after_10s_m,
            s.max_position_error_after_10s_m,
        ),
    ] {
        assert!(
            (a - b).abs() <= 0.01 * b,
            "{name}: vehicle {a} vs software {b}"
        );
    }
    // The navigation bound holds on the vehicle too: estimation within 10 cm.
    assert!(f.rms_estimation_error_m <= 0.10);
}
