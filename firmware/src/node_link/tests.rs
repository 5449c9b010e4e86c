use super::*;
use crate::protocol::{encode_with_version, DropReason};

fn largest_downlink() -> Downlink {
    Downlink {
        session: u32::MAX,
        seq: u64::MAX,
        pulse_us: [u16::MAX; 3],
        ttl_ms: u8::MAX,
        arm: ArmCommand::Armed,
        t_us: u32::MAX,
    }
}

fn largest_uplink() -> Uplink {
    Uplink {
        session: u32::MAX,
        echo_seq: u16::MAX,
        echo_t_us: u32::MAX,
        imu_age_us: u32::MAX,
        dt_us: u32::MAX,
        samples: u16::MAX,
        delta_angle_rad: [f32::MAX; 3],
        delta_velocity_m_s: [f32::MIN; 3],
        pressure_pa: f32::NAN,
        pressure_count: u8::MAX,
        status: u8::MAX,
        counters: NodeCounters {
            accepted: u16::MAX,
            corrupt: u16::MAX,
            replayed: u16::MAX,
            out_of_range: u16::MAX,
            foreign: u16::MAX,
            version: u16::MAX,
            ttl_expired: u16::MAX,
            imu_errors: u16::MAX,
            dvl_refused: u8::MAX,
        },
        dvl: Some(UplinkDvl {
            age_ms: u16::MAX,
            velocity_mm_s: [i16::MIN, i16::MIN],
            std_mm_s: u8::MAX,
        }),
    }
}

fn frame_of<M: Serialize>(seq: u16, msg: &M) -> heapless::Vec<u8, MAX_FRAME_LEN> {
    let mut out = [0u8; MAX_FRAME_LEN];
    let f = seal(seq, msg, &mut out).unwrap();
    heapless::Vec::from_slice(f).unwrap()
}

fn decode_all<M: DeserializeOwnedDebug>(d: &mut LinkDecoder<M>, bytes: &[u8]) -> Vec<LinkFrame<M>> {
    bytes.iter().filter_map(|&b| d.push(b)).collect()
}

trait DeserializeOwnedDebug: serde::de::DeserializeOwned + core::fmt::Debug {}
impl<T: serde::de::DeserializeOwned + core::fmt::Debug> DeserializeOwnedDebug for T {}

#[test]
fn largest_messages_fit_their_frame_lengths() {
    let down = frame_of(u16::MAX, &largest_downlink());
    let up = frame_of(u16::MAX, &largest_uplink());
    // The computed bounds allow the envelope's session its 5 varint bytes; the
    // node link sends 0 there (one byte): the frames are within the bound by that slack.
    assert!(down.len() <= MAX_DOWNLINK_FRAME_LEN, "{}", down.len());
    assert!(up.len() <= MAX_UPLINK_FRAME_LEN, "{}", up.len());
    assert!(MAX_DOWNLINK_FRAME_LEN - down.len() <= 5);
    assert!(MAX_UPLINK_FRAME_LEN - up.len() <= 5);
    // The DVL's velocity keeps the uplink within its budget (docs/drivers.md): 109 B.
    const { assert!(MAX_UPLINK_FRAME_LEN <= 109) };
    assert!(up.len() <= 109, "{}", up.len());
    let without = frame_of(
        u16::MAX,
        &Uplink {
            dvl: None,
            ..largest_uplink()
        },
    );
    // `Some` at its largest less `None` (its tag alone).
    assert_eq!(
        up.len() - without.len(),
        10,
        "the DVL's velocity at its largest"
    );
    println!(
        "largest downlink frame {} B (bound {MAX_DOWNLINK_FRAME_LEN}), uplink {} B (bound {MAX_UPLINK_FRAME_LEN})",
        down.len(),
        up.len()
    );
}

