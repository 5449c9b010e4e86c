//! A million inputs of each kind: absurd commands and corrupted frames from a seeded
//! xorshift generator, fed to the decoder and the application.

use super::*;

/// xorshift64*: fast, seeded, reproducible (the inputs are the same on every run).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }

    fn byte(&mut self) -> u8 {
        self.next() as u8
    }

    /// Half of the time a plausible value, else any bit pattern (NaN, infinities, 1e38...).
    fn f32(&mut self) -> f32 {
        match self.below(4) {
            0 => f32::from_bits(self.next() as u32),
            1 => [
                f32::NAN,
                f32::INFINITY,
                -f32::INFINITY,
                1e30,
                -1e30,
                f32::MAX,
            ][self.below(6)],
            _ => (self.next() % 20_001) as f32 * 1e-3 - 10.0,
        }
    }

    fn f3(&mut self) -> [f32; 3] {
        [self.f32(), self.f32(), self.f32()]
    }
}

/// A valid command with absurd values: every kind, each number plausible or any bit pattern.
fn absurd(r: &mut Rng, now_us: u64) -> Command {
    let t = |r: &mut Rng| match r.below(3) {
        0 => r.next(),
        _ => now_us
            .saturating_add(r.next() % 2_000_000)
            .saturating_sub(1_000_000),
    };
    match r.below(17) {
        0 => Command::Heartbeat { t_us: t(r) },
        1 => Command::Arm,
        2 => Command::Disarm,
        3 => Command::SetMode(
            [
                Mode::Idle,
                Mode::Manual,
                Mode::Hold,
                Mode::Stabilize,
                Mode::DepthHold,
                Mode::Auto,
                Mode::Track {
                    plane: Plane::ThreeD,
                    law: Law::Tracking,
                },
                Mode::Track {
                    plane: Plane::Xy,
                    law: Law::Paper,
                },
            ][r.below(8)],
        ),
        4 => Command::SetReference {
            reference: match r.below(4) {
                0 => Reference::Hold { pos_m: r.f3() },
                1 => Reference::Line {
                    start_m: r.f3(),
                    heading_rad: r.f32(),
                    speed_m_s: r.f32(),
                },
                2 => Reference::Helix {
                    center_m: r.f3(),
                    radius_m: r.f32(),
                    speed_m_s: r.f32(),
                    depth_rate_m_s: r.f32(),
                },
                _ => Reference::Paper(PaperPolynomial {
                    h_r_m: r.f32(),
                    t_f_s: r.f32(),
                }),
            },
            start_us: if r.below(2) == 0 { None } else { Some(t(r)) },
        },
        5 => {
            let mut g = Gains::default();
            g.tracking.xy_kp = r.f32();
            g.tracking.depth_kd = r.f32();
            g.tracking.hand_m = r.f32();
            Command::SetTrackingGains(g.tracking)
        }
        6 => {
            let mut g = Gains::default();
            g.paper_xz.c1w = r.f32();
            g.paper_xy.k = r.f32();
            Command::SetPaperGains {
                xz: g.paper_xz,
                xy: g.paper_xy,
            }
        }
        7 | 8 => {
            let [x, y, z] = r.f3();
            Command::Nav(NavSample {
                t_us: t(r),
                state: NavState {
                    x_m: x,
                    y_m: y,
                    z_m: z,
                    yaw_rad: r.f32(),
                    u_m_s: r.f32(),
                    r_rad_s: r.f32(),
                    ..NavState::default()
                },
            })
        }
        9 | 10 => {
            let [surge, yaw, heave] = r.f3();
            Command::ManualThrust(ManualThrust { surge, yaw, heave })
        }
        11 => {
            let mut p = VehicleParams::OBSERVER;
            p.mass_kg = r.f32();
            p.x_uu = r.f32();
            p.thrust_max_forward_n = r.f32();
            p.pulse.neutral_us = r.f32();
            p.pulse.min_us = r.f32();
            Command::SetVehicle(p)
        }
        12 => Command::SetFailsafe(Failsafe {
            heartbeat_neutral_us: r.next() % 20_000_000,
            heartbeat_disarm_us: r.next() % 20_000_000,
            nav_stale_us: r.next(),
            manual_stale_us: r.next() % 3_000_000,
        }),
        13 => Command::MissionItem {
            index: r.below(4) as u16,
            count: r.below(5) as u16,
            pos_m: r.f3(),
            speed_m_s: r.f32(),
        },
        14 => Command::Imu(ImuSample {
            t_us: t(r),
            gyro_rad_s: r.f3(),
            accel_m_s2: r.f3(),
        }),
        15 => Command::Pressure {
            t_us: t(r),
            pressure_pa: r.f32(),
        },
        _ => Command::OpenSession {
            nonce: r.next() as u32,
        },
    }
}

