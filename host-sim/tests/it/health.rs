//! The vehicle's health failsafes flown in closed loop: the firmware library in process
//! (its health inputs on the simulated power-sense module, leak probe and enclosure sensor
//! of `world::battery`), the 6-DOF plant with the surface at `z = 0`, lock-step at 50 Hz,
//! the vehicle's navigation the plant's truth over the tether, and the surface's side of the
//! tether (the protocol's `Client`) sending what a pilot or a ground station would.
//!
//! - leak: SURFACE starts <= 0.5 s after the probe reads wet; reported within 1 s;
//! - battery critical (volts, and mAh): SURFACE within 1 s of the simulated truth crossing
//!   the threshold;
//! - enclosure pressure: a warning (no action) 2 s after the limit;
//! - the depth limit, commanded 2 m below in MANUAL, DEPTH HOLD, position HOLD, GUIDED
//!   (`Track` on a descending helix) and AUTO: the true depth never more than 0.2 m below;
//! - the remaining time on a constant survey within 10 % of the battery model's truth.

// Test code: a failed expectation should stop the test.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use controller_core::alloc::PwmMap;
use controller_core::params::{Vehicle, VehicleParams};
use controller_core::reference::Reference;
use firmware::protocol::Board;
use firmware::protocol::{
    fault, Client, Command, Event, Law, ManualThrust, Mode, NackReason, NavSample, Plane, Reply,
    Status, Telemetry,
};
use firmware::Config;
use host_sim::closed_loop::navigation::to_nav;
use host_sim::tether::in_process::InProcessFirmware;
use sim_scenario::health::{HealthSpec, SurfaceEndSpec};
use sim_world::battery::BatterySpec;
use sim_world::plant::six_dof::SixDof;
use sim_world::plant::{Environment, Plant, PlantState};

/// Control period of the lock-step loop, s.
const DT_S: f64 = 0.02;
/// Plant substeps per control period.
const SUBSTEPS: usize = 20;

/// The vehicle, its plant and the surface's end of the tether.
struct Rig {
    fw: InProcessFirmware,
    plant: Box<dyn Plant>,
    pwm: PwmMap,
    client: Client,
    k: u64,
    sticks: Option<ManualThrust>,
    tel: Telemetry,
    status: Option<Status>,
    nacks: Vec<(u16, NackReason)>,
    sessions: u32,
}

impl Rig {
    fn new(battery: BatterySpec, health: HealthSpec, depth_m: f64) -> Self {
        let fw = InProcessFirmware::with_health(Config::lockstep(Board::Host), &battery, &health)
            .unwrap();
        let vehicle = Vehicle::observer();
        let initial = PlantState {
            eta: [0.0, 0.0, depth_m, 0.0, 0.0, 0.0],
            nu: [0.0; 6],
        };
        let mut plant = Box::new(SixDof::new(
            &VehicleParams::default(),
            Environment::default(),
            true,
            initial,
        ));
        plant.set_bounds(true, None);
        let mut rig = Self {
            fw,
            plant,
            pwm: PwmMap::for_vehicle(&vehicle),
            client: Client::default(),
            k: 0,
            sticks: None,
            tel: Telemetry::default(),
            status: None,
            nacks: Vec::new(),
            sessions: 0,
        };
        let f = rig.client.open(0x5EED, 0).unwrap();
        let bytes = f.bytes().to_vec();
        rig.exchange(&bytes);
        assert_ne!(rig.client.session(), 0);
        rig
    }

    fn t_us(&self) -> u64 {
        self.k * 20_000
    }

    fn t_s(&self) -> f64 {
        self.k as f64 * DT_S
    }

    fn depth_m(&self) -> f64 {
        self.plant.state().eta[2]
    }

    fn exchange(&mut self, bytes: &[u8]) -> Vec<Reply> {
        let out = self.fw.pass(bytes);
        let mut rest = out.as_slice();
        let mut replies = Vec::new();
        while let Some(e) = self.client.receive(&mut rest) {
            if let Event::Reply { reply, .. } = e {
                match reply {
                    Reply::Telemetry(t) => self.tel = t,
                    Reply::Status(s) => self.status = Some(s),
                    Reply::Nack { seq, reason } => self.nacks.push((seq, reason)),
                    _ => {}
                }
                replies.push(reply);
            }
        }
        replies
    }