#[test]
fn both_directions_at_50_hz_keep_the_115200_link_at_most_half_busy() {
    let down_us = wire_time_us(MAX_DOWNLINK_FRAME_LEN, LINK_BAUD);
    let up_us = wire_time_us(MAX_UPLINK_FRAME_LEN, LINK_BAUD);
    // Full duplex: each direction has the whole period; the busier one is the uplink.
    const { assert!(LINK_PERIOD_US <= 20_000, "at least 50 Hz") };
    assert!(
        2 * up_us <= LINK_PERIOD_US,
        "uplink {up_us} us a {LINK_PERIOD_US} us period"
    );
    assert!(2 * down_us <= LINK_PERIOD_US, "downlink {down_us} us");
    // And both in one half-duplex period (an RS-485 pair) still fit.
    assert!(down_us + up_us <= LINK_PERIOD_US);
    println!(
        "wire time at {LINK_BAUD} Bd: downlink {down_us} us ({:.1} %), uplink {up_us} us ({:.1} %)",
        100.0 * f64::from(down_us) / f64::from(LINK_PERIOD_US),
        100.0 * f64::from(up_us) / f64::from(LINK_PERIOD_US)
    );
}

#[test]
fn wire_time_is_ten_bits_a_byte() {
    assert_eq!(wire_time_us(1, 115_200), 87); // 86.8 us rounded up
    assert_eq!(wire_time_us(1152, 115_200), 100_000);
    assert_eq!(wire_time_us(10, 0), 100_000_000);
}

#[test]
fn frames_round_trip_in_a_stream() {
    let mut d = LinkDecoder::<Downlink>::new();
    let a = largest_downlink();
    let b = Downlink {
        session: 7,
        seq: 1,
        pulse_us: [1500, 1100, 1900],
        ttl_ms: 60,
        arm: ArmCommand::Disarmed,
        t_us: 0,
    };
    let mut stream = frame_of(3, &a).to_vec();
    stream.extend_from_slice(&frame_of(4, &b));
    let got = decode_all(&mut d, &stream);
    assert_eq!(
        got,
        vec![
            LinkFrame::Frame { seq: 3, msg: a },
            LinkFrame::Frame { seq: 4, msg: b }
        ]
    );
    assert_eq!(d.frames, 2);

    let mut u = LinkDecoder::<Uplink>::new();
    let up = Uplink {
        pressure_pa: 101_325.0,
        ..largest_uplink()
    };
    let got = decode_all(&mut u, &frame_of(9, &up));
    assert_eq!(got, vec![LinkFrame::Frame { seq: 9, msg: up }]);
}

#[test]
fn every_flipped_bit_is_dropped_and_counted() {
    let msg = Downlink {
        session: 0x1234_5678,
        seq: 1,
        pulse_us: [1600, 1400, 1500],
        ttl_ms: 50,
        arm: ArmCommand::Armed,
        t_us: 123_456,
    };
    let frame = frame_of(1, &msg);
    let inner = frame.len() - 2;
    for i in 1..=inner {
        for bit in 0..8 {
            let mut f = frame.clone();
            f[i] ^= 1 << bit;
            let mut d = LinkDecoder::<Downlink>::new();
            let got = decode_all(&mut d, &f);
            assert!(
                got.iter().all(|g| !matches!(g, LinkFrame::Frame { .. })),
                "byte {i} bit {bit}: {got:?}"
            );
            assert_eq!(d.frames, 0);
            assert!(d.dropped.total() >= 1 || got.is_empty());
        }
    }
}

#[test]
fn another_version_is_dropped_as_version() {
    let mut out = [0u8; MAX_FRAME_LEN];
    let msg = largest_downlink();
    let f = encode_with_version(NODE_LINK_VERSION + 1, 0, 1, &msg, &mut out).unwrap();
    let mut d = LinkDecoder::<Downlink>::new();
    assert_eq!(
        decode_all(&mut d, f),
        vec![LinkFrame::Dropped(DropReason::Version)]
    );
    assert_eq!(d.dropped.version, 1);
    // A tether frame (the tether's version) on the node link is refused the same way.
    let f = crate::protocol::encode(0, 1, &msg, &mut out).unwrap();
    assert_eq!(
        decode_all(&mut d, f),
        vec![LinkFrame::Dropped(DropReason::Version)]
    );
}

