//! The health actions in the state machine: SURFACE's thrust, the health parameters' armed
//! rule, the depth limit's refusals and cap.

use super::*;
use crate::health::{FailsafeAction, HealthParams, HealthSample};
use controller_core::controller::Gains;
use controller_core::params::Vehicle;

const T0: u64 = 1_000_000;

fn nav_at(depth_m: f32, w_m_s: f32) -> Command {
    Command::Nav(NavSample {
        t_us: T0,
        state: NavState {
            z_m: depth_m,
            w_m_s,
            ..NavState::default()
        },
    })
}

/// Armed in `mode` at `depth_m` with a fresh heartbeat and navigation.
fn armed(mode: Mode, depth_m: f32, params: HealthParams) -> Autopilot {
    let c = Controller::new(Vehicle::observer(), Gains::default()).unwrap();
    let mut a = Autopilot::new(c, Failsafe::DEFAULT);
    a.handle(T0, 1, &Command::SetHealth(params)).unwrap();
    a.handle(T0, 2, &Command::Heartbeat { t_us: T0 }).unwrap();
    a.handle(T0, 3, &nav_at(depth_m, 0.0)).unwrap();
    a.handle(T0, 4, &Command::SetMode(mode)).unwrap();
    a.handle(T0, 5, &Command::Arm).unwrap();
    a
}

#[test]
fn surface_thrusts_up_only_and_holds_or_disarms_at_the_top() {
    let mut a = armed(Mode::Surface, 5.0, HealthParams::DEFAULT);
    let out = a.step(T0);
    let [f1, f2, f3] = out.allocation.thrust_n;
    assert_eq!((f1, f2), (0.0, 0.0));
    // 60 % of the 15 N upward (reverse) thrust.
    assert!((f3 + 9.0).abs() < 0.05, "{f3}");
    // At 0.3 m with SURFACE_END = disarm: disarmed.
    let params = HealthParams {
        surface_end: crate::health::SurfaceEnd::Disarm,
        ..HealthParams::DEFAULT
    };
    let mut a = armed(Mode::Surface, 0.25, params);
    a.step(T0);
    assert!(!a.armed());
}

#[test]
fn a_leak_switches_an_armed_vehicle_to_surface_once() {
    let mut a = armed(Mode::Hold, 5.0, HealthParams::DEFAULT);
    let wet = HealthSample {
        leak_wet: true,
        ..HealthSample::default()
    };
    a.health_check(T0, &wet);
    assert_eq!(a.mode(), Mode::Hold);
    a.health_check(T0 + 200_000, &wet);
    assert_eq!(a.mode(), Mode::Surface);
    // The pilot takes over; the leak that holds does not act again.
    a.handle(T0 + 200_000, 9, &Command::SetMode(Mode::Manual))
        .unwrap();
    a.health_check(T0 + 220_000, &wet);
    assert_eq!(a.mode(), Mode::Manual);
    assert_ne!(a.step(T0 + 220_000).faults & fault::LEAK, 0);
}

#[test]
fn armed_only_a_tighter_depth_limit_is_taken() {
    let p = HealthParams {
        depth_limit_m: 20.0,
        ..HealthParams::DEFAULT
    };
    let mut a = armed(Mode::Hold, 5.0, p);
    let with = |depth_limit_m| HealthParams { depth_limit_m, ..p };
    let relaxed = HealthParams {
        batt_crt_volt: 0.0,
        fs_leak_enable: FailsafeAction::None,
        ..p
    };
    assert_eq!(
        a.handle(T0, 10, &Command::SetHealth(relaxed)),
        Err(NackReason::Armed)
    );
    assert_eq!(
        a.handle(T0, 11, &Command::SetHealth(with(30.0))),
        Err(NackReason::Armed)
    );
    assert_eq!(
        a.handle(T0, 12, &Command::SetHealth(with(0.0))),
        Err(NackReason::Armed)
    );
    assert_eq!(a.handle(T0, 13, &Command::SetHealth(with(10.0))), Ok(()));
    assert_eq!(a.health_params().depth_limit_m, 10.0);
}

#[test]
fn deeper_targets_are_refused_and_the_pilot_is_capped_at_the_limit() {
    let p = HealthParams {
        depth_limit_m: 10.0,
        ..HealthParams::DEFAULT
    };
    let mut a = armed(Mode::Manual, 10.0, p);
    let deep = Reference::Hold {
        pos_m: [0.0, 0.0, 12.0],
    };
    let set = |reference| Command::SetReference {
        reference,
        start_us: None,
    };
    assert_eq!(a.handle(T0, 20, &set(deep)), Err(NackReason::DepthLimit));
    let item = |z| Command::MissionItem {
        index: 0,
        count: 1,
        pos_m: [1.0, 0.0, z],
        speed_m_s: 0.5,
    };
    assert_eq!(a.handle(T0, 21, &item(12.0)), Err(NackReason::DepthLimit));
    assert_eq!(a.handle(T0, 22, &item(10.0)), Ok(()));
    // Full down at the limit, at rest: no downward thrust; full surge stays.
    let full = ManualThrust {
        surge: 0.0,
        yaw: 0.0,
        heave: 0.0,
    };
    a.handle(T0, 23, &Command::ManualThrust(full)).unwrap();
    let down = ManualThrust {
        surge: 1.0,
        yaw: 0.0,
        heave: 1.0,
    };
    a.handle(T0, 24, &Command::ManualThrust(down)).unwrap();
    let out = a.step(T0);
    let [f1, f2, f3] = out.allocation.thrust_n;
    assert!(f3 <= 0.0, "{f3}");
    assert!(f1 > 15.0 && f2 > 15.0, "{f1} {f2}");
    // Shallower, the same command gives full down thrust.
    a.handle(T0, 25, &nav_at(5.0, 0.0)).unwrap();
    let out = a.step(T0);
    assert!(
        out.allocation.thrust_n[2] > 19.0,
        "{:?}",
        out.allocation.thrust_n
    );
}
