//! The protocol's own tests: the bytes on the wire, round trips, the decoder's drops.
#![allow(clippy::unwrap_used, clippy::panic, clippy::indexing_slicing)]

use super::*;
use controller_core::nav::{DvlFix, HeadingFix, ImuSample, PositionFix};
use controller_core::reference::Reference;
use controller_core::state::NavState;

/// The session the frames of these tests carry (two varint bytes: 0xAC 0x02).
const SESSION: u32 = 300;

fn frame(seq: u16, cmd: &Command) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME_LEN];
    encode(SESSION, seq, cmd, &mut out).unwrap().to_vec()
}

#[test]
fn the_bytes_are_postcard_then_crc32_then_cobs_as_in_version_9() {
    // Computed independently (Python: zlib.crc32 and a textbook COBS) from the postcard
    // payloads [9, 7, 0xAC, 0x02, 1] (version 9, seq 7, session 300 as a varint, `Arm` =
    // variant 1) and [9, 42, 0xAC, 0x02, 0, 0xE8, 0x07] (seq 42, `Heartbeat` = variant 0,
    // t_us = 1000 as a varint). Version 6 put the session after the sequence number.
    assert_eq!(
        frame(7, &Command::Arm),
        [0, 10, 9, 7, 172, 2, 1, 197, 91, 182, 195, 0]
    );
    assert_eq!(
        frame(42, &Command::Heartbeat { t_us: 1000 }),
        [0, 5, 9, 42, 172, 2, 7, 232, 7, 166, 234, 222, 185, 0]
    );
}

#[test]
fn every_command_and_reply_round_trips_and_fits() {
    let nav = NavState {
        x_m: 1.5,
        yaw_rad: -3.0,
        r_rad_s: f32::MAX,
        ..NavState::default()
    };
    let commands = [
        Command::Heartbeat { t_us: u64::MAX },
        Command::Arm,
        Command::Disarm,
        Command::SetMode(Mode::Track {
            plane: Plane::ThreeD,
            law: Law::Tracking,
        }),
        Command::SetReference {
            reference: Reference::Lawnmower {
                start_m: [1.0, 2.0, 3.0],
                heading_rad: 0.5,
                leg_length_m: 15.0,
                spacing_m: 5.0,
                legs: u16::MAX,
                speed_m_s: 0.25,
            },
            start_us: Some(u64::MAX),
        },
        Command::Nav(NavSample {
            t_us: u64::MAX,
            state: nav,
        }),
        Command::ManualThrust(ManualThrust {
            surge: 1.0,
            yaw: -1.0,
            heave: 0.5,
        }),
        Command::SetTrackingGains(Default::default()),
        Command::SetPaperGains {
            xz: Default::default(),
            xy: Default::default(),
        },
        Command::StartNav {
            t_us: u64::MAX,
            initial: nav,
            config: Default::default(),
        },
        Command::StopNav,
        Command::Imu(ImuSample {
            t_us: u64::MAX,
            gyro_rad_s: [f32::MAX; 3],
            accel_m_s2: [-9.8; 3],
        }),
        Command::Pressure {
            t_us: u64::MAX,
            pressure_pa: 101_325.0,
        },
        Command::UsblFix(PositionFix {
            t_us: u64::MAX,
            north_m: 1.0,
            east_m: 2.0,
            std_m: 0.3,
        }),
        Command::DvlFix(DvlFix {
            t_us: u64::MAX,
            velocity_m_s: [0.2, -0.1],
            std_m_s: 0.01,
        }),
        Command::Compass(HeadingFix {
            t_us: u64::MAX,
            yaw_rad: 1.0,
            std_rad: 0.02,
        }),
        Command::Step { t_us: u64::MAX },
        Command::SetVehicle(controller_core::params::VehicleParams::OBSERVER),
        Command::SetFailsafe(Failsafe::DEFAULT),
        Command::SetHealth(crate::HealthParams {
            batt_capacity_mah: f32::MAX,
            leak1_pin: i8::MIN,
            ..crate::HealthParams::DEFAULT
        }),
        Command::SetMode(Mode::Surface),
        Command::OpenSession { nonce: u32::MAX },
        Command::SetCompassCal(controller_core::nav::compass_cal::CompassCalibration {
            sin_rad: f32::MAX,
            cos_rad: f32::MIN,
        }),
        Command::SetMode(Mode::Guided),
        Command::GuidedTarget {
            pos_m: [f32::MAX, f32::MIN, f32::MAX],
        },
    ];
    for (i, cmd) in commands.iter().enumerate() {
        let f = frame(u16::MAX - i as u16, cmd);
        assert!(f.len() <= MAX_FRAME_LEN);
        assert_eq!(f.iter().filter(|&&b| b == 0).count(), 2, "{cmd:?}");
        match decode_frame::<Command>(&f) {
            Some(Decoded::Frame { seq, session, msg }) => {
                assert_eq!((seq, session, msg), (u16::MAX - i as u16, SESSION, *cmd));
            }
            other => panic!("{cmd:?}: {other:?}"),
        }
    }
    let mut out = [0u8; MAX_FRAME_LEN];
    let t = Reply::Telemetry(Telemetry {
        t_us: u64::MAX,
        loop_ticks: u32::MAX,
        faults: u16::MAX,
        nav,
        nav_pos_std_m: [f32::MAX; 3],
        dvl: DvlReport {
            t_us: u64::MAX,
            velocity_m_s: [f32::MAX, f32::MIN],
        },
        ..Telemetry::default()
    });
    let f = encode(u32::MAX, 1, &t, &mut out).unwrap().to_vec();
    assert_eq!(
        decode_frame::<Reply>(&f),
        Some(Decoded::Frame {
            seq: 1,
            session: u32::MAX,
            msg: t
        })
    );
    let mut st = Status {
        t_us: u64::MAX,
        nav_t_us: u64::MAX,
        steps: u32::MAX,
        ..Status::default()
    };
    st.nav_health.imu_samples = u32::MAX;
    st.nav_health.resets = u32::MAX;
    st.link.dropped.crc = u32::MAX;
    st.link.replayed = u32::MAX;
    st.link.no_session = u32::MAX;
    st.faults = u16::MAX;
    st.ident = crate::IdentOutcome::Aborted(crate::IdentAbort::DepthBand);
    st.battery = crate::BatteryStatus {
        voltage_v: f32::MAX,
        current_a: f32::MIN,
        consumed_mah: f32::MAX,
        remaining_pct: f32::MAX,
        time_remaining_s: f32::MAX,
    };
    let f = encode(u32::MAX, 2, &Reply::Status(st), &mut out)
        .unwrap()
        .to_vec();
    assert_eq!(
        decode_frame::<Reply>(&f),
        Some(Decoded::Frame {
            seq: 2,
            session: u32::MAX,
            msg: Reply::Status(st)
        })
    );
}

