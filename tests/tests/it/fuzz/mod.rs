//! Fuzzing the tether decoder and the application's receive path.
//!
//! Each input is a byte stream made of segments: valid frames, random garbage (zeros
//! included), valid frames with a bit flipped, truncated frames and oversize runs. Checked:
//! no panic; the frames accepted are exactly the valid frames, in order (every valid frame
//! recovered, no corrupted frame accepted); oversize runs are counted as overflows; the
//! application fed the same streams keeps its pulses within 1100-1900 us. The decoder is
//! fuzzed byte by byte (`push`) and in uneven slices (`push_slice`, the firmware loop's path),
//! which must agree exactly.
//!
//! `cargo test` runs 256 inputs per property. The long run (the figure in docs/protocol.md):
//! `FUZZ_CASES=1000000 cargo test -p rov-tests --release --test it fuzz:: -- --nocapture`.

// Test code: a failed expectation should stop the test.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

mod million;

use controller_core::controller::Gains;
use controller_core::nav::compass_cal::CompassCalibration;
use controller_core::nav::onboard::OnboardConfig;
use controller_core::nav::{DvlFix, HeadingFix, ImuSample, NavHealth, PositionFix};
use controller_core::params::VehicleParams;
use controller_core::reference::{PaperPolynomial, Reference};
use controller_core::state::NavState;
use firmware::protocol::{
    encode, Board, Command, Decoded, FrameDecoder, Law, ManualThrust, Mode, NavSample, Plane,
    MAX_ENCODED_LEN, MAX_FRAME_LEN,
};
use firmware::{Config, Failsafe};
use proptest::prelude::*;
use proptest::test_runner::{Config as PtConfig, TestRunner};
use rov_tests::{app, pulses_us, Topside};

fn cases() -> u32 {
    std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(256)
}

fn finite() -> impl Strategy<Value = f32> {
    -1.0e4f32..1.0e4
}

fn nav_state() -> impl Strategy<Value = NavState> {
    proptest::array::uniform12(finite()).prop_map(|a| NavState {
        x_m: a[0],
        y_m: a[1],
        z_m: a[2],
        roll_rad: a[3],
        pitch_rad: a[4],
        yaw_rad: a[5],
        u_m_s: a[6],
        v_m_s: a[7],
        w_m_s: a[8],
        p_rad_s: a[9],
        q_rad_s: a[10],
        r_rad_s: a[11],
    })
}

fn mode() -> impl Strategy<Value = Mode> {
    let plane = prop_oneof![Just(Plane::Xz), Just(Plane::Xy), Just(Plane::ThreeD)];
    let law = prop_oneof![Just(Law::Paper), Just(Law::Tracking)];
    prop_oneof![
        Just(Mode::Idle),
        Just(Mode::Manual),
        Just(Mode::Hold),
        Just(Mode::Stabilize),
        Just(Mode::DepthHold),
        (plane, law).prop_map(|(plane, law)| Mode::Track { plane, law }),
    ]
}

fn command() -> impl Strategy<Value = Command> {
    prop_oneof![
        any::<u64>().prop_map(|t_us| Command::Heartbeat { t_us }),
        Just(Command::Arm),
        Just(Command::Disarm),
        mode().prop_map(Command::SetMode),
        (any::<u64>(), nav_state())
            .prop_map(|(t_us, state)| Command::Nav(NavSample { t_us, state })),
        (-1.5f32..1.5, -1.5f32..1.5, -1.5f32..1.5).prop_map(|(surge, yaw, heave)| {
            Command::ManualThrust(ManualThrust { surge, yaw, heave })
        }),
        (finite(), finite(), any::<Option<u64>>()).prop_map(|(h, t, start_us)| {
            Command::SetReference {
                reference: Reference::Paper(PaperPolynomial { h_r_m: h, t_f_s: t }),
                start_us,
            }
        }),
        (finite(), finite(), finite()).prop_map(|(x, y, z)| Command::SetReference {
            reference: Reference::Hold { pos_m: [x, y, z] },
            start_us: None,
        }),
        finite().prop_map(|k| {
            let g = Gains::default();
            let mut xy = g.paper_xy;
            xy.k = k;
            Command::SetPaperGains { xz: g.paper_xz, xy }
        }),
        finite().prop_map(|k| {
            let mut t = Gains::default().tracking;
            t.xy_kp = k;
            Command::SetTrackingGains(t)
        }),
        nav_commands(),
    ]
}