    /// Send `cmd` now; its `Nack` reason, if refused.
    fn send(&mut self, cmd: &Command) -> Option<NackReason> {
        if self.client.needs_session() {
            // A session's sequence numbers run out after 65,535 frames: a new session.
            self.sessions += 1;
            let f = self
                .client
                .open(0x5EED + self.sessions, self.t_us())
                .unwrap();
            let bytes = f.bytes().to_vec();
            self.exchange(&bytes);
        }
        let sent = self
            .client
            .send(cmd, self.t_us())
            .unwrap_or_else(|e| panic!("{cmd:?} at {:.2} s: {e:?}", self.t_s()));
        let bytes = sent.frame.bytes().to_vec();
        let replies = self.exchange(&bytes);
        replies.iter().find_map(|r| match r {
            Reply::Nack { seq, reason } if *seq == sent.seq => Some(*reason),
            _ => None,
        })
    }

    /// One control period: heartbeat, sticks, `Nav` (the truth), the step's pulses on the
    /// plant for 20 ms.
    fn step(&mut self) {
        let t_us = self.t_us();
        self.send(&Command::Heartbeat { t_us });
        if let Some(m) = self.sticks {
            self.send(&Command::ManualThrust(m));
        }
        let state = to_nav(&self.plant.state());
        self.send(&Command::Nav(NavSample { t_us, state }));
        let thrust = self
            .tel
            .pulse_us
            .map(|p| f64::from(self.pwm.thrust_n(f32::from(p))));
        for _ in 0..SUBSTEPS {
            self.plant.step(thrust, DT_S / SUBSTEPS as f64);
        }
        self.k += 1;
    }

    /// Heartbeat and `Nav` at the start, the mode, arm.
    fn arm_in(&mut self, mode: Mode) {
        self.step();
        if matches!(mode, Mode::Manual | Mode::Stabilize | Mode::DepthHold) {
            self.sticks = Some(ManualThrust::default());
        }
        assert_eq!(self.send(&Command::SetMode(mode)), None);
        self.step();
        assert_eq!(self.send(&Command::Arm), None);
        self.step();
        assert!(self.tel.armed);
    }

    fn run_until(&mut self, t_s: f64, mut each: impl FnMut(&Self)) {
        while self.t_s() < t_s {
            self.step();
            each(self);
        }
    }
}

fn health() -> HealthSpec {
    HealthSpec::default()
}

/// Times of the first step from `after_s` at which `f` holds.
fn first(rows: &[(f64, bool)], after_s: f64) -> Option<f64> {
    rows.iter()
        .find(|(t, v)| *t >= after_s && *v)
        .map(|(t, _)| *t)
}

#[test]
fn a_leak_surfaces_the_vehicle_within_half_a_second_and_it_holds_at_the_top() {
    let leak_at_s = 10.0;
    let spec = HealthSpec {
        leak_at_s: Some(leak_at_s),
        ..health()
    };
    let mut rig = Rig::new(BatterySpec::default(), spec, 6.0);
    rig.arm_in(Mode::Hold);
    let mut surface = Vec::new();
    let mut reported = Vec::new();
    rig.run_until(60.0, |r| {
        surface.push((r.t_s(), r.tel.mode == Mode::Surface));
        let st = r.status.map_or(0, |s| s.faults);
        reported.push((r.t_s(), st & fault::LEAK != 0));
    });
    // The step at t answers the Nav of t: the probe is wet from the pass after 10 s.
    let t_surface = first(&surface, 0.0).expect("SURFACE never entered");
    let delay = t_surface - leak_at_s;
    println!("leak at {leak_at_s} s: SURFACE at {t_surface:.2} s ({delay:.2} s)");
    assert!((0.0..=0.5).contains(&delay), "{delay}");
    let t_rep = first(&reported, 0.0).unwrap();
    assert!(t_rep - leak_at_s <= 1.0, "{}", t_rep - leak_at_s);
    // Up from 6 m to the 0.3 m arrival depth, then held there (armed).
    let d = rig.depth_m();
    println!("depth at 60 s: {d:.3} m");
    assert!(rig.tel.armed);
    assert!((0.1..=0.5).contains(&d), "{d}");
    // Arming again is refused while the leak holds.
    rig.send(&Command::Disarm);
    rig.step();
    assert_eq!(rig.send(&Command::Arm), Some(NackReason::Health));
}