#[test]
fn garbage_and_overlong_frames_resynchronize() {
    let msg = Downlink {
        session: 1,
        seq: 1,
        pulse_us: [1500; 3],
        ttl_ms: 100,
        arm: ArmCommand::Disarmed,
        t_us: 1,
    };
    let mut d = LinkDecoder::<Downlink>::new();
    let mut stream = vec![0x55u8; 3 * MAX_LINK_FRAME_LEN];
    stream.extend_from_slice(&frame_of(2, &msg));
    let got = decode_all(&mut d, &stream);
    assert_eq!(
        got,
        vec![
            LinkFrame::Dropped(DropReason::Overflow),
            LinkFrame::Frame { seq: 2, msg }
        ]
    );
    // An uplink is not a downlink: CRC good, message malformed.
    let mut d = LinkDecoder::<Downlink>::new();
    let got = decode_all(&mut d, &frame_of(2, &largest_uplink()));
    assert_eq!(got, vec![LinkFrame::Dropped(DropReason::Malformed)]);
    // Cut short: a too-short frame.
    let mut d = LinkDecoder::<Downlink>::new();
    let got = decode_all(&mut d, &[0, 3, 1, 2, 0]);
    assert!(matches!(got.as_slice(), [LinkFrame::Dropped(_)]), "{got:?}");
}

#[test]
fn a_downlink_sequence_is_taken_only_above_the_last_one_at_any_distance() {
    assert!(seq_after(0, None));
    assert!(seq_after(u64::MAX, None));
    assert!(seq_after(1, Some(0)));
    assert!(!seq_after(5, Some(5)));
    for back in [
        1u64,
        0x7fff,
        0x8000,
        0x8001,
        0xffff,
        0x1_0000,
        1 << 32,
        (1 << 40) + 3,
    ] {
        let last = (1u64 << 48) + 17;
        assert!(!seq_after(last - back, Some(last)), "{back} back");
        assert!(seq_after(last + back, Some(last)), "{back} ahead");
    }
    assert_eq!(low_16(0x1_2345), 0x2345);
}

#[test]
fn uplink_sequence_order_wraps() {
    assert!(seq_newer(1, 0));
    assert!(seq_newer(0, u16::MAX));
    assert!(!seq_newer(5, 5));
    assert!(!seq_newer(4, 5));
    assert!(!seq_newer(5 + 0x8000, 5));
    assert!(seq_newer(5 + 0x7fff, 5));
}

#[test]
fn esc_range_is_the_controllers() {
    let map = controller_core::params::PulseCurve::STANDARD;
    assert_eq!(f32::from(ESC_NEUTRAL_US), map.neutral_us);
    assert_eq!(f32::from(ESC_MIN_US), map.min_us);
    assert_eq!(f32::from(ESC_MAX_US), map.max_us);
}

#[test]
fn the_default_link_period_follows_the_rate() {
    // 115,200 Bd: 5 and 10 ms would be over half busy; the images' 20 ms.
    assert_eq!(default_link_period_us(115_200), 20_000);
    assert!(busy_per_mille(10_000, 115_200) > 500);
    // 1 Mbd: 5 ms (the 108-byte uplink with the DVL's velocity takes 1.08 ms of it).
    assert_eq!(default_link_period_us(1_000_000), 5_000);
    assert_eq!(busy_per_mille(5_000, 1_000_000), 216);
    // A rate too slow for any: 20 ms, which the check then refuses.
    assert_eq!(default_link_period_us(9_600), 20_000);
    assert_eq!(
        check_link_period(20_000, 2_500, 9_600),
        Err(LinkPeriodError::OverHalfBusy)
    );
}