#[test]
fn garbage_truncation_and_corruption_are_dropped_and_counted() {
    let good = frame(5, &Command::Arm);
    let mut d = FrameDecoder::<Command>::new();
    let mut stream = vec![0x11, 0x22, 0x33]; // garbage before a frame
    stream.extend(&good);
    stream.extend(&good[..5]); // a truncated frame, then a whole one
    stream.extend(&good);
    let mut bad_crc = good.clone();
    bad_crc[3] ^= 0x40;
    stream.extend(&bad_crc);
    stream.extend([0, 1, 0]); // COBS of nothing: too short
    stream.extend(std::iter::repeat_n(7u8, 300)); // over-long
    stream.push(0);
    let mut other_version = [0u8; MAX_FRAME_LEN];
    stream.extend(
        encode_with_version(
            PROTOCOL_VERSION + 1,
            SESSION,
            77,
            &Command::Arm,
            &mut other_version,
        )
        .unwrap(),
    );
    let got: Vec<_> = stream.iter().filter_map(|&b| d.push(b)).collect();
    let frames = got
        .iter()
        .filter(|x| {
            matches!(
                x,
                Decoded::Frame {
                    seq: 5,
                    session: SESSION,
                    msg: Command::Arm
                }
            )
        })
        .count();
    assert_eq!(frames, 2);
    assert_eq!(d.frames, 2);
    // The garbage and the truncated frame are not even valid COBS (their first code byte
    // points past their end); the flipped bit is.
    assert_eq!(d.dropped.cobs, 2, "{:?}", d.dropped);
    assert_eq!(d.dropped.crc, 1);
    assert_eq!(d.dropped.too_short, 1);
    assert_eq!(d.dropped.overflow, 1);
    assert_eq!(d.dropped.version, 1);
    assert!(got.contains(&Decoded::Dropped {
        reason: DropReason::Version,
        seq: Some(77)
    }));
    assert_eq!(d.dropped.total(), 6);
}

#[test]
fn a_good_crc_on_a_bad_payload_is_malformed_with_its_sequence_number() {
    // This version, seq 9, session 1, variant 200 (no such command), with a correct CRC.
    let payload = [PROTOCOL_VERSION, 9, 1, 200, 1];
    let mut body = payload.to_vec();
    body.extend(CRC.checksum(&payload).to_le_bytes());
    let mut f = vec![0u8; 32];
    let n = cobs::encode(&body, &mut f[1..]);
    f.truncate(n + 2);
    f[n + 1] = 0;
    assert_eq!(
        decode_frame::<Command>(&f),
        Some(Decoded::Dropped {
            reason: DropReason::Malformed,
            seq: Some(9)
        })
    );
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(500))]

    /// Slices of any size give the same results and counts as byte by byte.
    #[test]
    fn push_slice_equals_push(
        chunks in proptest::collection::vec(proptest::collection::vec(0u8..4, 0..40), 0..20),
        cut in 1usize..50,
    ) {
        let good = frame(3, &Command::Disarm);
        let mut stream = Vec::new();
        for c in &chunks {
            stream.extend(c);
            stream.extend(&good);
        }
        let mut a = FrameDecoder::<Command>::new();
        let want: Vec<_> = stream.iter().filter_map(|&b| a.push(b)).collect();
        let mut b = FrameDecoder::<Command>::new();
        let mut got = Vec::new();
        for part in stream.chunks(cut) {
            let mut rest = part;
            while !rest.is_empty() {
                if let Some(x) = b.push_slice(&mut rest) {
                    got.push(x);
                }
            }
        }
        proptest::prop_assert_eq!(got, want);
        proptest::prop_assert_eq!(a.frames, b.frames);
        proptest::prop_assert_eq!(a.dropped, b.dropped);
    }
}
