//! `host-sim topside --serial DEV` with the topside layout: the PC cannot
//! tell a topside MCU from an onboard vehicle, both speak the same tether protocol. Behind a
//! pseudo-terminal runs the topside layout's topside board as the firmware library: the same
//! `App` as every image, its thrusters and sensors the node link (`topside_link`), the
//! node (`firmware::node::Node`) at the far end of a 115,200 Bd wire model, and the
//! scenario's plant and simulated sensors feeding the node (the one closed loop); all on the
//! host's clock in a thread, as the boards run. The topside opens the terminal's other end
//! as it would a USB-serial adapter; a MAVLink ground station (the `mavlink` crate) talks to
//! the topside: the heartbeat, a parameter set on the topside board, and the node link's
//! state: healthy in `SYS_STATUS`; cut, lost in `SYS_STATUS` with a `STATUSTEXT`; joined
//! again, healthy with a `STATUSTEXT`.

use controller_core::alloc::PwmMap;
use controller_core::controller::{Controller, Gains};
use controller_core::nav::onboard::PressureDepth;
use controller_core::nav::ImuSample;
use controller_core::reference::RefSample;
use controller_core::state::NavState;
use firmware::node::{Node, NodeConfig};
use firmware::protocol::Board;
use firmware::topside_link::{LinkSensors, LinkThruster, NodeBridge, TopsideConfig, TopsideLink};
use firmware::{App, Config, Monotonic, Timing};
use host_sim::closed_loop::estimator_nav::{onboard_config, VehicleNav};
use host_sim::closed_loop::{ClosedLoop, ControllerEndpoint, RunOptions, StepReply};
use host_sim::tether::in_process::{SimPwm, SimSerial};
use host_sim::tether::topside_layout::{
    layout_scenario, FALLBACK_PERIOD_US, NODE_IMU_PERIOD_US, PASS_US,
};
use mavlink::dialects::ardupilotmega::{
    MavMessage, MavParamType, MavSysStatusSensor, MavType, PARAM_SET_DATA,
};
use mavlink::{MavConnection, MavHeader};
use serialport::{SerialPort, TTYPort};
use sim_scenario::deployment::Control;
use sim_scenario::Scenario;
use sim_world::sensors::Measurement;
use sim_world::tether_wire::Duplex;
use std::cell::{Cell, RefCell};
use std::collections::VecDeque;
use std::convert::Infallible;
use std::io::{Read, Write};
use std::path::PathBuf;
use std::rc::Rc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::gcs;
use gcs::wait;

/// Both MCUs' clock: the host's, since the thread started (us).
#[derive(Clone, Default)]
struct Clock(Rc<Cell<u64>>);

impl Monotonic for Clock {
    fn now_us(&mut self) -> u64 {
        self.0.get()
    }
}

/// One end of the node link: what the wire delivered, what the MCU wrote.
#[derive(Clone, Default)]
struct Port {
    rx: Rc<RefCell<VecDeque<u8>>>,
    tx: Rc<RefCell<Vec<u8>>>,
}

impl embedded_io::ErrorType for Port {
    type Error = Infallible;
}

impl embedded_io::Read for Port {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let mut q = self.rx.borrow_mut();
        let n = buf.len().min(q.len());
        for (b, x) in buf.iter_mut().zip(q.drain(..n)) {
            *b = x;
        }
        Ok(n)
    }
}

impl embedded_io::ReadReady for Port {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(!self.rx.borrow().is_empty())
    }
}