#[test]
fn a_link_period_is_refused_below_the_imu_period_above_half_busy_or_below_50_hz() {
    assert_eq!(check_link_period(20_000, 2_500, 115_200), Ok(()));
    // The shortest at 115,200 Bd within half busy: 18.75 ms (53 Hz; twice the 108-byte
    // uplink's 9.375 ms); in IMU periods, 20 ms.
    assert_eq!(check_link_period(18_750, 2_500, 115_200), Ok(()));
    for short in [18_749, 17_500, 15_000] {
        assert_eq!(
            check_link_period(short, 2_500, 115_200),
            Err(LinkPeriodError::OverHalfBusy),
            "{short} us"
        );
    }
    assert_eq!(
        check_link_period(2_000, 2_500, 1_000_000),
        Err(LinkPeriodError::BelowImuPeriod)
    );
    assert_eq!(check_link_period(2_500, 2_500, 1_000_000), Ok(()));
    assert_eq!(
        check_link_period(25_000, 2_500, 115_200),
        Err(LinkPeriodError::Below50Hz)
    );
}

#[test]
fn a_dvl_velocity_round_trips_in_millimetres() {
    use controller_core::nav::DvlFix;
    let fix = DvlFix {
        t_us: 9_950_000,
        velocity_m_s: [0.2504, -1.2346],
        std_m_s: 0.0105,
    };
    let up = UplinkDvl::from_fix(&fix, 10_000_400).unwrap();
    assert_eq!(
        up,
        UplinkDvl {
            age_ms: 50,
            velocity_mm_s: [250, -1235],
            std_mm_s: 11,
        }
    );
    let back = up.to_fix(5_000_000);
    assert_eq!(back.t_us, 5_000_000);
    for (a, b) in back.velocity_m_s.iter().zip(fix.velocity_m_s) {
        assert!((a - b).abs() <= 0.5e-3 + 1e-6, "{back:?}");
    }
    assert!((back.std_m_s - fix.std_m_s).abs() <= 0.5e-3 + 1e-6);
    // In a frame, both ways through the decoder.
    let msg = Uplink {
        dvl: Some(up),
        pressure_pa: 101_325.0,
        ..largest_uplink()
    };
    let mut d = LinkDecoder::<Uplink>::new();
    assert_eq!(
        decode_all(&mut d, &frame_of(1, &msg)),
        vec![LinkFrame::Frame { seq: 1, msg }]
    );
    // A figure of merit of 0 is the resolution, 1 mm/s, for the estimator.
    let zero = UplinkDvl { std_mm_s: 0, ..up };
    assert_eq!(zero.to_fix(0).std_m_s, 1e-3);
}

#[test]
fn a_dvl_velocity_that_does_not_fit_is_not_sent() {
    use controller_core::nav::DvlFix;
    let ok = DvlFix {
        t_us: 1_000,
        velocity_m_s: [20.0, -20.0],
        std_m_s: MAX_UPLINK_DVL_STD_M_S,
    };
    assert!(UplinkDvl::from_fix(&ok, 1_000).is_some());
    let bad = [
        DvlFix {
            velocity_m_s: [f32::NAN, 0.0],
            ..ok
        },
        DvlFix {
            velocity_m_s: [0.0, 32.8],
            ..ok
        },
        DvlFix {
            std_m_s: 0.256,
            ..ok
        },
        DvlFix {
            std_m_s: -0.002,
            ..ok
        },
    ];
    for f in bad {
        assert_eq!(UplinkDvl::from_fix(&f, 2_000), None, "{f:?}");
    }
    // Stamped after the sealing, or older than 65.5 s.
    assert_eq!(UplinkDvl::from_fix(&ok, 999), None);
    assert_eq!(UplinkDvl::from_fix(&ok, 1_000 + 65_536_000), None);
    assert!(UplinkDvl::from_fix(&ok, 1_000 + 65_535_000).is_some());
}
