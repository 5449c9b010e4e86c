//! The emulated board's instruments (QEMU `netduinoplus2`, the firmware's `qemu` image,
//! `host-sim hil --qemu`): the health inputs the host sends on its USART3 (the simulated
//! battery read as the power-sense module's ADC pins, the leak probe's GPIO) and the DVL's
//! A50 reports on its USART2, parsed and gated on the board.
//!
//! - a leak: SURFACE starts <= 0.5 s after the probe reads wet, and the vehicle rises;
//! - the battery's charge: SURFACE within 1 s of the simulated truth crossing `BATT_CRT_MAH`
//!   (the vehicle counts from a full battery at boot);
//! - `nav-circle-3d` with the DVL through its wire format: the true tracking and estimation
//!   RMS within 10 % + 1 cm of `host-sim run`, every DVL report fused.
//!
//! Skipped, with a message, without `qemu-system-arm` or the thumbv7em target (failed under
//! `ROV_REQUIRE_QEMU`). The navigation run (13 minutes of wall time on a loaded 2-core
//! machine) runs where `ROV_LONG=all` is set (the long tests CI leaves out, docs/testing.md);
//! elsewhere it prints `SKIPPED` and how to run it.

// Test code: a failed expectation should stop the test.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use controller_core::alloc::PwmMap;
use firmware::protocol::{fault, Mode};
use host_sim::closed_loop::runner::{run, RunOptions};
use host_sim::commands::hil::{run_hil, HilOptions, HilOutput, HilTarget};
use host_sim::tether::qemu::image_or_skip;
use sim_scenario::Scenario;
use sim_world::battery::VehicleElectrics;
use sim_world::clock::us;
use std::time::Duration;

/// A 5 m circle at 2 m depth on the plant's truth, with `extra` TOML tables, for
/// `duration_s`.
fn circle(extra: &str, duration_s: f64) -> Scenario {
    let text = format!(
        r#"name = "emulated-health"
description = "circle-3d with health events"
plane = "3d"
controller = "tracking"
duration_s = {duration_s}

[reference]
kind = "circle"
center_m = [0.0, 5.0, 2.0]
radius_m = 5.0
speed_m_s = 0.25

[initial]
z_m = 2.0

[thrusters]
saturate = true

{extra}
"#
    );
    Scenario::from_toml(&text, "emulated_instruments.rs").unwrap()
}

/// The scenario on the emulated board, recorded; `None` when QEMU or the image is missing.
fn on_the_board(sc: &Scenario) -> Option<HilOutput> {
    let elf = image_or_skip().expect("the firmware's qemu image")?;
    let mut o = HilOptions::new(HilTarget::Qemu { elf });
    o.wall_limit = Duration::from_secs(900);
    o.record = true;
    Some(run_hil(&sc.resolve().unwrap(), &o, None).unwrap())
}

/// First time at or after `after_s` when `pred` holds on a telemetry row.
fn first_row(
    out: &HilOutput,
    after_s: f64,
    pred: impl Fn(&host_sim::commands::hil::TelemetryRow) -> bool,
) -> Option<f64> {
    out.telemetry
        .iter()
        .find(|r| r.t_s >= after_s && pred(r))
        .map(|r| r.t_s)
}

/// True depth at `t_s` (the recorded run).
fn depth_at(out: &HilOutput, t_s: f64) -> f64 {
    out.run
        .log
        .iter()
        .find(|x| x.t_s >= t_s)
        .map(|x| x.state.eta[2])
        .unwrap()
}

#[test]
fn a_leak_on_the_emulated_board_surfaces_within_half_a_second() {
    // The leak 2 s into the circle, the flight 10 s after it to rise.
    let leak_at_s = 2.0;
    let end_s = leak_at_s + 10.0;
    let sc = circle(
        &format!("[health]\nleak_at_s = {leak_at_s}\nfs_leak_enable = 2\n"),
        end_s,
    );
    let Some(out) = on_the_board(&sc) else {
        return;
    };
    assert!(
        first_row(&out, 0.0, |r| r.telemetry.mode == Mode::Surface).unwrap() >= leak_at_s,
        "SURFACE before the leak"
    );
    let t_surface =
        first_row(&out, 0.0, |r| r.telemetry.mode == Mode::Surface).expect("SURFACE never entered");
    let t_fault = first_row(&out, 0.0, |r| r.telemetry.faults & fault::LEAK != 0).unwrap();
    let (z_leak, z_end) = (depth_at(&out, t_surface), depth_at(&out, end_s - 0.1));
    println!(
        "leak at {leak_at_s:.2} s: SURFACE at {t_surface:.2} s (+{:.2} s), LEAK fault at \
         {t_fault:.2} s; depth {z_leak:.2} m -> {z_end:.2} m at {:.1} s",
        t_surface - leak_at_s,
        end_s - 0.1
    );
    assert!(t_surface - leak_at_s <= 0.5);
    assert!(t_fault - leak_at_s <= 1.0);
    assert!(z_end < z_leak - 1.0, "the vehicle did not rise");
}

