//! The node's DVL velocity on the topside: stamped on the IMU samples' timeline, given
//! once, counted; the node's refusals summed across the wrap of its count.

use super::*;

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
