//! The topside image's loop pass (`loop.topside_3d`): the surface board's loop
//! (`topside_board.rs`, `harness::topside_pass`) with the same App as `loop.onboard_3d`, its
//! sensors and thrusters the node link (`LinkSensors`, `LinkThruster`, `TopsideLink`).
//!
//! Each timed iteration is one link period (20 ms): the node's uplink arrives (encoded
//! untimed; decoded, checked and turned into an IMU sample and a pressure in the timed
//! pass), the PC's frames of that period are decoded and handled (the same schedule as
//! `loop.onboard_3d`: a heartbeat and a compass heading at 10 Hz, a DVL velocity at 5 Hz, a
//! USBL fix at 1 Hz, 0.3 s late; and the node's DVL velocity in the uplink at 5 Hz, on other
//! passes than the tether's: more fixes than a vehicle gets, whose DVL is on one side), the
//! uplink runs the control step (`App::step_now`: the
//! estimator's prediction and the fixes, the 3-D tracking law, the allocation), the
//! downlink is encoded, and `Telemetry` goes out at 10 Hz. Built only with the `topside`
//! feature, so that the default image (the other figures) is unchanged.

use crate::bench::{Bench, Platform, CALLS};
use crate::loop_bench::{frame, open_session, FakeSerial};
use crate::onboard_bench::surface_frames;
use controller_core::controller::{Controller, Gains};
use controller_core::nav::onboard::{OnboardConfig, PressureDepth};
use controller_core::nav::GRAVITY_M_S2;
use controller_core::params::Vehicle;
use controller_core::state::NavState;
use core::cell::Cell;
use firmware::node_link::{seal, status, NodeCounters, Uplink, UplinkDvl, LINK_PERIOD_US};
use firmware::protocol::{fault, Board, Command, Mode, MAX_FRAME_LEN};
use firmware::topside_link::{LinkSensors, LinkThruster, NodeBridge, TopsideConfig, TopsideLink};
use firmware::{App, Config, Monotonic, Timing};

/// The session of the node link in the bench.
const SESSION: u32 = 0x2570_BE4C;

/// Simulated microseconds for the firmware, the platform's counter for its loop figures.
struct SimClock<'a, P: Platform> {
    p: &'a P,
    now_us: &'a Cell<u64>,
}

impl<P: Platform> Monotonic for SimClock<'_, P> {
    fn now_us(&mut self) -> u64 {
        self.now_us.get()
    }
    fn ticks(&mut self) -> u32 {
        self.p.now()
    }
}

struct Topside<'a, P: Platform> {
    app: App<LinkThruster<'a>, FakeSerial, SimClock<'a, P>, LinkSensors<'a>>,
    link: TopsideLink<'a, FakeSerial>,
    steps: u32,
}

