//! The node's DVL velocity on the topside: stamped on the IMU samples' timeline, given
//! once, counted; the node's refusals summed across the wrap of its count.

use super::*;
use embedded_io::{Read, ReadReady};

const DVL: UplinkDvl = UplinkDvl {
    age_ms: 63,
    velocity_mm_s: [250, -100],
    std_mm_s: 10,
};

fn with_dvl(up: Uplink, dvl: UplinkDvl) -> Uplink {
    Uplink {
        dvl: Some(dvl),
        ..up
    }
}

#[test]
fn a_dvl_velocity_at_arrival_stamps_is_placed_on_the_imu_samples_timeline() {
    let mut b = Bench::new();
    let mut s = b.bridge.sensors();
    // The increments' newest sample 1.5 ms before the sealing, stamped at the arrival: the
    // velocity (63 ms before the sealing) 61.5 ms before the arrival.
    let up = Uplink {
        imu_age_us: 1_500,
        ..with_dvl(uplink(0, 1), DVL)
    };
    assert!(b.send_up(1_000_000, &up));
    let fix = s.dvl(1_000_000).unwrap();
    assert_eq!(fix.t_us, 1_000_000 - 61_500);
    assert_eq!(fix.velocity_m_s, [0.25, -0.1]);
    assert_eq!(fix.std_m_s, 0.01);
    assert_eq!(s.dvl(1_000_000), None, "given once");
    assert_eq!(b.link.counters().dvl_fixes, 1);
    // An uplink without one gives none.
    assert!(b.send_up(1_020_000, &uplink(0, 1)));
    assert_eq!(s.dvl(1_020_000), None);
    assert_eq!(b.link.counters().dvl_fixes, 1);
    // A velocity younger than the newest IMU sample is stamped at that sample (the
    // estimator's newest time), never after it.
    let up = Uplink {
        imu_age_us: 1_500,
        ..with_dvl(uplink(0, 1), UplinkDvl { age_ms: 1, ..DVL })
    };
    assert!(b.send_up(1_040_000, &up));
    assert_eq!(s.dvl(1_040_000).unwrap().t_us, 1_040_000);
}

#[test]
fn a_dvl_velocity_at_node_sample_stamps_is_the_sealing_less_its_age() {
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
    let up = Uplink {
        imu_age_us: 1_500,
        ..with_dvl(echo(&d, seq, 4_000), DVL)
    };
    let arrival = 10_000 + 4_000 + 400_000 + 9_000;
    assert!(b.send_up(arrival, &up));
    let one_way = u64::from(b.link.one_way_us().unwrap());
    let imu = s.imu(arrival).unwrap();
    assert_eq!(imu.t_us, arrival - one_way - 1_500);
    assert_eq!(s.dvl(arrival).unwrap().t_us, arrival - one_way - 63_000);
}

#[test]
fn the_nodes_refused_dvl_reports_are_summed_across_their_wrap() {
    let mut b = Bench::new();
    let counted = |refused: u8| Uplink {
        counters: NodeCounters {
            dvl_refused: refused,
            ..NodeCounters::default()
        },
        ..uplink(0, 1)
    };
    let mut t = 0;
    for (refused, total) in [(2u8, 2u32), (2, 2), (250, 250), (3, 259), (10, 266)] {
        t += PERIOD;
        assert!(b.send_up(t, &counted(refused)));
        assert_eq!(b.link.counters().node_dvl_refused, total, "{refused}");
    }
}

#[test]
fn a_dvl_speed_over_20_m_s_refuses_the_uplink() {
    let mut b = Bench::new();
    let mut s = b.bridge.sensors();
    let fast = UplinkDvl {
        velocity_mm_s: [0, -20_001],
        ..DVL
    };
    assert!(!b.send_up(1_000, &with_dvl(uplink(0, 1), fast)));
    assert_eq!(b.link.counters().bad_data, 1);
    assert_eq!((s.dvl(1_000), s.imu(1_000)), (None, None));
    let edge = UplinkDvl {
        velocity_mm_s: [20_000, -20_000],
        ..DVL
    };
    assert!(b.send_up(2_000, &with_dvl(uplink(0, 1), edge)));
    assert_eq!(s.dvl(2_000).unwrap().velocity_m_s, [20.0, -20.0]);
}