#[test]
fn surface_end_disarm_disarms_at_the_top() {
    let spec = HealthSpec {
        leak_at_s: Some(2.0),
        surface_end: SurfaceEndSpec::Disarm,
        ..health()
    };
    let mut rig = Rig::new(BatterySpec::default(), spec, 3.0);
    rig.arm_in(Mode::Hold);
    let mut disarmed_at = None;
    rig.run_until(40.0, |r| {
        if !r.tel.armed && disarmed_at.is_none() {
            disarmed_at = Some((r.t_s(), r.depth_m()));
        }
    });
    let (t, d) = disarmed_at.expect("never disarmed");
    println!("disarmed at {t:.2} s, {d:.3} m");
    assert!(d <= 0.35, "{d}");
}

/// A battery at 25 %: 14.1 V at rest, under 14.0 V with the thrusters' sag.
fn low_battery() -> BatterySpec {
    BatterySpec {
        capacity_mah: 2_000.0,
        initial_pct: 25.0,
        ..BatterySpec::default()
    }
}

#[test]
fn a_critical_battery_voltage_surfaces_within_a_second_of_the_true_crossing() {
    let spec = HealthSpec {
        batt_low_volt: 14.5,
        batt_crt_volt: 14.0,
        ..health()
    };
    let mut rig = Rig::new(low_battery(), spec, 8.0);
    rig.arm_in(Mode::Manual);
    // Gentle yaw, then full surge and down from 5 s: the sag crosses 14.0 V.
    rig.run_until(5.0, |_| {});
    rig.sticks = Some(ManualThrust {
        surge: 0.0,
        yaw: 0.0,
        heave: 0.0,
    });
    rig.step();
    rig.sticks = Some(ManualThrust {
        surge: 1.0,
        yaw: 0.0,
        heave: 1.0,
    });
    let mut truth = Vec::new();
    let mut surface = Vec::new();
    let mut reported = Vec::new();
    rig.run_until(20.0, |r| {
        let v = r.fw.electrics().battery().voltage_v();
        truth.push((r.t_s(), v < 14.0));
        surface.push((r.t_s(), r.tel.mode == Mode::Surface));
        let st = r.status.map_or(0, |s| s.faults);
        reported.push((r.t_s(), st & fault::BATTERY_CRITICAL != 0));
    });
    let t_truth = first(&truth, 0.0).expect("the voltage never crossed 14.0 V");
    let t_surface = first(&surface, 0.0).expect("SURFACE never entered");
    let t_rep = first(&reported, 0.0).unwrap();
    let st = rig.status.unwrap();
    println!(
        "true crossing {t_truth:.2} s, SURFACE {t_surface:.2} s ({:.2} s), reported {:.2} s; {:.2} V {:.1} A",
        t_surface - t_truth,
        t_rep - t_truth,
        st.battery.voltage_v,
        st.battery.current_a
    );
    assert!((0.0..=1.0).contains(&(t_surface - t_truth)));
    assert!(t_rep - t_truth <= 1.0);
}

#[test]
fn a_critical_battery_charge_surfaces_within_a_second_of_the_true_crossing() {
    // The vehicle counts from a full battery at boot (as ArduPilot does).
    let battery = BatterySpec {
        capacity_mah: 200.0,
        ..BatterySpec::default()
    };
    let spec = HealthSpec {
        batt_low_mah: 150.0,
        batt_crt_mah: 100.0,
        ..health()
    };
    let mut rig = Rig::new(battery, spec, 8.0);
    rig.arm_in(Mode::Manual);
    rig.step();
    rig.sticks = Some(ManualThrust {
        surge: 1.0,
        yaw: 0.0,
        heave: -0.2,
    });
    let mut truth = Vec::new();
    let mut surface = Vec::new();
    rig.run_until(120.0, |r| {
        truth.push((r.t_s(), r.fw.electrics().battery().left_mah() < 100.0));
        surface.push((r.t_s(), r.tel.mode == Mode::Surface));
    });
    let t_truth = first(&truth, 0.0).expect("the charge never went under 100 mAh");
    let t_surface = first(&surface, 0.0).expect("SURFACE never entered");
    println!(
        "true crossing {t_truth:.2} s, SURFACE {t_surface:.2} s ({:.2} s)",
        t_surface - t_truth
    );
    assert!((t_surface - t_truth).abs() <= 1.0);
}