/// Inputs of each kind (at least a million by default; `SAFETY_FUZZ_INPUTS` to change).
/// The inputs of each kind: `SAFETY_FUZZ_INPUTS`, else 1 M where `ROV_LONG` is set (CI) and
/// 200 k elsewhere (the README's command: the same checks on the first fifth of the draws).
fn inputs_per_kind() -> usize {
    if let Some(n) = std::env::var("SAFETY_FUZZ_INPUTS")
        .ok()
        .and_then(|v| v.parse().ok())
    {
        return n;
    }
    if std::env::var_os("ROV_LONG").is_some_and(|v| v != "0") {
        return 1_000_000;
    }
    eprintln!(
        "QUICK a_million_inputs_of_each_kind: 200 k of its 1 M inputs of each kind (all of \
         them: ROV_LONG=1 cargo test -p rov-tests --test it fuzz::million)"
    );
    200_000
}

/// At least 1 M inputs of each kind (CI; 200 k in the README's command): bursts, multi-byte damage,
/// truncation, glued frames (the decoder the App uses), replays and valid frames with absurd
/// values (through the App). Asserted: 0 corrupted frames accepted, 0 replays accepted, 0
/// pulses outside the ESC's 1100-1900 us, 0 panics (a panic fails the test).
#[test]
fn a_million_inputs_of_each_kind() {
    let n = inputs_per_kind();
    let t0 = std::time::Instant::now();
    let mut r = Rng(0x9E37_79B9_7F4A_7C15);
    // A pool of valid frames of every kind (session 7), their bytes intact.
    let pool: Vec<Vec<u8>> = (0..4096)
        .map(|i| frame(7, i as u16, &absurd(&mut r, 1_000_000)))
        .collect();
    let mut d = FrameDecoder::<Command>::new();
    let mut corrupted_accepted = [0u64; 4];
    let mut intact_recovered = 0u64;
    for (kind, accepted) in corrupted_accepted.iter_mut().enumerate() {
        for _ in 0..n {
            let f = &pool[r.below(pool.len())];
            let mut bytes = f.clone();
            let len = bytes.len();
            match kind {
                // A burst: up to 8 consecutive bytes replaced (at least one changed).
                0 => {
                    let k = 1 + r.below(8);
                    let at = r.below(len - 1);
                    for b in bytes.iter_mut().skip(at).take(k) {
                        *b = r.byte();
                    }
                    if bytes == *f {
                        bytes[at] ^= 0x5A;
                    }
                }
                // Multi-byte damage: 2-6 bytes anywhere, each changed.
                1 => {
                    for _ in 0..2 + r.below(5) {
                        let at = r.below(len);
                        bytes[at] ^= 1 + r.byte() % 255;
                    }
                    if bytes == *f {
                        bytes[1] ^= 0x11;
                    }
                }
                // Truncation: the frame cut short, then the next frame's leading delimiter.
                2 => {
                    let cut = 1 + r.below(len - 2);
                    bytes.truncate(cut);
                }
                // Glued: two frames with the delimiters between them lost.
                _ => {
                    let g = &pool[r.below(pool.len())];
                    bytes.truncate(len - 1);
                    bytes.extend_from_slice(&g[1..]);
                }
            }
            // The next intact frame after it (the line goes on).
            let good = &pool[r.below(pool.len())];
            let mut got = Vec::new();
            let mut src: &[u8] = &bytes;
            while !src.is_empty() {
                if let Some(Decoded::Frame { .. }) = d.push_slice(&mut src) {
                    got.push(());
                }
            }
            if let Some(Decoded::Frame { .. }) = d.push(0) {
                got.push(());
            }
            *accepted += got.len() as u64;
            let mut src: &[u8] = good;
            while !src.is_empty() {
                if let Some(Decoded::Frame { .. }) = d.push_slice(&mut src) {
                    intact_recovered += 1;
                }
            }
        }
    }
    let decoder_s = t0.elapsed().as_secs_f64();

    // Through the App: replays and absurd values, in a session, on a fixed-rate clock.
    let (mut a, c) = app(Config::fixed_rate(Board::Host));
    let mut top = Topside::default();
    top.open(&mut a);
    let mut sent: Vec<Vec<u8>> = Vec::new();
    let (mut replays, mut out_of_range, mut pulses_checked) = (0u64, 0u64, 0u64);
    let mut thrusting = 0u64;
    let check = |a: &mut rov_tests::TestApp, out: &mut u64, checked: &mut u64| {
        for p in pulses_us(a) {
            *checked += 1;
            if !(1100.0..=1900.0).contains(&p) {
                *out += 1;
            }
        }
    };
    let mut absurd_n = 0usize;
    while absurd_n < n || (replays as usize) < n {
        c.advance_us(1_000);
        // Keep the link alive now and then so that arming and the laws are reachable.
        let cmd = if r.below(10) == 0 {
            Command::Heartbeat { t_us: 0 }
        } else {
            absurd(&mut r, c.get_us())
        };
        if matches!(cmd, Command::OpenSession { .. }) {
            continue; // a session change would make the replays below "no session" instead
        }
        if top.client.needs_session() {
            // As the host's link does before its numbers wrap: a new session (the old
            // session's frames are then refused `NoSession`; the replays start again).
            top.open(&mut a);
            sent.clear();
        }
        let (_, f) = top.frame(&cmd);
        a.parts_mut().1.rx.extend(f.iter().copied());
        a.tick();
        absurd_n += 1;
        if sent.len() < 256 {
            sent.push(f);
        } else {
            let k = r.below(256);
            sent[k] = f;
        }
        check(&mut a, &mut out_of_range, &mut pulses_checked);
        thrusting += u64::from(pulses_us(&mut a) != [1500.0; 3]);
        // A replay of a frame already sent (any of the last few hundred).
        if (replays as usize) < n {
            let old = &sent[r.below(sent.len())];
            a.parts_mut().1.rx.extend(old.iter().copied());
            a.tick();
            replays += 1;
            check(&mut a, &mut out_of_range, &mut pulses_checked);
        }
        if a.parts_mut().1.tx.len() > 1 << 16 {
            a.parts_mut().1.tx.clear();
        }
    }
    let st = a.link_stats();
    let total_s = t0.elapsed().as_secs_f64();
    println!(
        "fuzz: {n} inputs of each kind; corrupted accepted (burst, multi-byte, \
         truncated, glued) {corrupted_accepted:?}, intact frames after them recovered \
         {intact_recovered} of {}; {replays} replays, refused as replays {}; {absurd_n} valid \
         frames with absurd values ({thrusting} with thrust), {pulses_checked} pulses checked, \
         {out_of_range} outside 1100-1900 us; {decoder_s:.1} s decoder, {total_s:.1} s in all",
        4 * n,
        st.replayed
    );
    assert_eq!(corrupted_accepted, [0; 4]);
    assert_eq!(
        intact_recovered,
        4 * n as u64,
        "every intact frame after the damage"
    );
    assert_eq!(u64::from(st.replayed), replays, "every replay refused");
    assert_eq!(st.no_session, 0);
    assert_eq!(out_of_range, 0);
}
