//! The topside's end of the node link, on the host: the App's thrusters into downlinks, the
//! uplinks into the App's sensors, the silence failsafes, the refusals; and the two roles
//! joined by an in-memory wire.
#![allow(
    clippy::unwrap_used,
    clippy::indexing_slicing,
    clippy::needless_range_loop
)]

use super::*;
use crate::app::{App, Config, Monotonic};
use crate::node::{Node, NodeConfig};
use crate::node_link::encode_frame_for_tests;
use crate::node_link::NODE_LINK_VERSION;
use crate::protocol::Board;
use controller_core::controller::{Controller, Gains};
use controller_core::params::Vehicle;
use std::cell::RefCell;
use std::collections::VecDeque;
use std::convert::Infallible;
use std::rc::Rc;

const SESSION: u32 = 0x7095_1DE5;
const PERIOD: u64 = LINK_PERIOD_US as u64;

/// A port whose two directions are shared queues (so two roles can be joined).
#[derive(Debug, Clone, Default)]
struct Port {
    rx: Rc<RefCell<VecDeque<u8>>>,
    tx: Rc<RefCell<VecDeque<u8>>>,
}

impl Port {
    /// The other end of this port.
    fn other_end(&self) -> Port {
        Port {
            rx: self.tx.clone(),
            tx: self.rx.clone(),
        }
    }
}

impl embedded_io::ErrorType for Port {
    type Error = Infallible;
}
impl Read for Port {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let mut q = self.rx.borrow_mut();
        let n = buf.len().min(q.len());
        for (b, x) in buf.iter_mut().zip(q.drain(..n)) {
            *b = x;
        }
        Ok(n)
    }
}
impl ReadReady for Port {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(!self.rx.borrow().is_empty())
    }
}
impl Write for Port {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        self.tx.borrow_mut().extend(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}
impl WriteReady for Port {
    fn write_ready(&mut self) -> Result<bool, Infallible> {
        Ok(true)
    }
}

#[derive(Debug, Clone, Default)]
struct Clock(Rc<Cell<u64>>);
impl Monotonic for Clock {
    fn now_us(&mut self) -> u64 {
        self.0.get()
    }
}

/// Every downlink the topside wrote to `port`'s far end.
fn downlinks(far: &Port) -> Vec<(u16, Downlink)> {
    let mut d = LinkDecoder::<Downlink>::new();
    let bytes: Vec<u8> = far.rx.borrow_mut().drain(..).collect();
    bytes
        .iter()
        .filter_map(|&b| d.push(b))
        .map(|f| match f {
            LinkFrame::Frame { seq, msg } => (seq, msg),
            LinkFrame::Dropped(r) => panic!("downlink dropped: {r:?}"),
        })
        .collect()
}

const RATE: [f32; 3] = [0.2, -0.1, 0.05];
const ACCEL: [f32; 3] = [0.3, 0.0, -9.81];

fn uplink(echo_seq: u16, pressure_count: u8) -> Uplink {
    let dt = 0.02;
    Uplink {
        session: SESSION,
        echo_seq,
        echo_t_us: 0,
        imu_age_us: 0,
        dt_us: 20_000,
        samples: 8,
        delta_angle_rad: RATE.map(|w| w * dt),
        delta_velocity_m_s: ACCEL.map(|a| a * dt),
        pressure_pa: 150_000.0,
        pressure_count,
        status: status::ARMED,
        counters: NodeCounters::default(),
        dvl: None,
    }
}

struct Bench {
    bridge: &'static NodeBridge,
    link: TopsideLink<'static, Port>,
    far: Port,
    up_seq: u16,
}

impl Bench {
    fn new() -> Self {
        let bridge: &'static NodeBridge = Box::leak(Box::new(NodeBridge::new(20_000)));
        let port = Port::default();
        let far = port.other_end();
        let link = TopsideLink::new(bridge, port, TopsideConfig::new(SESSION));
        Self {
            bridge,
            link,
            far,
            up_seq: 0,
        }
    }