/// The on-board estimator's messages, with any values, NaN and infinities too.
fn nav_commands() -> impl Strategy<Value = Command> {
    let any_f = || any::<f32>();
    prop_oneof![
        (any::<u64>(), nav_state(), any_f()).prop_map(|(t_us, initial, n)| {
            let mut config = OnboardConfig::default();
            config.nav.gyro_noise_rad_s_sqrt_hz = n;
            Command::StartNav {
                t_us,
                initial,
                config,
            }
        }),
        prop_oneof![
            Just(Command::StopNav),
            // The compass calibration: `COMPASS_DEV_*` and the flown turn.
            (any_f(), any_f()).prop_map(|(sin_rad, cos_rad)| {
                Command::SetCompassCal(CompassCalibration { sin_rad, cos_rad })
            }),
            (any_f(), any_f()).prop_map(|(yaw_rate_rad_s, time_limit_s)| {
                Command::StartCompassCal {
                    yaw_rate_rad_s,
                    time_limit_s,
                }
            }),
        ],
        (any::<u64>(), proptest::array::uniform6(any_f())).prop_map(|(t_us, v)| {
            Command::Imu(ImuSample {
                t_us,
                gyro_rad_s: [v[0], v[1], v[2]],
                accel_m_s2: [v[3], v[4], v[5]],
            })
        }),
        (any::<u64>(), any_f())
            .prop_map(|(t_us, pressure_pa)| Command::Pressure { t_us, pressure_pa }),
        (any::<u64>(), any_f(), any_f(), any_f()).prop_map(|(t_us, n, e, s)| {
            Command::UsblFix(PositionFix {
                t_us,
                north_m: n,
                east_m: e,
                std_m: s,
            })
        }),
        (any::<u64>(), any_f(), any_f(), any_f()).prop_map(|(t_us, u, v, s)| {
            Command::DvlFix(DvlFix {
                t_us,
                velocity_m_s: [u, v],
                std_m_s: s,
            })
        }),
        (any::<u64>(), any_f(), any_f()).prop_map(|(t_us, y, s)| {
            Command::Compass(HeadingFix {
                t_us,
                yaw_rad: y,
                std_rad: s,
            })
        }),
        any::<u64>().prop_map(|t_us| Command::Step { t_us }),
        (any_f(), any_f()).prop_map(|(mass, buoy)| {
            let mut p = VehicleParams::OBSERVER;
            p.mass_kg = mass;
            p.buoyancy_offset_n = buoy;
            Command::SetVehicle(p)
        }),
        proptest::array::uniform4(any::<u64>()).prop_map(|t| {
            Command::SetFailsafe(Failsafe {
                heartbeat_neutral_us: t[0],
                heartbeat_disarm_us: t[1],
                nav_stale_us: t[2],
                manual_stale_us: t[3],
            })
        }),
    ]
}

#[derive(Debug, Clone)]
enum Segment {
    Valid(Command),
    Garbage(Vec<u8>),
    BitFlip(Command, usize, u8),
    Truncated(Command, usize),
    Oversize(usize, u8),
}

fn segment() -> impl Strategy<Value = Segment> {
    prop_oneof![
        4 => command().prop_map(Segment::Valid),
        2 => proptest::collection::vec(any::<u8>(), 0..64).prop_map(Segment::Garbage),
        2 => (command(), any::<usize>(), 0u8..8).prop_map(|(c, i, b)| Segment::BitFlip(c, i, 1 << b)),
        1 => (command(), any::<usize>()).prop_map(|(c, i)| Segment::Truncated(c, i)),
        1 => ((MAX_ENCODED_LEN + 1)..(2 * MAX_ENCODED_LEN), 1u8..=255).prop_map(|(n, f)| Segment::Oversize(n, f)),
    ]
}

fn frame(session: u32, seq: u16, c: &Command) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    encode(session, seq, c, &mut buf)
        .expect("every command fits")
        .to_vec()
}