#[test]
fn an_enclosure_pressure_rise_warns_and_changes_nothing() {
    // 101,325 Pa rising 1 kPa/s from 5 s: over 105 kPa at 8.7 s, the warning 2 s later.
    let spec = HealthSpec {
        enclosure_pressure_rise_at_s: Some(5.0),
        enclosure_pressure_rise_pa_s: 1_000.0,
        ..health()
    };
    let mut rig = Rig::new(BatterySpec::default(), spec, 4.0);
    rig.arm_in(Mode::Hold);
    let mut reported = Vec::new();
    rig.run_until(20.0, |r| {
        let st = r.status.map_or(0, |s| s.faults);
        reported.push((r.t_s(), st & fault::ENCLOSURE != 0));
    });
    let t_over = 5.0 + (105_000.0 - 101_325.0) / 1_000.0;
    let t_rep = first(&reported, 0.0).expect("no enclosure warning");
    println!("over at {t_over:.2} s, reported {t_rep:.2} s");
    assert!(
        (2.0..=3.0).contains(&(t_rep - t_over)),
        "{}",
        t_rep - t_over
    );
    assert_eq!(rig.tel.mode, Mode::Hold);
    assert!(rig.tel.armed);
}

/// The depth limit of the depth-limit tests, m.
const LIMIT_M: f32 = 10.0;

fn limited() -> HealthSpec {
    HealthSpec {
        depth_limit_m: LIMIT_M,
        ..health()
    }
}

/// Deepest true depth over the run, m.
fn deepest(rig: &mut Rig, until_s: f64) -> f64 {
    let mut max = rig.depth_m();
    rig.run_until(until_s, |r| max = max.max(r.depth_m()));
    max
}

#[test]
fn the_depth_limit_holds_the_pilot_in_manual_and_depth_hold() {
    for mode in [Mode::Manual, Mode::DepthHold] {
        let mut rig = Rig::new(BatterySpec::default(), limited(), 6.0);
        rig.arm_in(mode);
        rig.step();
        // Full down: 2 m below the limit and beyond, as far as the pilot asks.
        rig.sticks = Some(ManualThrust {
            surge: 0.3,
            yaw: 0.0,
            heave: 1.0,
        });
        let max = deepest(&mut rig, 60.0);
        let warned = rig.status.unwrap().faults & fault::DEPTH_LIMIT != 0;
        println!("{mode:?}: deepest {max:.3} m (limit {LIMIT_M} m), warning {warned}");
        assert!(max <= f64::from(LIMIT_M) + 0.2, "{mode:?}: {max}");
        assert!(
            max >= f64::from(LIMIT_M) - 0.5,
            "{mode:?}: the cap stops short: {max}"
        );
        assert!(warned);
    }
}