    fn send_up(&mut self, now: u64, up: &Uplink) -> bool {
        self.up_seq += 1;
        self.send_up_seq(now, self.up_seq, up)
    }

    fn send_up_seq(&mut self, now: u64, seq: u16, up: &Uplink) -> bool {
        let f = encode_frame_for_tests(NODE_LINK_VERSION, seq, up);
        self.far.tx.borrow_mut().extend(f);
        self.link.poll(now, true)
    }
}

#[test]
fn the_apps_duties_go_into_the_next_downlink() {
    let mut b = Bench::new();
    let mut t = b.bridge.thrusters();
    assert_eq!(
        t[0].max_duty_cycle(),
        20_000,
        "one step a microsecond at 50 Hz"
    );
    t[0].set_duty_cycle(1700).unwrap();
    t[1].set_duty_cycle(1300).unwrap();
    t[2].set_duty_cycle(1500).unwrap();
    b.send_up(0, &uplink(0, 1));
    b.link.send_if_due(0, true);
    let d = downlinks(&b.far);
    assert_eq!(d.len(), 1);
    let (_, cmd) = d[0];
    assert_eq!(cmd.pulse_us, [1700, 1300, 1500]);
    assert_eq!(cmd.session, SESSION);
    assert_eq!(cmd.ttl_ms, 100);
    assert_eq!(cmd.arm, ArmCommand::Armed);
    // Nothing new written: the next one a link period later, disarmed now.
    b.link.send_if_due(PERIOD - 1, false);
    assert!(downlinks(&b.far).is_empty());
    b.send_up(PERIOD, &uplink(0, 1));
    b.link.send_if_due(PERIOD, false);
    let d = downlinks(&b.far);
    assert_eq!(d[0].1.arm, ArmCommand::Disarmed);
    // A pulse outside the ESC's range (a bad duty) is clamped, never refused by the node.
    t[0].set_duty_cycle(20_000).unwrap();
    t[1].set_duty_cycle(0).unwrap();
    b.link.send_if_due(PERIOD + 1, true);
    assert_eq!(downlinks(&b.far)[0].1.pulse_us, [1900, 1100, 1500]);
}

#[test]
fn an_uplink_becomes_one_imu_sample_and_a_pressure() {
    let mut b = Bench::new();
    let mut s = b.bridge.sensors();
    assert!(b.send_up(1_000, &uplink(0, 1)));
    let imu = s.imu(5_000).unwrap();
    assert_eq!(imu.t_us, 5_000);
    for k in 0..3 {
        assert!((imu.gyro_rad_s[k] - RATE[k]).abs() < 1e-5);
        assert!((imu.accel_m_s2[k] - ACCEL[k]).abs() < 1e-4);
    }
    assert_eq!(s.pressure_pa(5_000), Some(150_000.0));
    assert_eq!(s.pressure_pa(5_000), None, "a reading is given once");
    // The same pressure count: no new reading.
    assert!(b.send_up(21_000, &uplink(0, 1)));
    assert_eq!(s.pressure_pa(21_000), None);
    assert_eq!(b.bridge.faults(), 0);
}

#[test]
fn a_silent_uplink_predicts_only_then_commands_neutral() {
    let mut b = Bench::new();
    let mut s = b.bridge.sensors();
    // At boot nothing was heard: lost, neutral.
    b.link.poll(0, false);
    assert_eq!(b.bridge.faults(), fault::NODE_LINK_LOST);
    assert!(s.imu(0).is_none());
    b.send_up(0, &uplink(0, 1));
    assert_eq!(b.bridge.faults(), 0);
    let first = s.imu(0).unwrap();
    let mut t = b.bridge.thrusters();
    t.iter_mut().for_each(|o| o.set_duty_cycle(1700).unwrap());
    // Two silent periods: nothing yet; the held sample keeps the estimator going.
    b.link.poll(3 * PERIOD - 1, true);
    assert_eq!(b.bridge.faults(), 0);
    // Three: the surface is told; no pressure; the previous IMU sample again.
    b.link.poll(3 * PERIOD, true);
    assert_eq!(b.bridge.faults(), fault::NODE_LINK_LOST);
    b.bridge.pressure_pa.set(Some(1.0e5));
    assert_eq!(s.pressure_pa(3 * PERIOD), None);
    let held = s.imu(3 * PERIOD).unwrap();
    assert_eq!(held.gyro_rad_s, first.gyro_rad_s);
    assert_eq!(held.t_us, 3 * PERIOD);
    b.link.send_if_due(3 * PERIOD, true);
    assert_eq!(downlinks(&b.far)[0].1.pulse_us, [1700; 3]);
    // 250 ms: neutral commanded whatever the App writes; no IMU sample.
    b.link.poll(249_999, true);
    b.link.send_if_due(249_999, true);
    assert_eq!(downlinks(&b.far)[0].1.pulse_us, [1700; 3]);
    b.link.poll(250_000, true);
    t.iter_mut().for_each(|o| o.set_duty_cycle(1700).unwrap());
    b.link.send_if_due(250_000, true);
    assert_eq!(downlinks(&b.far)[0].1.pulse_us, [1500; 3]);
    assert!(s.imu(250_000).is_none());
    // The node answers again: thrust resumes.
    b.send_up(260_000, &uplink(0, 2));
    t.iter_mut().for_each(|o| o.set_duty_cycle(1700).unwrap());
    b.link.send_if_due(260_000, true);
    assert_eq!(downlinks(&b.far)[0].1.pulse_us, [1700; 3]);
    assert_eq!(b.bridge.faults(), 0);
}

#[test]
fn bad_uplinks_are_refused_counted_and_leave_the_estimate_alone() {
    let mut b = Bench::new();
    let mut s = b.bridge.sensors();
    assert!(b.send_up(0, &uplink(0, 1)));
    let good = s.imu(0).unwrap();
    let _ = s.pressure_pa(0);
    let mut nan = uplink(0, 2);
    nan.delta_angle_rad[1] = f32::NAN;
    let mut inf = uplink(0, 2);
    inf.delta_velocity_m_s[2] = f32::INFINITY;
    let mut spin = uplink(0, 2);
    spin.delta_angle_rad[0] = 41.0 * 0.02; // 41 rad/s
    let mut shove = uplink(0, 2);
    shove.delta_velocity_m_s[0] = 161.0 * 0.02;
    let mut dt0 = uplink(0, 2);
    dt0.dt_us = 0;
    let mut long = uplink(0, 2);
    long.dt_us = 80_001;
    let mut p_nan = uplink(0, 2);
    p_nan.pressure_pa = f32::NAN;
    let mut p_low = uplink(0, 2);
    p_low.pressure_pa = 0.0;
    for bad in [nan, inf, spin, shove, dt0, long, p_nan, p_low] {
        assert!(!b.send_up(1_000, &bad), "{bad:?}");
    }
    assert_eq!(b.link.counters().bad_data, 8);
    // Another topside's node, a replayed and an older sequence, another version, a bad CRC.
    assert!(!b.send_up(
        1_000,
        &Uplink {
            session: 99,
            ..uplink(0, 2)
        }
    ));
    assert!(
        !b.send_up_seq(1_000, 1, &uplink(0, 2)),
        "the accepted one's"
    );
    assert!(!b.send_up_seq(1_000, 0, &uplink(0, 2)));
    let f = encode_frame_for_tests(NODE_LINK_VERSION + 1, b.up_seq + 1, &uplink(0, 2));
    b.far.tx.borrow_mut().extend(f);
    let mut f = encode_frame_for_tests(NODE_LINK_VERSION, b.up_seq + 1, &uplink(0, 2));
    f[6] ^= 0x40;
    b.far.tx.borrow_mut().extend(f);
    assert!(!b.link.poll(1_000, true));
    let c = b.link.counters();
    assert_eq!((c.foreign, c.replayed, c.version, c.corrupt), (1, 2, 1, 1));
    assert_eq!(c.accepted, 1);
    // The estimator still sees the good sample (held), no pressure from the refused ones.
    assert_eq!(s.imu(1_000).unwrap().gyro_rad_s, good.gyro_rad_s);
    assert_eq!(s.pressure_pa(1_000), None);
    // A node not yet serving any session (0) is heard.
    assert!(b.send_up(
        2_000,
        &Uplink {
            session: 0,
            ..uplink(0, 2)
        }
    ));
}

/// The node's echo of `d` after holding it `held_us`.
fn echo(d: &Downlink, seq: u16, held_us: u32) -> Uplink {
    Uplink {
        echo_t_us: d.t_us.wrapping_add(held_us),
        ..uplink(seq, 1)
    }
}

#[test]
fn the_echoed_time_gives_the_round_trip() {
    let mut b = Bench::new();
    b.send_up(0, &uplink(0, 1));
    b.link.send_if_due(1_000, true);
    let (seq, d) = downlinks(&b.far)[0];
    assert_eq!(d.t_us, 1_000, "the downlink carries its send time");
    // Sent at 1 ms, held 2 ms by the node, back at 13.5 ms: 10.5 ms on the wire.
    b.send_up(13_500, &echo(&d, seq, 2_000));
    assert_eq!(b.link.round_trip_us(), Some(10_500));
    // A node of no session yet (it applied no downlink) tells nothing.
    let mut b = Bench::new();
    b.send_up(
        5_000,
        &Uplink {
            session: 0,
            echo_t_us: 0,
            ..uplink(0, 1)
        },
    );
    assert_eq!(b.link.round_trip_us(), None);
}

#[test]
fn a_round_trip_of_a_second_is_measured_whatever_was_sent_meanwhile() {
    // 500 ms each way: some 50 downlinks go out before the first echo comes back (the
    // topside kept the send times of 8, 160 ms, before the link's version 2).
    let mut b = Bench::new();
    b.send_up(0, &uplink(0, 1));
    let mut first = None;
    let mut t = 0;
    while t <= 1_000_000 {
        b.link.send_if_due(t, true);
        for (seq, d) in downlinks(&b.far) {
            first.get_or_insert((seq, d));
        }
        t += 1_000;
    }
    let (seq, d) = first.unwrap();
    assert!(b.link.counters().sent >= 50, "{:?}", b.link.counters());
    b.send_up(1_020_000, &echo(&d, seq, 3_000));
    assert_eq!(b.link.round_trip_us(), Some(1_017_000));
    // The uplink's one way: half, plus half of the uplink's longer wire time.
    let up = wire_time_us(MAX_UPLINK_FRAME_LEN, LINK_BAUD);
    let down = wire_time_us(MAX_DOWNLINK_FRAME_LEN, LINK_BAUD);
    assert_eq!(b.link.one_way_us(), Some((1_017_000 + up - down) / 2));
}

#[test]
fn node_sample_stamps_place_the_increments_on_the_topsides_clock() {
    let bridge: &'static NodeBridge = Box::leak(Box::new(NodeBridge::new(20_000)));
    let port = Port::default();
    let far = port.other_end();
    let config = TopsideConfig {
        imu_stamp: ImuStamp::NodeSample,
        ..TopsideConfig::new(SESSION)
    };
    let mut b = Bench {
        bridge,
        link: TopsideLink::new(bridge, port, config),
        far,
        up_seq: 0,
    };
    let mut s = b.bridge.sensors();
    b.send_up(0, &uplink(0, 1));
    b.link.send_if_due(10_000, true);
    let (seq, d) = downlinks(&b.far)[0];
    // 200 ms each way plus the wire times; the newest sample 1.5 ms old when sent.
    let up = Uplink {
        imu_age_us: 1_500,
        ..echo(&d, seq, 4_000)
    };
    let arrival = 10_000 + 4_000 + 400_000 + 9_000;
    assert!(b.send_up(arrival, &up));
    let rt = b.link.round_trip_us().unwrap();
    assert_eq!(rt, 409_000);
    let one_way = b.link.one_way_us().unwrap();
    let imu = s.imu(arrival).unwrap();
    assert_eq!(imu.t_us, arrival - u64::from(one_way) - 1_500);
    // The held sample, re-fed while the uplink is late, keeps the lag and goes forward.
    let later = s.imu(arrival + 30_000).unwrap();
    assert_eq!(later.t_us, imu.t_us + 30_000);
    // A stamp never goes back: a larger lag that would is refused.
    let up = Uplink {
        imu_age_us: 100_000,
        ..echo(&d, seq, 4_000)
    };
    assert!(b.send_up(arrival + 31_000, &up));
    assert_eq!(s.imu(arrival + 31_000), None);
}

#[test]
fn a_latched_node_under_an_armed_topside_is_reported() {
    let mut b = Bench::new();
    let up = Uplink {
        status: status::LATCHED,
        ..uplink(0, 1)
    };
    b.send_up(0, &up);
    assert_eq!(b.bridge.faults(), fault::NODE_NOT_ARMED);
    b.link.poll(1, false);
    assert_eq!(b.bridge.faults(), 0, "disarmed: nothing to report");
}

#[test]
fn the_app_drives_the_bridge_and_reports_its_faults() {
    let bridge = NodeBridge::new(20_000);
    let controller = Controller::new(Vehicle::observer(), Gains::default()).unwrap();
    let config = Config::fixed_rate(Board::Stm32f4);
    let clock = Clock::default();
    let t = clock.0.clone();
    let mut app = App::with_sensors(
        bridge.thrusters(),
        Port::default(),
        clock,
        controller,
        config,
        bridge.sensors(),
    )
    .unwrap();
    // Neutral at construction, into the bridge.
    assert!(bridge.written.get());
    assert_eq!(bridge.pulses_us(), [1500; 3]);
    // The node link's fault reaches the surface's telemetry and status.
    let mut link = TopsideLink::new(&bridge, Port::default(), TopsideConfig::new(SESSION));
    link.poll(0, false);
    assert_eq!(
        app.telemetry(0).faults & fault::NODE_LINK_LOST,
        fault::NODE_LINK_LOST
    );
    assert_eq!(
        app.status(0, 0).faults & fault::NODE_LINK_LOST,
        fault::NODE_LINK_LOST
    );
    // `step_now` runs the step at once and restarts the period.
    t.set(5_000);
    let steps = app.autopilot().steps;
    app.step_now();
    assert_eq!(app.autopilot().steps, steps + 1);
    t.set(24_999);
    app.tick();
    assert_eq!(
        app.autopilot().steps,
        steps + 1,
        "next step a period after step_now"
    );
    t.set(25_000);
    app.tick();
    assert_eq!(app.autopilot().steps, steps + 2);
}

/// A constant IMU for the node.
struct NodeImu;
impl Sensors for NodeImu {
    fn imu(&mut self, now_us: u64) -> Option<ImuSample> {
        Some(ImuSample {
            t_us: now_us,
            gyro_rad_s: RATE,
            accel_m_s2: ACCEL,
        })
    }
    fn pressure_pa(&mut self, _now_us: u64) -> Option<f32> {
        Some(150_000.0)
    }
}

#[derive(Default)]
struct Esc(Vec<u16>);
impl embedded_hal::pwm::ErrorType for Esc {
    type Error = Infallible;
}
impl SetDutyCycle for Esc {
    fn max_duty_cycle(&self) -> u16 {
        20_000
    }
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Infallible> {
        self.0.push(duty);
        Ok(())
    }
}

#[test]
fn topside_and_node_joined_by_a_wire() {
    let bridge = NodeBridge::new(20_000);
    let top_port = Port::default();
    let node_port = top_port.other_end();
    let mut link = TopsideLink::new(&bridge, top_port, TopsideConfig::new(SESSION));
    let clock = Clock::default();
    let t = clock.0.clone();
    let escs = [Esc::default(), Esc::default(), Esc::default()];
    let mut node = Node::new(escs, node_port, clock, NodeImu, NodeConfig::DEFAULT).unwrap();
    let mut sensors = bridge.sensors();
    let mut thrusters = bridge.thrusters();
    let mut armed = false;
    let mut steps = 0;
    let mut last_imu = None;
    // 1 s at a 100 us loop on both sides; the topside arms at 0.2 s and asks for 1650 us.
    for i in 0..10_000u64 {
        let now = i * 100;
        t.set(now);
        node.tick();
        if now == 200_000 {
            armed = true;
        }
        if link.poll(now, armed) {
            // The App's step: read the sensors, write the thrusters.
            last_imu = sensors.imu(now);
            let p = if armed { 1650 } else { 1500 };
            thrusters
                .iter_mut()
                .for_each(|o| o.set_duty_cycle(p).unwrap());
            steps += 1;
        }
        link.send_if_due(now, armed);
    }
    assert!(steps >= 48, "a step per uplink: {steps}");
    assert!(node.armed());
    assert_eq!(node.output_us(), [1650; 3]);
    assert_eq!(node.session(), SESSION);
    let imu = last_imu.unwrap();
    for k in 0..3 {
        assert!((imu.gyro_rad_s[k] - RATE[k]).abs() < 1e-5, "{imu:?}");
    }
    assert_eq!(bridge.faults(), 0);
    let c = link.counters();
    assert_eq!((c.corrupt, c.replayed, c.foreign, c.bad_data), (0, 0, 0, 0));
    // The wire is instantaneous here: the round trip is the node's wait for its next uplink.
    assert!(link.round_trip_us().unwrap() <= 20_000);
    let nc = node.counters();
    assert_eq!(
        (nc.corrupt, nc.replayed, nc.foreign, nc.out_of_range),
        (0, 0, 0, 0)
    );
    // The cable is cut: the node is neutral within the time to live, latched at 1 s; the
    // topside reports the loss after 3 periods and commands neutral at 250 ms.
    let cut = 1_000_000u64;
    let mut neutral_at = None;
    let mut lost_at = None;
    for i in 0..15_000u64 {
        let now = cut + i * 100;
        t.set(now);
        // Whatever either end sent is lost.
        node.parts_mut().1.rx.borrow_mut().clear();
        node.tick();
        link.serial_mut().rx.borrow_mut().clear();
        link.poll(now, armed);
        link.send_if_due(now, armed);
        if neutral_at.is_none() && node.output_us() == [1500; 3] {
            neutral_at = Some(now - cut);
        }
        if lost_at.is_none() && bridge.faults() & fault::NODE_LINK_LOST != 0 {
            lost_at = Some(now - cut);
        }
    }
    println!(
        "cut: node neutral after {neutral_at:?} us, topside reports the loss after {lost_at:?} us"
    );
    assert!(neutral_at.unwrap() <= 100_000, "{neutral_at:?}");
    assert!(lost_at.unwrap() <= 3 * PERIOD, "{lost_at:?}");
    assert!(!node.armed(), "latched");
}

#[test]
fn a_restarted_node_is_heard_again_after_250_ms() {
    let mut b = Bench::new();
    for i in 0..10u16 {
        assert!(b.send_up_seq(u64::from(i) * PERIOD, 1_000 + i, &uplink(0, 1)));
    }
    // The node's watchdog resets it: its uplinks count from 0 again, refused as replays...
    let t0 = 10 * PERIOD;
    let mut heard = None;
    for i in 0..20u16 {
        let now = t0 + u64::from(i) * PERIOD;
        let up = Uplink {
            session: 0,
            ..uplink(0, 1)
        };
        if b.send_up_seq(now, i, &up) && heard.is_none() {
            heard = Some(now - t0);
        }
    }
    // ... until 250 ms after the last valid one (at t0 - PERIOD).
    assert_eq!(heard, Some(240_000), "{:?}", b.link.counters());
    assert_eq!(b.link.counters().replayed, 12);
}

mod dvl;