impl embedded_io::Write for Port {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        self.tx.borrow_mut().extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

impl embedded_io::WriteReady for Port {
    fn write_ready(&mut self) -> Result<bool, Infallible> {
        Ok(true)
    }
}

/// The node's IMU and pressure sensor: the plant's simulated readings, each from its time
/// stamp on.
#[derive(Clone, Default)]
struct NodeSensors {
    imu: Rc<RefCell<(VecDeque<ImuSample>, Option<ImuSample>)>>,
    pressure: Rc<RefCell<VecDeque<(u64, f32)>>>,
}

impl firmware::Sensors for NodeSensors {
    fn imu(&mut self, now_us: u64) -> Option<ImuSample> {
        let mut f = self.imu.borrow_mut();
        while f.0.front().is_some_and(|s| s.t_us <= now_us) {
            f.1 = f.0.pop_front();
        }
        f.1.map(|s| ImuSample { t_us: now_us, ..s })
    }
    fn pressure_pa(&mut self, now_us: u64) -> Option<f32> {
        let mut q = self.pressure.borrow_mut();
        let mut latest = None;
        while q.front().is_some_and(|&(t, _)| t <= now_us) {
            latest = q.pop_front().map(|(_, p)| p);
        }
        latest
    }
}

type TopsideApp = App<LinkThruster<'static>, SimSerial, Clock, LinkSensors<'static>>;

/// The topside board and its node, as the loop's controller: the PC's tether is the
/// pseudo-terminal.
struct Boards {
    clock: Rc<Cell<u64>>,
    app: TopsideApp,
    link: TopsideLink<'static, Port>,
    node: Node<SimPwm, Port, Clock, NodeSensors>,
    top_port: Port,
    node_port: Port,
    wire: Duplex,
    sensors: NodeSensors,
    pressure: PressureDepth,
    pwm: PwmMap,
    pty: TTYPort,
    cut: Arc<AtomicBool>,
    cut_done: bool,
    t_us: u64,
}

impl Boards {
    fn pass(&mut self, t_us: u64) {
        self.clock.set(t_us);
        let t_s = t_us as f64 * 1e-6;
        let mut bytes = Vec::new();
        self.wire.down.read_into(t_s, &mut bytes);
        self.node_port.rx.borrow_mut().extend(bytes.drain(..));
        self.wire.up.read_into(t_s, &mut bytes);
        self.top_port.rx.borrow_mut().extend(bytes.drain(..));
        // The node's loop.
        self.node.tick();
        let up: Vec<u8> = self.node_port.tx.borrow_mut().drain(..).collect();
        self.wire.up.write(t_s, &up);
        // The topside board's loop.
        self.app.tick();
        let armed = self.app.autopilot().armed();
        if self.link.poll(t_us, armed) {
            self.app.step_now();
        }
        self.link.send_if_due(t_us, armed);
        let down: Vec<u8> = self.top_port.tx.borrow_mut().drain(..).collect();
        self.wire.down.write(t_s, &down);
    }

    /// The PC's tether: the pseudo-terminal's bytes in, the App's out.
    fn tether(&mut self) {
        let mut buf = [0u8; 512];
        // Until the topside opens its end, reads and writes fail: bytes lost, as on a UART.
        // Read only what is there (a read waits for its timeout otherwise).
        let n = match self.pty.bytes_to_read() {
            Ok(waiting) if waiting > 0 => self.pty.read(&mut buf).unwrap_or(0),
            _ => 0,
        };
        self.app.parts_mut().1.rx.extend(buf[..n].iter().copied());
        let out: Vec<u8> = self.app.parts_mut().1.tx.drain(..).collect();
        if !out.is_empty() {
            let _ = self.pty.write_all(&out);
        }
    }
}

impl ControllerEndpoint for Boards {
    fn step(
        &mut self,
        t_s: f64,
        _nav: &NavState,
        _reference: &RefSample,
    ) -> anyhow::Result<StepReply> {
        // The test cuts the node link and joins it again.
        let cut = self.cut.load(Ordering::Relaxed);
        if cut != self.cut_done {
            self.wire.set_cut(cut.then_some(t_s));
            self.cut_done = cut;
        }
        let t_us = (t_s * 1e6).round() as u64;
        let mut next = (self.t_us / PASS_US + 1) * PASS_US;
        while next <= t_us {
            self.pass(next);
            next += PASS_US;
        }
        self.t_us = t_us;
        self.tether();
        let out = *self.app.last_output();
        let pulse = self.node.output_us();
        Ok(StepReply {
            requested: out.requested,
            achieved: out.allocation.achieved,
            thrust_cmd_n: out.allocation.thrust_n,
            applied_n: pulse.map(|p| f64::from(self.pwm.thrust_n(f32::from(p)))),
            pulse_us: pulse.map(f64::from),
            errors: out.errors,
            saturated: false,
            estimate: None,
        })
    }