/// The DVL's UART on the node: the test writes lines into it.
#[derive(Debug, Clone, Default)]
struct DvlUart(Rc<RefCell<VecDeque<u8>>>);

impl embedded_io::ErrorType for DvlUart {
    type Error = Infallible;
}
impl Read for DvlUart {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let mut q = self.0.borrow_mut();
        let n = buf.len().min(q.len());
        for (b, x) in buf.iter_mut().zip(q.drain(..n)) {
            *b = x;
        }
        Ok(n)
    }
}
impl ReadReady for DvlUart {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(!self.0.borrow().is_empty())
    }
}

/// A `wrz` line valid at `tov_us` on the node's clock, sent 30 ms later, moving at `u`
/// mm/s; its CRC-8 and CR LF.
fn wrz(tov_us: u64, u_mm_s: i32) -> String {
    let tov = 1_767_225_600_000_000 + tov_us;
    let body = format!(
        "wrz,{}.{:03},0.000,0.000,y,3.20,0.010,1e-4;0;0;0;1e-4;0;0;0;1e-4,{tov},{},100.00,0",
        u_mm_s / 1000,
        u_mm_s % 1000,
        tov + 30_000
    );
    let crc = crate::sensors::dvl::a50::CRC8.checksum(body.as_bytes());
    format!("{body}*{crc:02x}\r\n")
}

#[test]
fn the_nodes_dvl_reaches_the_topsides_sensors_through_the_link() {
    use crate::sensors::dvl::{a50::VelocityGate, DvlPort, WithDvl};
    let bridge = NodeBridge::new(20_000);
    let top_port = Port::default();
    let node_port = top_port.other_end();
    let mut link = TopsideLink::new(&bridge, top_port, TopsideConfig::new(SESSION));
    let clock = Clock::default();
    let t = clock.0.clone();
    t.set(1_000_000);
    let uart = DvlUart::default();
    let sensors = WithDvl {
        inner: NodeImu,
        dvl: DvlPort::new(uart.clone(), VelocityGate::default(), 87).with_poll_limits(64, 1),
    };
    let escs = [Esc::default(), Esc::default(), Esc::default()];
    let mut node = Node::new(escs, node_port, clock, sensors, NodeConfig::DEFAULT).unwrap();
    let mut top = bridge.sensors();
    let mut fixes = Vec::new();
    let mut sent = Vec::new();
    // 2 s, both loops every 100 us (the node's IMU at 400 Hz); a line every 100 ms, whole,
    // its time of validity 30 ms before its sending and its wire time (87 us a byte) before
    // its arrival now.
    for i in 0..20_000u64 {
        let now = 1_000_000 + i * 100;
        t.set(now);
        if i % 1_000 == 500 {
            let u = 100 + (i / 1_000) as i32;
            let wire_us = 87 * wrz(now, u).len() as u64;
            let tov = now - 30_000 - wire_us;
            let line = wrz(tov, u);
            sent.push((tov, u));
            uart.0.borrow_mut().extend(line.bytes());
        }
        node.tick();
        link.poll(now, false);
        if let Some(f) = top.dvl(now) {
            fixes.push((now, f));
        }
        link.send_if_due(now, false);
    }
    assert_eq!(fixes.len(), sent.len());
    assert_eq!(link.counters().dvl_fixes as usize, sent.len());
    let mut worst = 0_i64;
    for ((_, f), (tov, u)) in fixes.iter().zip(&sent) {
        assert_eq!(f.velocity_m_s, [*u as f32 / 1e3, 0.0]);
        worst = worst.max((f.t_us as i64 - *tov as i64).abs());
    }
    // The stamp: the node's time of validity on the IMU's timeline (arrival stamps: the
    // newest sample's age, up to an IMU period), to the millisecond, and the node's two
    // 100 us passes that read the line (64 bytes a pass).
    println!("worst stamp error {worst} us");
    assert!(worst <= 2_500 + 500 + 200, "{worst} us");
}
