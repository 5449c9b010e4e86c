//! The DVL through its wire format: the simulated DVL's fixes reach the in-process
//! firmware as Water Linked A50 `wrz` reports on its DVL port (`firmware::sensors::dvl`),
//! instead of `DvlFix` commands over the tether; the navigation runs fly the same.

use crate::long_emulated;

use host_sim::commands::hil::{run_hil, HilOptions, HilOutput, HilTarget};
use sim_scenario::Scenario;
use std::time::Duration;

fn fly(name: &str, dvl_on_uart: bool) -> HilOutput {
    let sc = Scenario::load(name).unwrap();
    let mut o = HilOptions::new(HilTarget::InProcess);
    o.wall_limit = Duration::from_secs(900);
    o.record = false;
    o.dvl_on_uart = dvl_on_uart;
    run_hil(&sc.resolve().unwrap(), &o, None).expect("in-process run")
}

/// Tracking and estimation RMS with the DVL on its UART within 10 % + 1 cm of the same run
/// with the DVL's fixes as tether commands; every report admitted and fused.
fn same_figures_through_the_wire(name: &str) {
    let tether = fly(name, false);
    let wire = fly(name, true);
    let (t, w) = (&tether.run.summary, &wire.run.summary);
    let (th, wh) = (
        tether.report.nav_health.unwrap(),
        wire.report.nav_health.unwrap(),
    );
    eprintln!(
        "{name}: DVL as tether commands: tracking RMS {:.4} m, estimation RMS {:.4} m, {} DVL fused; \
         DVL as A50 wrz on its UART: {:.4} m, {:.4} m, {} DVL fused; nacks {} / {}",
        t.rms_position_error_m,
        t.rms_estimation_error_m,
        th.dvl_fused,
        w.rms_position_error_m,
        w.rms_estimation_error_m,
        wh.dvl_fused,
        tether.report.firmware_nacks,
        wire.report.firmware_nacks,
    );
    assert!(wire.report.onboard_estimator);
    assert_eq!(wire.report.steps_failsafe, 0);
    // The fixes went through the port: as many fused as over the tether (the rate is the
    // sensor's), none lost on the way.
    assert!(wh.dvl_fused > 0);
    assert!(
        wh.dvl_fused.abs_diff(th.dvl_fused) <= th.dvl_fused / 100,
        "{} vs {}",
        wh.dvl_fused,
        th.dvl_fused
    );
    for (what, a, b) in [
        (
            "tracking RMS",
            w.rms_position_error_m,
            t.rms_position_error_m,
        ),
        (
            "estimation RMS",
            w.rms_estimation_error_m,
            t.rms_estimation_error_m,
        ),
    ] {
        assert!(
            (a - b).abs() <= 0.10 * b + 0.01,
            "{name} {what}: wire {a} vs tether {b}"
        );
    }
}

#[test]
fn nav_circle_3d_with_the_dvl_on_its_uart() {
    same_figures_through_the_wire("nav-circle-3d");
}

#[test]
fn nav_lawnmower_3d_with_the_dvl_on_its_uart() {
    if !long_emulated::long_test(
        "instruments",
        "nav_lawnmower_3d_with_the_dvl_on_its_uart",
        65,
    ) {
        return;
    }
    same_figures_through_the_wire("nav-lawnmower-3d");
}

/// The simulated DVL's line: a fix sent as `wrz` comes out of the firmware's DVL port as the
/// same fix (velocity to the report's 1 mm/s, the same time of validity and deviation).
#[test]
fn the_simulated_dvl_line_carries_the_fix() {
    use controller_core::nav::DvlFix;
    use firmware::sensors::dvl::{a50, DvlPort};
    use sim_world::sensors::DvlWire;

    let mut wire = DvlWire::default();
    let mut port = DvlPort::new(wire.clone(), a50::VelocityGate::default(), 0);
    for (k, v) in [[0.25_f32, -0.1234], [-1.5, 0.0], [0.0004, 2.9996]]
        .into_iter()
        .enumerate()
    {
        let fix = DvlFix {
            t_us: 1_000_000 + 200_000 * k as u64,
            velocity_m_s: v,
            std_m_s: 0.01,
        };
        wire.send_wrz(&fix);
        let got = port.poll(fix.t_us).expect("admitted");
        assert_eq!(got.t_us, fix.t_us);
        assert_eq!(got.std_m_s, 0.01);
        for i in 0..2 {
            assert!(
                (got.velocity_m_s[i] - v[i]).abs() <= 0.0005 + 1e-6,
                "{got:?} {v:?}"
            );
        }
        assert_eq!(wire.pending(), 0);
    }
    let s = port.stats();
    assert_eq!((s.accepted, s.refused()), (3, 0));
}