#[test]
fn a_critical_battery_charge_on_the_emulated_board_surfaces_within_a_second() {
    // The leak test flies the same health wires on the board everywhere; this one in CI.
    if !crate::long_emulated::long_test(
        "emulated_instruments",
        "a_critical_battery_charge_on_the_emulated_board_surfaces_within_a_second",
        85,
    ) {
        return;
    }
    // The vehicle counts from a full battery at boot (as ArduPilot does): a 200 mAh pack,
    // critical at 195 mAh left, crossed after 5 mAh of a circle's draw (the hotel load and
    // the thrusters, about 1 A).
    let sc = circle(
        "[battery]\ncapacity_mah = 200.0\n\n[health]\nbatt_low_mah = 198.0\n\
         batt_crt_mah = 195.0\nbatt_fs_crt_act = 3\n",
        30.0,
    );
    let Some(out) = on_the_board(&sc) else {
        return;
    };
    // The host's truth replayed: the battery advanced with the pulses of each step, as the
    // host did before sending the next step's readings.
    let setup = sc.resolve().unwrap();
    let mut e = VehicleElectrics::new(
        setup.battery,
        setup.health.events().unwrap(),
        setup.health.params(&setup.battery).unwrap(),
        PwmMap::for_vehicle(setup.vehicle()),
        f64::from(setup.vehicle_params.thrust_max_forward_n),
    );
    let mut t_truth = None;
    for r in &out.telemetry {
        e.advance(us(r.t_s), r.pulse_us.map(f32::from));
        if t_truth.is_none() && e.battery().left_mah() < 195.0 {
            t_truth = Some(r.t_s);
        }
    }
    let t_truth = t_truth.expect("the charge never crossed 195 mAh");
    let t_surface =
        first_row(&out, 0.0, |r| r.telemetry.mode == Mode::Surface).expect("SURFACE never entered");
    let t_fault = first_row(&out, 0.0, |r| {
        r.telemetry.faults & fault::BATTERY_CRITICAL != 0
    })
    .unwrap();
    println!(
        "true crossing of 195 mAh at {t_truth:.2} s: SURFACE at {t_surface:.2} s ({:+.2} s), \
         BATTERY_CRITICAL at {t_fault:.2} s",
        t_surface - t_truth
    );
    assert!((-0.1..=1.0).contains(&(t_surface - t_truth)));
}

#[test]
fn nav_circle_with_the_dvl_on_its_uart_on_the_emulated_board_matches_software() {
    if !crate::long_emulated::long_test_all(
        "emulated_instruments",
        "nav_circle_with_the_dvl_on_its_uart_on_the_emulated_board_matches_software",
        780,
    ) {
        return;
    }
    let sc = Scenario::load("nav-circle-3d").unwrap();
    let Some(h) = on_the_board(&sc) else {
        return;
    };
    let sw = run(&sc.resolve().unwrap(), &RunOptions::default()).unwrap();
    let (hs, ss) = (&h.run.summary, &sw.summary);
    let health = h
        .report
        .nav_health
        .expect("the board's navigation counters");
    // The simulated DVL's reports: 5 Hz over the run.
    let dvl_reports = (hs.simulated_s * 5.0).floor() as u32;
    println!(
        "tracking RMS (last 80 %) {:.4} m on the board, {:.4} m in software; estimation RMS \
         {:.4} m / {:.4} m; DVL fused {} of {} reports",
        hs.rms_position_error_last80_m,
        ss.rms_position_error_last80_m,
        hs.rms_estimation_error_m,
        ss.rms_estimation_error_m,
        health.dvl_fused,
        dvl_reports
    );
    assert!(h.report.onboard_estimator);
    assert!(!hs.nan_detected && !hs.diverged);
    let within = |a: f64, b: f64| a <= 1.1 * b + 0.01;
    assert!(within(
        hs.rms_position_error_last80_m,
        ss.rms_position_error_last80_m
    ));
    assert!(within(hs.rms_estimation_error_m, ss.rms_estimation_error_m));
    // The DVL's reports reach the estimator from the board's own port.
    assert!(health.dvl_fused * 100 >= dvl_reports * 95);
}