    /// The node's sensors; the fixes would come from the PC, which sends none here.
    fn forward(&mut self, measurements: &[Measurement]) -> anyhow::Result<()> {
        for m in measurements {
            match *m {
                Measurement::Imu(s) => self.sensors.imu.borrow_mut().0.push_back(s),
                Measurement::Depth(d) => {
                    let p = self.pressure.pressure_pa(d.depth_m);
                    self.sensors.pressure.borrow_mut().push_back((d.t_us, p));
                }
                _ => {}
            }
        }
        Ok(())
    }
}

/// Run the topside board, its node and the plant on the host's clock until `stop`; returns
/// the gain the topside App holds at the end.
fn run_boards(pty: TTYPort, stop: Arc<AtomicBool>, cut: Arc<AtomicBool>) -> f32 {
    let mut sc = Scenario::load("nav-circle-3d").unwrap();
    sc.deployment.control = Control::Topside;
    let sc = layout_scenario(&sc).resolve().unwrap();
    let clock = Rc::new(Cell::new(0u64));
    let config = Config {
        timing: Timing::FixedRate {
            control_period_us: FALLBACK_PERIOD_US,
            telemetry_period_us: 100_000,
        },
        ..Config::fixed_rate(Board::Host)
    };
    let bridge: &'static NodeBridge = Box::leak(Box::new(NodeBridge::new(config.pwm_period_us())));
    let app = App::with_sensors(
        bridge.thrusters(),
        SimSerial::default(),
        Clock(clock.clone()),
        Controller::new(*sc.vehicle(), Gains::default()).unwrap(),
        config,
        bridge.sensors(),
    )
    .unwrap();
    let top_port = Port::default();
    let link = TopsideLink::new(bridge, top_port.clone(), TopsideConfig::new(0x5E71_A125));
    let node_port = Port::default();
    let sensors = NodeSensors::default();
    let node = Node::new(
        [SimPwm::default(), SimPwm::default(), SimPwm::default()],
        node_port.clone(),
        Clock(clock.clone()),
        sensors.clone(),
        NodeConfig {
            imu_period_us: NODE_IMU_PERIOD_US,
            ..NodeConfig::DEFAULT
        },
    )
    .unwrap();
    let boards = Boards {
        clock,
        app,
        link,
        node,
        top_port,
        node_port,
        wire: Duplex::new(sc.deployment.wire(), 1),
        sensors,
        pressure: onboard_config(&sc).pressure,
        pwm: PwmMap::for_vehicle(sc.vehicle()),
        pty,
        cut,
        cut_done: false,
        t_us: 0,
    };
    let opts = RunOptions {
        open_ended: true,
        ..RunOptions::default()
    };
    let nav = VehicleNav::for_scenario(&sc, sc.disturbance.noise_seed);
    let mut run = ClosedLoop::new(&sc, &opts, nav, boards).unwrap();
    let t0 = Instant::now();
    while !stop.load(Ordering::Relaxed) {
        // The host's clock: the loop runs what has elapsed.
        let now_s = t0.elapsed().as_secs_f64();
        while run.t_s() <= now_s {
            assert!(run.step().unwrap(), "{}", run.stop_reason());
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    run.endpoint()
        .app
        .autopilot()
        .controller()
        .gains()
        .tracking
        .xy_kp
}

/// The node's sensors and motors are healthy in `SYS_STATUS`.
fn node_healthy(m: &MavMessage) -> Option<bool> {
    let node = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO
        | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
        | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS;
    match m {
        MavMessage::SYS_STATUS(s) => Some(s.onboard_control_sensors_health.contains(node)),
        _ => None,
    }
}

pub(crate) fn the_topside_drives_a_topside_board_on_a_serial_line_and_shows_its_node_link() {
    let (mut master, slave) = TTYPort::pair().expect("a pseudo-terminal pair");
    let device = slave.name().expect("the pty's name");
    drop(slave);
    master.set_timeout(Duration::from_millis(1)).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let cut = Arc::new(AtomicBool::new(false));
    let boards = {
        let (stop, cut) = (stop.clone(), cut.clone());
        std::thread::spawn(move || run_boards(master, stop, cut))
    };

    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("topside-layout-serial");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let port = gcs::free_udp_port();
    let mut topside = gcs::topside_serial(&device, port, &dir, 60);
    let gcs = mavlink::connect::<MavMessage>(&format!("udpin:127.0.0.1:{port}")).unwrap();
    let send = |msg: &MavMessage| {
        let h = MavHeader {
            system_id: 255,
            component_id: 190,
            sequence: 0,
        };
        gcs.send(&h, msg).unwrap();
    };

    let hb = wait(&gcs, Duration::from_secs(10), |m| match m {
        MavMessage::HEARTBEAT(h) => Some(h.clone()),
        _ => None,
    })
    .expect("a HEARTBEAT through the serial line");
    assert_eq!(hb.mavtype, MavType::MAV_TYPE_SUBMARINE);

    // A parameter set on the topside board, acknowledged by it.
    send(&MavMessage::PARAM_SET(PARAM_SET_DATA {
        param_value: 1.5,
        target_system: 1,
        target_component: 1,
        param_id: "TRK_XY_KP".into(),
        param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
    }));
    let v = wait(&gcs, Duration::from_secs(5), |m| match m {
        MavMessage::PARAM_VALUE(p) if p.param_id.to_str().ok() == Some("TRK_XY_KP") => {
            Some(p.param_value)
        }
        _ => None,
    });
    assert_eq!(v, Some(1.5));

    // The node link up: the node's sensors and motors healthy.
    let healthy = wait(&gcs, Duration::from_secs(10), |m| {
        node_healthy(m).filter(|&h| h)
    });
    assert_eq!(
        healthy,
        Some(true),
        "SYS_STATUS never showed the node link healthy"
    );

    // The node link cut: the ground station is told, and the health drops.
    let cut_at = Instant::now();
    cut.store(true, Ordering::Relaxed);
    let (mut text, mut lost) = (None, None);
    let end = Instant::now() + Duration::from_secs(5);
    while Instant::now() < end && (text.is_none() || lost.is_none()) {
        if let Some(m) = wait(&gcs, Duration::from_millis(50), |m| Some(m.clone())) {
            if let MavMessage::STATUSTEXT(t) = &m {
                let s = t.text.to_str().unwrap_or("").to_string();
                if s.contains("node link lost") && text.is_none() {
                    text = Some((s, cut_at.elapsed()));
                }
            }
            if node_healthy(&m) == Some(false) && lost.is_none() {
                lost = Some(cut_at.elapsed());
            }
        }
    }
    let (text, text_after) = text.expect("no STATUSTEXT of the node link's loss");
    assert!(text.starts_with("Failsafe: node link lost"), "{text}");
    let lost_after = lost.expect("SYS_STATUS never showed the node link lost");
    println!(
        "node link cut: STATUSTEXT {text:?} after {:.0} ms, SYS_STATUS unhealthy after {:.0} ms \
         (wall clock, the topside's 1 Hz SYS_STATUS)",
        text_after.as_secs_f64() * 1e3,
        lost_after.as_secs_f64() * 1e3
    );
    // The topside's 60 ms silence plus the 100 ms telemetry period and the 20 ms topside
    // period, with the host's scheduling: well under a second.
    assert!(text_after < Duration::from_secs(1), "{text_after:?}");

    // Joined again: the ground station is told the link is back, and the health returns.
    let joined_at = Instant::now();
    cut.store(false, Ordering::Relaxed);
    let (mut cleared, mut healthy) = (None, None);
    let end = Instant::now() + Duration::from_secs(5);
    while Instant::now() < end && (cleared.is_none() || healthy.is_none()) {
        if let Some(m) = wait(&gcs, Duration::from_millis(50), |m| Some(m.clone())) {
            if let MavMessage::STATUSTEXT(t) = &m {
                let s = t.text.to_str().unwrap_or("").to_string();
                if s.starts_with("Cleared: node link lost") && cleared.is_none() {
                    cleared = Some(joined_at.elapsed());
                }
            }
            if node_healthy(&m) == Some(true) && healthy.is_none() {
                healthy = Some(joined_at.elapsed());
            }
        }
    }
    let cleared = cleared.expect("no STATUSTEXT of the node link's return");
    let healthy = healthy.expect("SYS_STATUS never showed the node link healthy again");
    println!(
        "node link joined again: \"Cleared: node link lost\" after {:.0} ms, SYS_STATUS \
         healthy after {:.0} ms",
        cleared.as_secs_f64() * 1e3,
        healthy.as_secs_f64() * 1e3
    );

    let _ = topside.kill();
    let _ = topside.wait();
    stop.store(true, Ordering::Relaxed);
    let gain = boards.join().unwrap();
    assert_eq!(
        gain, 1.5,
        "the topside board holds the gain set over the serial line"
    );
}