/// The stream (frames of `session`, numbered from 1), the valid frames it holds in order,
/// and how many oversize runs.
fn build(session: u32, segs: &[Segment]) -> (Vec<u8>, Vec<(u16, Command)>, u32) {
    let mut bytes = Vec::new();
    let mut valid = Vec::new();
    let mut oversize = 0;
    let frame = |seq, c: &Command| frame(session, seq, c);
    for (i, s) in segs.iter().enumerate() {
        let seq = i as u16 + 1;
        match s {
            Segment::Valid(c) => {
                bytes.extend(frame(seq, c));
                valid.push((seq, *c));
            }
            Segment::Garbage(g) => bytes.extend(g),
            Segment::BitFlip(c, at, mask) => {
                let mut f = frame(seq, c);
                let n = f.len();
                f[at % n] ^= mask;
                bytes.extend(f);
            }
            Segment::Truncated(c, at) => {
                let f = frame(seq, c);
                // Everything but the final delimiter, at most, then one byte other than the
                // frame's next one: without it the following segment could, by chance, start
                // with exactly the missing bytes and make the frame whole and valid (seen once
                // in a million inputs: a garbage byte equal to the one cut off).
                let cut = at % (f.len() - 1);
                bytes.extend(&f[..cut]);
                bytes.push(f[cut] ^ 0x80);
            }
            Segment::Oversize(n, fill) => {
                bytes.extend(std::iter::repeat_n(*fill, *n));
                bytes.push(0);
                oversize += 1;
            }
        }
    }
    (bytes, valid, oversize)
}

#[test]
fn decoder_recovers_every_valid_frame_and_accepts_nothing_else() {
    let mut runner = TestRunner::new(PtConfig {
        cases: cases(),
        failure_persistence: None,
        ..PtConfig::default()
    });
    let stats = std::cell::Cell::new((0u64, 0u64, 0u64, 0u64));
    let r = runner.run(&proptest::collection::vec(segment(), 1..12), |segs| {
        let (bytes, valid, oversize) = build(7, &segs);
        let mut d = FrameDecoder::<Command>::new();
        let mut got = Vec::new();
        for b in &bytes {
            if let Some(Decoded::Frame { seq, msg, .. }) = d.push(*b) {
                got.push((seq, msg));
            }
        }
        prop_assert_eq!(&got, &valid);
        prop_assert!(d.dropped.overflow >= oversize);
        prop_assert_eq!(d.frames as usize, valid.len());
        // The slice path (what the firmware's loop uses) in uneven chunks: the same frames
        // and the same drop counts as byte by byte.
        let mut s = FrameDecoder::<Command>::new();
        let mut got_s = Vec::new();
        for chunk in bytes.chunks(1 + segs.len() * 7 % 61) {
            let mut rest = chunk;
            while !rest.is_empty() {
                if let Some(Decoded::Frame { seq, msg, .. }) = s.push_slice(&mut rest) {
                    got_s.push((seq, msg));
                }
            }
        }
        prop_assert_eq!(&got_s, &valid);
        prop_assert_eq!(s.dropped, d.dropped);
        prop_assert_eq!(s.frames, d.frames);
        let (i, f, v, dr) = stats.get();
        stats.set((
            i + 1,
            f + segs.len() as u64,
            v + valid.len() as u64,
            dr + u64::from(d.dropped.total()),
        ));
        Ok(())
    });
    let (inputs, segments, valid, dropped) = stats.get();
    println!(
        "decoder fuzz: {inputs} inputs, {segments} segments, {valid} valid frames all recovered, \
         {dropped} frames dropped, 0 corrupted accepted"
    );
    if let Err(e) = r {
        panic!("{e}");
    }
}

#[test]
fn app_survives_any_byte_stream() {
    let mut runner = TestRunner::new(PtConfig {
        cases: (cases() / 16).max(32),
        failure_persistence: None,
        ..PtConfig::default()
    });
    let r = runner.run(&proptest::collection::vec(segment(), 1..24), |segs| {
        for cfg in [
            Config::lockstep(Board::Host),
            Config::fixed_rate(Board::Host),
        ] {
            let (mut a, c) = app(cfg);
            let mut top = Topside::default();
            top.open(&mut a);
            let (bytes, _valid, _) = build(top.session(), &segs);
            for chunk in bytes.chunks(37) {
                a.parts_mut().1.rx.extend(chunk);
                c.advance_us(7_000);
                a.tick();
                for p in pulses_us(&mut a) {
                    prop_assert!((1100.0..=1900.0).contains(&p));
                }
                let lim = *a.autopilot().controller().limits();
                for f in a.last_output().allocation.thrust_n {
                    prop_assert!(f <= lim.max_forward_n && f >= -lim.max_reverse_n);
                }
            }
        }
        Ok(())
    });
    if let Err(e) = r {
        panic!("{e}");
    }
}