#[test]
fn the_depth_limit_refuses_deeper_targets_and_holds_guided_hold_and_auto() {
    // GUIDED (a tracking reference): a point 2 m below is refused; a helix that starts
    // above and descends past it is flown, held at the limit.
    let mut rig = Rig::new(BatterySpec::default(), limited(), 6.0);
    let below = Reference::Hold {
        pos_m: [0.0, 0.0, LIMIT_M + 2.0],
    };
    let set = |reference| Command::SetReference {
        reference,
        start_us: None,
    };
    assert_eq!(rig.send(&set(below)), Some(NackReason::DepthLimit));
    let helix = Reference::Helix {
        center_m: [0.0, 3.0, 6.0],
        radius_m: 3.0,
        speed_m_s: 0.3,
        depth_rate_m_s: 0.2,
    };
    assert_eq!(rig.send(&set(helix)), None);
    rig.arm_in(Mode::Track {
        plane: Plane::ThreeD,
        law: Law::Tracking,
    });
    // 6 m + 0.2 m/s for 40 s: the helix asks for 14 m.
    let max = deepest(&mut rig, 40.0);
    println!("GUIDED helix to 14 m: deepest {max:.3} m");
    assert!(max <= f64::from(LIMIT_M) + 0.2, "{max}");

    // Position HOLD entered while descending at full thrust at 9.5 m.
    let mut rig = Rig::new(BatterySpec::default(), limited(), 6.0);
    rig.arm_in(Mode::Manual);
    rig.step();
    rig.sticks = Some(ManualThrust {
        surge: 0.0,
        yaw: 0.0,
        heave: 1.0,
    });
    while rig.depth_m() < 9.5 && rig.t_s() < 60.0 {
        rig.step();
    }
    rig.sticks = None;
    assert_eq!(rig.send(&Command::SetMode(Mode::Hold)), None);
    let until_s = rig.t_s() + 20.0;
    let max = deepest(&mut rig, until_s);
    println!("HOLD entered at 9.5 m descending: deepest {max:.3} m");
    assert!(max <= f64::from(LIMIT_M) + 0.2, "{max}");

    // AUTO: a waypoint 2 m below is refused; one at the limit is flown to it.
    let mut rig = Rig::new(BatterySpec::default(), limited(), 6.0);
    let item = |pos_m| Command::MissionItem {
        index: 0,
        count: 1,
        pos_m,
        speed_m_s: 0.5,
    };
    assert_eq!(
        rig.send(&item([10.0, 0.0, LIMIT_M + 2.0])),
        Some(NackReason::DepthLimit)
    );
    assert_eq!(rig.send(&item([10.0, 0.0, LIMIT_M])), None);
    rig.arm_in(Mode::Auto);
    let max = deepest(&mut rig, 60.0);
    println!("AUTO to a waypoint at the limit: deepest {max:.3} m");
    assert!(max <= f64::from(LIMIT_M) + 0.2, "{max}");
}

#[test]
fn the_remaining_time_on_a_constant_survey_is_within_ten_percent_of_the_truth() {
    // A 300 mAh battery on a circle at 0.5 m/s: empty in a few minutes.
    let battery = BatterySpec {
        capacity_mah: 300.0,
        ..BatterySpec::default()
    };
    let mut rig = Rig::new(battery, health(), 5.0);
    let circle = Reference::Circle {
        center_m: [0.0, 5.0, 5.0],
        radius_m: 5.0,
        speed_m_s: 0.5,
    };
    let set = Command::SetReference {
        reference: circle,
        start_us: None,
    };
    assert_eq!(rig.send(&set), None);
    rig.arm_in(Mode::Track {
        plane: Plane::ThreeD,
        law: Law::Tracking,
    });
    // (time, the vehicle's estimate) every 10 s; the truth is known at the end.
    let mut estimates = Vec::new();
    let mut t_empty = None;
    while rig.t_s() < 3_600.0 && t_empty.is_none() {
        rig.step();
        if rig.k.is_multiple_of(500) {
            let b = rig.status.unwrap().battery;
            estimates.push((rig.t_s(), b.time_remaining_s));
        }
        if rig.fw.electrics().battery().left_mah() <= 0.0 {
            t_empty = Some(rig.t_s());
        }
    }
    let t_empty = t_empty.expect("the battery did not run down within an hour");
    let mut worst: f64 = 0.0;
    for &(t, est) in &estimates {
        let truth = t_empty - t;
        // From 60 s (the current's filter settled) to 80 % of the run.
        if t < 60.0 || t > 0.8 * t_empty {
            continue;
        }
        let err = (f64::from(est) - truth) / truth;
        worst = worst.max(err.abs());
        println!(
            "t {t:.0} s: estimate {est:.1} s, truth {truth:.1} s ({:+.1} %)",
            100.0 * err
        );
    }
    println!(
        "empty at {t_empty:.1} s; worst error {:.1} %",
        100.0 * worst
    );
    assert!(worst <= 0.10, "{worst}");
}
