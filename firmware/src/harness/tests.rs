//! The harness on the host: its frames, and the node's and the topside's passes at the
//! host's time with fake outputs and ports.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

use super::*;
use crate::app::Config;
use crate::node::NodeConfig;
use crate::node_link::{
    status, ArmCommand, Downlink, LinkFrame, NodeCounters, Uplink, NODE_LINK_VERSION,
};
use crate::protocol::{encode, Board, Command, DropReason};
use crate::topside_link::{NodeBridge, TopsideConfig};
use controller_core::controller::{Controller, Gains};
use controller_core::params::Vehicle;
use std::cell::RefCell;
use std::collections::VecDeque;
use std::convert::Infallible;
use std::rc::Rc;

const SESSION: u32 = 0x4A55_0025;

/// A port whose two directions are shared queues (the host holds the other end).
#[derive(Debug, Clone, Default)]
struct Port {
    rx: Rc<RefCell<VecDeque<u8>>>,
    tx: Rc<RefCell<VecDeque<u8>>>,
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

/// The boards' instruction counter, absent on the host.
struct NoTicks;
impl Monotonic for NoTicks {
    fn now_us(&mut self) -> u64 {
        0
    }
}

#[derive(Debug, Default)]
struct Esc(u16);
impl embedded_hal::pwm::ErrorType for Esc {
    type Error = Infallible;
}
impl SetDutyCycle for Esc {
    fn max_duty_cycle(&self) -> u16 {
        20_000
    }
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Infallible> {
        self.0 = duty;
        Ok(())
    }
}

fn roundtrip<M: Serialize + serde::de::DeserializeOwned + PartialEq + Copy + core::fmt::Debug>(
    m: &M,
) {
    let mut out = [0u8; MAX_FRAME_LEN];
    let f = seal(7, m, &mut out).unwrap().to_vec();
    let mut d = HarnessDecoder::<M>::new();
    let got: Vec<_> = f.iter().filter_map(|&b| d.push(b)).collect();
    assert_eq!(got, vec![LinkFrame::Frame { seq: 7, msg: *m }]);
    // Not a node-link frame: another version there.
    let mut link = LinkDecoder::<M>::new();
    let got: Vec<_> = f.iter().filter_map(|&b| link.push(b)).collect();
    assert_eq!(got, vec![LinkFrame::Dropped(DropReason::Version)]);
}

#[test]
fn the_largest_harness_messages_fit_and_round_trip() {
    let imu = HarnessImu {
        gyro_rad_s: [f32::MAX; 3],
        accel_m_s2: [f32::MIN; 3],
    };
    roundtrip(&NodeStep {
        t_us: u64::MAX,
        link_rx_bytes: u32::MAX,
        imu: Some(imu),
        pressure_pa: Some(f32::MAX),
    });
    roundtrip(&NodeReport {
        t_us: u64::MAX,
        pulse_us: [u16::MAX; 3],
        status: u8::MAX,
        accepted: u16::MAX,
        link_rx_bytes: u32::MAX,
        link_tx_bytes: u32::MAX,
        refused: Some(HarnessRefusal::BytesMissing),
    });
    roundtrip(&TopsideStep {
        t_us: u64::MAX,
        tether_rx_bytes: u32::MAX,
        link_rx_bytes: u32::MAX,
    });
    roundtrip(&TopsideReport {
        t_us: u64::MAX,
        tether_rx_bytes: u32::MAX,
        tether_tx_bytes: u32::MAX,
        link_rx_bytes: u32::MAX,
        link_tx_bytes: u32::MAX,
        uplink_steps: u32::MAX,
        refused: Some(HarnessRefusal::TimeBack),
    });
    // A node-link frame is not a harness step.
    let f = crate::node_link::encode_frame_for_tests(NODE_LINK_VERSION, 1, &0u8);
    let mut d = HarnessDecoder::<u8>::new();
    let got: Vec<_> = f.iter().filter_map(|&b| d.push(b)).collect();
    assert_eq!(got, vec![LinkFrame::Dropped(DropReason::Version)]);
}

fn downlink(arm: ArmCommand, pulse: u16) -> Downlink {
    Downlink {
        session: SESSION,
        seq: 0,
        pulse_us: [pulse, pulse, 3000 - pulse],
        ttl_ms: 100,
        arm,
        t_us: 0,
    }
}

#[test]
fn the_node_runs_at_the_hosts_time_and_reports_its_pulses() {
    let now = Cell::new(0u64);
    let inputs = HarnessInputs::new();
    let port = Port::default();
    let host = Port {
        rx: port.tx.clone(),
        tx: port.rx.clone(),
    };
    let mut node = Node::new(
        [Esc::default(), Esc::default(), Esc::default()],
        CountingPort::new(port),
        HostClock::new(&now, NoTicks),
        inputs.sensors(),
        NodeConfig::DEFAULT,
    )
    .unwrap();
    let imu = HarnessImu {
        gyro_rad_s: [0.1, -0.2, 0.3],
        accel_m_s2: [0.0, 0.5, -9.81],
    };
    let mut delivered = 0u32;
    let mut seq = 0u16;
    let mut received = 0usize;
    let mut uplinks = Vec::new();
    let mut up_dec = LinkDecoder::<Uplink>::new();
    // 100 ms of IMU steps at 400 Hz; the topside (the host here) disarms, then arms at
    // 1650 us from 40 ms.
    for k in 0..=40u64 {
        let t_us = k * 2_500;
        if k % 8 == 4 {
            seq += 1;
            let cmd = if t_us < 40_000 {
                downlink(ArmCommand::Disarmed, 1500)
            } else {
                downlink(ArmCommand::Armed, 1650)
            };
            let cmd = Downlink {
                seq: u64::from(seq),
                ..cmd
            };
            let f = crate::node_link::encode_frame_for_tests(NODE_LINK_VERSION, seq, &cmd);
            delivered += f.len() as u32;
            host.tx.borrow_mut().extend(f);
        }
        let step = NodeStep {
            t_us,
            link_rx_bytes: delivered,
            imu: Some(imu),
            pressure_pa: Some(120_000.0),
        };
        let r = node_pass(&mut node, &now, &inputs, &step, delivered);
        assert_eq!(r.refused, None, "{r:?}");
        assert_eq!((r.t_us, r.link_rx_bytes), (t_us, delivered));
        // What the node wrote is what its report counts.
        let bytes: Vec<u8> = host.rx.borrow_mut().drain(..).collect();
        received += bytes.len();
        assert_eq!(r.link_tx_bytes as usize, received);
        uplinks.extend(bytes.iter().filter_map(|&b| up_dec.push(b)));
        let expect = if t_us >= 50_000 {
            [1650, 1650, 1350]
        } else {
            [1500; 3]
        };
        assert_eq!(r.pulse_us, expect, "at {t_us} us");
    }
    // An uplink every 20 ms, with 8 IMU intervals of the host's samples in each.
    assert_eq!(uplinks.len(), 5, "{uplinks:?}");
    let LinkFrame::Frame { msg: up, .. } = uplinks[2] else {
        panic!("{uplinks:?}")
    };
    assert_eq!((up.samples, up.dt_us), (8, 20_000));
    assert!((up.delta_angle_rad[2] - 0.3 * 0.02).abs() < 1e-6, "{up:?}");
    assert_eq!(up.pressure_pa, 120_000.0);
    assert_eq!(
        up.counters,
        NodeCounters {
            accepted: up.counters.accepted,
            ..Default::default()
        }
    );

    // Refused steps change nothing: time going back, bytes not all there.
    let before = (now.get(), node.output_us(), node.counters());
    let r = node_pass(
        &mut node,
        &now,
        &inputs,
        &NodeStep {
            t_us: 1,
            link_rx_bytes: delivered,
            imu: None,
            pressure_pa: None,
        },
        delivered,
    );
    assert_eq!(r.refused, Some(HarnessRefusal::TimeBack));
    let step = NodeStep {
        t_us: 200_000,
        link_rx_bytes: delivered + 5,
        imu: None,
        pressure_pa: None,
    };
    let r = node_pass(&mut node, &now, &inputs, &step, delivered);
    assert_eq!(r.refused, Some(HarnessRefusal::BytesMissing));
    assert_eq!((r.t_us, r.pulse_us), (100_000, [1650, 1650, 1350]));
    assert_eq!(before, (now.get(), node.output_us(), node.counters()));
    // Without the downlinks the node goes neutral on its time to live (100 ms after the
    // last one at 90 ms): the host's time is the node's.
    let step = NodeStep {
        t_us: 190_001,
        link_rx_bytes: delivered,
        imu: None,
        pressure_pa: None,
    };
    let r = node_pass(&mut node, &now, &inputs, &step, delivered);
    assert_eq!(r.pulse_us, [1500; 3]);
    assert_ne!(r.status & status::TTL_NEUTRAL, 0);
}

#[test]
fn the_topside_steps_on_uplinks_at_the_hosts_time() {
    let now = Cell::new(0u64);
    let bridge = NodeBridge::new(20_000);
    let tether = Port::default();
    let pc = Port {
        rx: tether.tx.clone(),
        tx: tether.rx.clone(),
    };
    let link_port = Port::default();
    let node = Port {
        rx: link_port.tx.clone(),
        tx: link_port.rx.clone(),
    };
    let config = Config {
        timing: crate::app::Timing::FixedRate {
            control_period_us: 25_000,
            telemetry_period_us: 100_000,
        },
        ..Config::fixed_rate(Board::Host)
    };
    let controller = Controller::new(Vehicle::observer(), Gains::default()).unwrap();
    let mut app: TopsideApp<'_, Port, HostClock<'_, NoTicks>> = App::with_sensors(
        bridge.thrusters(),
        CountingPort::new(tether),
        HostClock::new(&now, NoTicks),
        controller,
        config,
        bridge.sensors(),
    )
    .unwrap();
    let mut link = TopsideLink::new(
        &bridge,
        CountingPort::new(link_port),
        TopsideConfig::new(SESSION),
    );
    let mut steps = 0u32;
    let (mut tether_in, mut link_in) = (0u32, 0u32);
    // The PC's heartbeat at 10 ms is answered at 10 ms, not before.
    let mut buf = [0u8; MAX_FRAME_LEN];
    let hb = encode(0, 1, &Command::Heartbeat { t_us: 10_000 }, &mut buf).unwrap();
    tether_in += hb.len() as u32;
    pc.tx.borrow_mut().extend(hb);
    let step = |t_us, tether_rx_bytes, link_rx_bytes| TopsideStep {
        t_us,
        tether_rx_bytes,
        link_rx_bytes,
    };
    // Bytes the step counts that have not arrived: refused, nothing read.
    let r = topside_pass(
        &mut app,
        &mut link,
        &now,
        &step(10_000, tether_in, 0),
        0,
        0,
        &mut steps,
    );
    assert_eq!(r.refused, Some(HarnessRefusal::BytesMissing));
    assert_eq!((r.t_us, r.tether_rx_bytes, r.tether_tx_bytes), (0, 0, 0));
    let r = topside_pass(
        &mut app,
        &mut link,
        &now,
        &step(10_000, tether_in, 0),
        tether_in,
        0,
        &mut steps,
    );
    assert_eq!(r.refused, None);
    assert_eq!((r.t_us, r.tether_rx_bytes), (10_000, tether_in));
    assert!(r.tether_tx_bytes > 0, "answered: {r:?}");
    assert_eq!(pc.rx.borrow().len() as u32, r.tether_tx_bytes);
    let downlinks_before = r.link_tx_bytes;
    // An uplink at 15 ms runs the step at once and a downlink goes down.
    let up = Uplink {
        session: SESSION,
        echo_seq: 0,
        echo_t_us: 0,
        imu_age_us: 0,
        dt_us: 20_000,
        samples: 8,
        delta_angle_rad: [0.0; 3],
        delta_velocity_m_s: [0.0, 0.0, -9.81 * 0.02],
        pressure_pa: 150_000.0,
        pressure_count: 1,
        status: status::LATCHED,
        counters: NodeCounters::default(),
        dvl: None,
    };
    let f = crate::node_link::encode_frame_for_tests(NODE_LINK_VERSION, 1, &up);
    link_in += f.len() as u32;
    node.tx.borrow_mut().extend(f);
    let r = topside_pass(
        &mut app,
        &mut link,
        &now,
        &step(15_000, tether_in, link_in),
        tether_in,
        link_in,
        &mut steps,
    );
    assert_eq!(
        (r.refused, r.uplink_steps, r.link_rx_bytes),
        (None, 1, link_in)
    );
    assert!(r.link_tx_bytes > downlinks_before, "{r:?}");
    assert_eq!(node.rx.borrow().len() as u32, r.link_tx_bytes);
    // Time never goes back.
    let r = topside_pass(
        &mut app,
        &mut link,
        &now,
        &step(14_999, tether_in, link_in),
        tether_in,
        link_in,
        &mut steps,
    );
    assert_eq!(
        (r.refused, r.t_us),
        (Some(HarnessRefusal::TimeBack), 15_000)
    );
}