/// Bounds of the frame format: the largest messages fit, a frame never exceeds
/// `MAX_FRAME_LEN`, and the receive buffer takes any valid frame.
#[test]
fn largest_messages_fit() {
    use firmware::protocol::{Reply, Status, Telemetry, MAX_PAYLOAD_LEN};
    let big = Telemetry {
        t_us: u64::MAX,
        nav_seq: u16::MAX,
        loop_ticks: u32::MAX,
        faults: u16::MAX,
        pulse_us: [u16::MAX; 3],
        mode: Mode::Track {
            plane: Plane::ThreeD,
            law: Law::Tracking,
        },
        nav_pos_std_m: [f32::MAX; 3],
        ..Telemetry::default()
    };
    let big_cal = CompassCalibration {
        sin_rad: f32::MAX,
        cos_rad: f32::MAX,
    };
    let big_status = Status {
        compass_cal: big_cal,
        // The largest outcome: flying, with its time.
        ident: firmware::protocol::IdentOutcome::Flying {
            elapsed_s: f32::MAX,
        },
        // The largest outcome: a calibration and a residual.
        compass_swing: firmware::compass_swing::SwingOutcome::Accepted {
            cal: big_cal,
            residual_rad: f32::MAX,
        },
        nav_health: NavHealth {
            imu_samples: u32::MAX,
            depth_fused: u32::MAX,
            heading_fused: u32::MAX,
            dvl_fused: u32::MAX,
            position_fused: u32::MAX,
            position_outliers: u32::MAX,
            other_outliers: u32::MAX,
            invalid: u32::MAX,
            resets: u32::MAX,
        },
        t_us: u64::MAX,
        heartbeat_seq: u16::MAX,
        nav_t_us: u64::MAX,
        steps: u32::MAX,
        loop_ticks_max: u32::MAX,
        overruns: u32::MAX,
        control_late_max_us: u32::MAX,
        faults: u16::MAX,
        battery: firmware::protocol::BatteryStatus {
            voltage_v: f32::MAX,
            current_a: f32::MAX,
            consumed_mah: f32::MAX,
            remaining_pct: f32::MAX,
            time_remaining_s: f32::MAX,
        },
        link: firmware::protocol::LinkStats {
            rx_frames: u32::MAX,
            tx_frames: u32::MAX,
            nacks: u32::MAX,
            tx_dropped: u32::MAX,
            no_session: u32::MAX,
            replayed: u32::MAX,
            dropped: firmware::protocol::DropCounters {
                overflow: u32::MAX,
                cobs: u32::MAX,
                too_short: u32::MAX,
                crc: u32::MAX,
                version: u32::MAX,
                malformed: u32::MAX,
            },
        },
    };
    println!(
        "size of the application state (host fakes): {} B, decoder {} B",
        std::mem::size_of::<rov_tests::TestApp>(),
        std::mem::size_of::<FrameDecoder<Command>>()
    );
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(u32::MAX, u16::MAX, &Reply::Telemetry(big), &mut buf)
        .unwrap()
        .len();
    println!(
        "largest telemetry frame: {n} bytes (max {MAX_FRAME_LEN}, payload max {MAX_PAYLOAD_LEN})"
    );
    assert!(n <= MAX_FRAME_LEN);
    let n = encode(u32::MAX, u16::MAX, &Reply::Status(big_status), &mut buf)
        .unwrap()
        .len();
    println!("largest status frame: {n} bytes");
    assert!(n <= MAX_FRAME_LEN);
    let worst_cmds = [
        Command::SetPaperGains {
            xz: Gains::default().paper_xz,
            xy: Gains::default().paper_xy,
        },
        Command::SetTrackingGains(Gains::default().tracking),
        Command::SetVehicle(VehicleParams::OBSERVER),
        Command::SetFailsafe(Failsafe {
            heartbeat_neutral_us: u64::MAX,
            heartbeat_disarm_us: u64::MAX,
            nav_stale_us: u64::MAX,
            manual_stale_us: u64::MAX,
        }),
        Command::StartNav {
            t_us: u64::MAX,
            initial: NavState::default(),
            config: OnboardConfig {
                imu_timeout_us: u32::MAX,
                pressure_timeout_us: u32::MAX,
                ..OnboardConfig::default()
            },
        },
        Command::Nav(NavSample {
            t_us: u64::MAX,
            state: NavState::default(),
        }),
        Command::SetReference {
            reference: Reference::Lawnmower {
                start_m: [0.0; 3],
                heading_rad: 0.0,
                leg_length_m: 0.0,
                spacing_m: 0.0,
                legs: u16::MAX,
                speed_m_s: 0.0,
            },
            start_us: Some(u64::MAX),
        },
    ];
    for c in worst_cmds {
        let n = encode(u32::MAX, u16::MAX, &c, &mut buf).unwrap().len();
        println!(
            "{}: {n} bytes",
            format!("{c:?}").split('(').next().unwrap_or("")
        );
        assert!(n <= MAX_FRAME_LEN);
    }
}