/// Run `loop.topside_3d`.
pub fn run_topside<P: Platform>(b: &Bench<'_, P>, p: &P) {
    let now_us = Cell::new(0u64);
    let Ok(controller) = Controller::new(Vehicle::observer(), Gains::default()) else {
        return;
    };
    let config = Config {
        timing: Timing::FixedRate {
            control_period_us: 25_000,
            telemetry_period_us: 100_000,
        },
        ..Config::fixed_rate(Board::Host)
    };
    let bridge = NodeBridge::new(config.pwm_period_us());
    let Ok(app) = App::with_sensors(
        bridge.thrusters(),
        FakeSerial::new(),
        SimClock { p, now_us: &now_us },
        controller,
        config,
        bridge.sensors(),
    ) else {
        return;
    };
    let link = TopsideLink::new(&bridge, FakeSerial::new(), TopsideConfig::new(SESSION));
    let mut t = Topside {
        app,
        link,
        steps: 0,
    };
    // The launch point at the depth of the node's pressure.
    let pressure_pa = 399_980.0;
    let z0 = PressureDepth::SEA_WATER.depth_m(pressure_pa);
    let initial = NavState {
        z_m: z0,
        ..NavState::default()
    };
    let mut seq = 0u16;
    let mut buf = [0u8; MAX_FRAME_LEN];
    open_session(&mut t.app);
    for cmd in [
        Command::Heartbeat { t_us: 0 },
        Command::StartNav {
            t_us: 0,
            initial,
            config: OnboardConfig::default(),
        },
        Command::SetMode(Mode::Hold),
        Command::Arm,
    ] {
        seq = seq.wrapping_add(1);
        t.app.parts_mut().1.append(frame(seq, &cmd, &mut buf));
        t.app.tick();
    }
    let mut up_seq = 0u16;
    let (mut disarmed, mut lost, mut no_law) = (0u32, 0u32, 0u32);
    b.run_state(
        "loop.topside_3d",
        CALLS,
        &mut t,
        |t, i| {
            let t_us = u64::from(i + 1) * u64::from(LINK_PERIOD_US);
            now_us.set(t_us);
            t.link.serial_mut().clear_tx();
            // The node's uplink of the period: level, at rest, a small rate that changes.
            let dt = LINK_PERIOD_US as f32 * 1e-6;
            let w = 0.001 * (i % 7) as f32 - 0.003;
            let up = Uplink {
                session: SESSION,
                echo_seq: 0,
                echo_t_us: 0,
                imu_age_us: 0,
                dt_us: LINK_PERIOD_US,
                samples: 8,
                delta_angle_rad: [w * dt, -w * dt, 2.0 * w * dt],
                delta_velocity_m_s: [0.0, 0.0, -GRAVITY_M_S2 * dt],
                pressure_pa,
                pressure_count: (i / 5) as u8,
                status: status::ARMED,
                counters: NodeCounters::default(),
                // At rest: a few mm/s, 60 ms old.
                dvl: (i % 10 == 7).then_some(UplinkDvl {
                    age_ms: 60,
                    velocity_mm_s: [(i % 7) as i16 - 3, 2 - (i % 5) as i16],
                    std_mm_s: 10,
                }),
            };
            up_seq = up_seq.wrapping_add(1);
            let mut out = [0u8; MAX_FRAME_LEN];
            if let Ok(f) = seal(up_seq, &up, &mut out) {
                t.link.serial_mut().append(f);
            }
            let serial = t.app.parts_mut().1;
            serial.clear_tx();
            surface_frames(serial, &mut seq, i, t_us, true);
        },
        // The board's loop pass (`topside_board.rs`).
        |t| {
            t.app.tick();
            let now = t.app.now_us();
            let armed = t.app.autopilot().armed();
            if t.link.poll(now, armed) {
                t.app.step_now();
                t.steps += 1;
            }
            t.link.send_if_due(now, armed);
        },
        |t| {
            let out = t.app.last_output();
            if out.faults & fault::SENSOR_LOST != 0 {
                lost += 1;
            }
            if !out.law_ran {
                no_law += 1;
            }
            if !t.app.autopilot().armed() {
                disarmed += 1;
            }
        },
    );
    let health = t
        .app
        .autopilot()
        .onboard_nav()
        .map(|o| o.estimator().health())
        .unwrap_or_default();
    let c = t.link.counters();
    p.print(format_args!(
        "TOPSIDE loop.topside_3d: {} uplink steps of {CALLS}, {} IMU samples, {} depths, {} \
         headings, {} DVL, {} USBL fused; uplinks refused {}; sensor-lost passes {lost}, \
         disarmed {disarmed}, without the law {no_law}",
        t.steps,
        health.imu_samples,
        health.depth_fused,
        health.heading_fused,
        health.dvl_fused,
        health.position_fused,
        c.corrupt
            .wrapping_add(c.replayed)
            .wrapping_add(c.foreign)
            .wrapping_add(c.bad_data),
    ));
    if lost + disarmed + no_law > 0 || t.steps != CALLS {
        p.print(format_args!(
            "WARN loop.topside_3d: steps {}, sensor-lost {lost}, disarmed {disarmed}, no law {no_law}",
            t.steps
        ));
    }
}
