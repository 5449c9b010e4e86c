//! The node's failsafes and its increments, on the host with fake outputs, port, clock and
//! sensors.
#![allow(clippy::unwrap_used, clippy::indexing_slicing)]

use super::*;
use crate::node_link::{encode_frame_for_tests, NODE_LINK_VERSION};
use controller_core::nav::ImuSample;
use std::cell::Cell;
use std::collections::VecDeque;
use std::convert::Infallible;
use std::rc::Rc;

/// 1 us per duty step at 50 Hz (like the boards' TIM3).
const MAX_DUTY: u16 = 20_000;
const SESSION: u32 = 0xA5A5_0001;

#[derive(Debug, Default)]
struct Pwm {
    writes: Vec<u16>,
}

impl embedded_hal::pwm::ErrorType for Pwm {
    type Error = Infallible;
}

impl SetDutyCycle for Pwm {
    fn max_duty_cycle(&self) -> u16 {
        MAX_DUTY
    }
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Infallible> {
        assert!(duty <= MAX_DUTY);
        self.writes.push(duty);
        Ok(())
    }
}

#[derive(Debug, Default)]
struct Port {
    rx: VecDeque<u8>,
    tx: Vec<u8>,
}

impl embedded_io::ErrorType for Port {
    type Error = Infallible;
}
impl Read for Port {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let n = buf.len().min(self.rx.len());
        for (b, x) in buf.iter_mut().zip(self.rx.drain(..n)) {
            *b = x;
        }
        Ok(n)
    }
}
impl ReadReady for Port {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(!self.rx.is_empty())
    }
}
impl Write for Port {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        self.tx.extend_from_slice(buf);
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

/// A constant IMU (or a silent one) and a pressure reading each call.
#[derive(Debug, Clone, Copy)]
struct FakeSensors {
    gyro_rad_s: [f32; 3],
    accel_m_s2: [f32; 3],
    imu_ok: bool,
    pressure_pa: Option<f32>,
}

impl Sensors for FakeSensors {
    fn imu(&mut self, now_us: u64) -> Option<ImuSample> {
        self.imu_ok.then_some(ImuSample {
            t_us: now_us,
            gyro_rad_s: self.gyro_rad_s,
            accel_m_s2: self.accel_m_s2,
        })
    }
    fn pressure_pa(&mut self, _now_us: u64) -> Option<f32> {
        self.pressure_pa
    }
}

const SENSORS: FakeSensors = FakeSensors {
    gyro_rad_s: [0.1, -0.2, 0.3],
    accel_m_s2: [0.5, 0.0, -9.81],
    imu_ok: true,
    pressure_pa: Some(120_000.0),
};

type TestNode = Node<Pwm, Port, Clock, FakeSensors>;

struct Bench {
    node: TestNode,
    clock: Rc<Cell<u64>>,
    seq: u64,
}

fn cmd(pulse_us: [u16; 3], ttl_ms: u8, arm: ArmCommand) -> Downlink {
    Downlink {
        session: SESSION,
        seq: 0,
        pulse_us,
        ttl_ms,
        arm,
        t_us: 0,
    }
}

/// The frame of downlink `d` with sequence `seq` (the envelope's its low 16 bits).
fn frame(seq: u64, d: Downlink) -> Vec<u8> {
    let d = Downlink { seq, ..d };
    encode_frame_for_tests(NODE_LINK_VERSION, low_16(seq), &d)
}

impl Bench {
    fn new() -> Self {
        let clock = Clock::default();
        let t = clock.0.clone();
        let pwm = [Pwm::default(), Pwm::default(), Pwm::default()];
        let node = Node::new(pwm, Port::default(), clock, SENSORS, NodeConfig::DEFAULT).unwrap();
        Self {
            node,
            clock: t,
            seq: 0,
        }
    }

    fn now(&self) -> u64 {
        self.clock.get()
    }

    /// Run the loop every 100 us for `us`.
    fn run_us(&mut self, us: u64) {
        let end = self.now() + us;
        while self.now() < end {
            self.clock.set(self.now() + 100);
            self.node.tick();
        }
    }

    fn send_raw(&mut self, bytes: &[u8]) {
        self.node.parts_mut().1.rx.extend(bytes);
        self.node.tick();
    }

    /// Send a downlink with the next sequence number.
    fn send(&mut self, d: Downlink) {
        self.seq = self.seq.wrapping_add(1);
        self.send_seq(self.seq, d);
    }

    fn send_seq(&mut self, seq: u64, d: Downlink) {
        self.send_raw(&frame(seq, d));
    }

    /// Send a downlink with the next sequence number and return its bytes (a recording).
    fn send_recorded(&mut self, d: Downlink) -> Vec<u8> {
        self.seq = self.seq.wrapping_add(1);
        let f = frame(self.seq, d);
        self.send_raw(&f);
        f
    }

    /// Neutral, then armed with `pulse_us`.
    fn arm(&mut self, pulse_us: [u16; 3]) {
        self.send(cmd([ESC_NEUTRAL_US; 3], 100, ArmCommand::Disarmed));
        self.send(cmd(pulse_us, 100, ArmCommand::Armed));
    }

    fn out(&self) -> [u16; 3] {
        self.node.output_us()
    }

    /// The duties on the three outputs now.
    fn duties(&mut self) -> [u16; 3] {
        let p = &self.node.parts_mut().0;
        [0, 1, 2].map(|i| *p[i].writes.last().unwrap())
    }

    /// Every uplink sent so far.
    fn uplinks(&mut self) -> Vec<(u16, Uplink)> {
        let tx = std::mem::take(&mut self.node.parts_mut().1.tx);
        let mut d = LinkDecoder::<Uplink>::new();
        tx.iter()
            .filter_map(|&b| d.push(b))
            .map(|f| match f {
                LinkFrame::Frame { seq, msg } => (seq, msg),
                LinkFrame::Dropped(r) => panic!("uplink dropped: {r:?}"),
            })
            .collect()
    }
}

const PULSES: [u16; 3] = [1700, 1300, 1550];

#[test]
fn neutral_is_written_first_on_every_output() {
    let mut b = Bench::new();
    for p in b.node.parts_mut().0.iter() {
        assert_eq!(p.writes, vec![1500], "one write at construction: neutral");
    }
    assert_eq!(b.out(), [1500; 3]);
    assert!(!b.node.armed());
    assert_eq!(b.node.status(0) & status::LATCHED, status::LATCHED);
}

#[test]
fn an_armed_command_arms_only_after_a_disarmed_one() {
    let mut b = Bench::new();
    // From boot, `Armed` alone does not arm.
    for _ in 0..5 {
        b.send(cmd(PULSES, 100, ArmCommand::Armed));
        b.run_us(1_000);
    }
    assert!(!b.node.armed());
    assert_eq!(b.out(), [1500; 3]);
    assert_eq!(b.node.counters().accepted, 5);
    b.send(cmd([1500; 3], 100, ArmCommand::Disarmed));
    assert_eq!(b.out(), [1500; 3]);
    b.send(cmd(PULSES, 100, ArmCommand::Armed));
    assert!(b.node.armed());
    assert_eq!(b.out(), PULSES);
    assert_eq!(b.duties(), PULSES);
    // A disarm is neutral at once.
    b.send(cmd(PULSES, 100, ArmCommand::Disarmed));
    assert_eq!(b.out(), [1500; 3]);
}

#[test]
fn a_command_older_than_its_time_to_live_gives_neutral() {
    let mut b = Bench::new();
    b.send(cmd([1500; 3], 40, ArmCommand::Disarmed));
    b.send(cmd(PULSES, 40, ArmCommand::Armed));
    let t0 = b.now();
    b.run_us(39_000);
    assert_eq!(b.out(), PULSES);
    b.run_us(1_100);
    assert_eq!(b.out(), [1500; 3], "neutral at {} us", b.now() - t0);
    assert_eq!(b.duties(), [1500; 3]);
    assert!(b.node.armed(), "still armed: a fresh command resumes");
    assert_eq!(
        b.node.status(b.now()) & status::TTL_NEUTRAL,
        status::TTL_NEUTRAL
    );
    b.run_us(20_000);
    assert_eq!(b.node.counters().ttl_expired, 1, "counted once");
    b.send(cmd(PULSES, 100, ArmCommand::Armed));
    assert_eq!(b.out(), PULSES);
    b.run_us(99_000);
    assert_eq!(b.out(), PULSES);
    b.run_us(1_100);
    assert_eq!(b.out(), [1500; 3]);
    assert_eq!(b.node.counters().ttl_expired, 2);
}

#[test]
fn one_second_without_a_valid_frame_disarms_and_latches() {
    let mut b = Bench::new();
    b.arm(PULSES);
    // Keep commanding for a while, then go silent (refused frames do not count as valid).
    for _ in 0..10 {
        b.run_us(20_000);
        b.send(cmd(PULSES, 100, ArmCommand::Armed));
    }
    let last = b.now();
    let mut bad = frame(b.seq + 1, cmd(PULSES, 100, ArmCommand::Armed));
    bad[5] ^= 0x10;
    while b.now() + 20_000 < last + 1_000_000 {
        b.run_us(20_000);
        b.send_raw(&bad);
        // Replays of the last good frame, too.
        b.send_seq(b.seq, cmd(PULSES, 100, ArmCommand::Armed));
    }
    b.run_us(last + 999_900 - b.now());
    assert!(b.node.armed(), "armed until 1 s of silence");
    assert_eq!(b.out(), [1500; 3], "neutral since the time to live");
    b.run_us(100);
    assert!(!b.node.armed(), "disarmed at {} us", b.now() - last);
    assert_eq!(b.node.status(b.now()) & status::LATCHED, status::LATCHED);
    // Good frames again: still disarmed while they say `Armed`.
    for _ in 0..10 {
        b.send(cmd(PULSES, 100, ArmCommand::Armed));
        b.run_us(20_000);
    }
    assert!(!b.node.armed());
    assert_eq!(b.out(), [1500; 3]);
    // The explicit transition re-arms.
    b.arm(PULSES);
    assert!(b.node.armed());
    assert_eq!(b.out(), PULSES);
}

#[test]
fn refused_frames_change_nothing_and_are_counted() {
    let mut b = Bench::new();
    b.arm(PULSES);
    let good = cmd([1600, 1600, 1600], 100, ArmCommand::Armed);
    let before = (b.out(), b.node.session(), b.node.counters().accepted);

    // Bad CRC.
    let mut f = frame(b.seq + 1, good);
    let n = f.len();
    f[n - 3] ^= 0x01;
    b.send_raw(&f);
    // Replays: the same sequence, an older one.
    b.send_seq(b.seq, good);
    b.send_seq(b.seq.saturating_sub(5), good);
    // Out of the ESC's range, a time to live of 0 or above 100 ms.
    for p in [
        [1099, 1500, 1500],
        [1500, 1901, 1500],
        [0, 0, 0],
        [u16::MAX; 3],
    ] {
        b.send_seq(b.seq + 1, cmd(p, 100, ArmCommand::Armed));
    }
    b.send_seq(b.seq + 1, cmd([1600; 3], 0, ArmCommand::Armed));
    b.send_seq(b.seq + 1, cmd([1600; 3], 101, ArmCommand::Armed));
    // Another topside, session 0.
    b.send_seq(
        b.seq + 1,
        Downlink {
            session: SESSION + 1,
            ..good
        },
    );
    b.send_seq(b.seq + 1, Downlink { session: 0, ..good });
    // Another link version.
    b.send_raw(&encode_frame_for_tests(
        NODE_LINK_VERSION + 1,
        low_16(b.seq + 1),
        &Downlink {
            seq: b.seq + 1,
            ..good
        },
    ));
    // A disarm frame that fails a check does not disarm either.
    b.send_seq(b.seq, cmd([1500; 3], 100, ArmCommand::Disarmed));

    assert_eq!(
        (b.out(), b.node.session(), b.node.counters().accepted),
        before
    );
    assert!(b.node.armed());
    let c = b.node.counters();
    assert_eq!(c.corrupt, 1);
    assert_eq!(c.replayed, 3);
    assert_eq!(c.out_of_range, 6);
    assert_eq!(c.foreign, 2);
    assert_eq!(c.version, 1);
    // The next in-order frame is taken.
    b.send(good);
    assert_eq!(b.out(), [1600; 3]);
}

#[test]
fn a_frame_with_a_refused_check_is_never_applied_whatever_its_arm_command() {
    // The node at boot takes the first valid frame's session; a bad one does not set it.
    let mut b = Bench::new();
    b.send_seq(1, cmd([2000, 1500, 1500], 100, ArmCommand::Disarmed));
    assert_eq!(b.node.session(), 0);
    b.send_seq(1, cmd([1500; 3], 100, ArmCommand::Disarmed));
    assert_eq!(b.node.session(), SESSION);
}

#[test]
fn another_session_is_served_only_after_the_latch() {
    let mut b = Bench::new();
    b.arm(PULSES);
    let other = Downlink {
        session: 77,
        ..cmd([1500; 3], 100, ArmCommand::Disarmed)
    };
    // Crossed wires: a second topside is refused while the first one talks.
    b.send_seq(1, other);
    assert_eq!(b.node.counters().foreign, 1);
    assert_eq!(b.node.session(), SESSION);
    // The first goes silent for 1 s: the node latches and serves the next session, from
    // any sequence number (a rebooted topside starts again at 0).
    b.run_us(1_000_100);
    assert_eq!(b.node.session(), 0);
    b.send_seq(0, other);
    assert_eq!(b.node.session(), 77);
    b.send_seq(
        1,
        Downlink {
            arm: ArmCommand::Armed,
            t_us: 0,
            pulse_us: PULSES,
            ..other
        },
    );
    assert!(b.node.armed());
}

#[test]
fn the_uplink_carries_the_increments_of_its_period_and_echoes_the_downlink() {
    let mut b = Bench::new();
    b.arm(PULSES);
    let echo = b.seq;
    b.run_us(20_000 * 5);
    let ups = b.uplinks();
    assert_eq!(ups.len(), 5);
    for (i, (seq, up)) in ups.iter().enumerate() {
        assert_eq!(usize::from(*seq), i);
        assert_eq!(up.echo_seq, low_16(echo));
        assert_eq!(up.session, SESSION);
        assert_eq!(up.pressure_pa, 120_000.0);
        assert_eq!(usize::from(up.pressure_count), i + 1);
        assert_eq!(up.status & status::ARMED, status::ARMED);
        if i == 0 {
            continue; // the first period starts at the first sample
        }
        // 400 Hz: 8 intervals of 2.5 ms a 20 ms period, contiguous.
        assert_eq!(up.samples, 8, "{up:?}");
        assert_eq!(up.dt_us, 20_000);
        let dt = 0.02;
        for k in 0..3 {
            assert!((up.delta_angle_rad[k] - SENSORS.gyro_rad_s[k] * dt).abs() < 1e-6);
            assert!((up.delta_velocity_m_s[k] - SENSORS.accel_m_s2[k] * dt).abs() < 1e-5);
        }
    }
}

#[test]
fn the_uplink_echoes_the_downlinks_time_plus_its_holding_time_and_the_samples_age() {
    let mut b = Bench::new();
    // Before any downlink: nothing to echo.
    b.run_us(20_000);
    let ups = b.uplinks();
    assert_eq!(ups.len(), 1);
    assert_eq!(ups[0].1.echo_t_us, 0);
    b.clock.set(25_000);
    b.send(cmd([ESC_NEUTRAL_US; 3], 100, ArmCommand::Disarmed));
    // The topside's clock is its own: 7 s ahead, and it wraps in 32 bits.
    b.clock.set(27_300);
    b.send(Downlink {
        t_us: u32::MAX - 1_000,
        ..cmd(PULSES, 100, ArmCommand::Armed)
    });
    b.run_us(20_000);
    let ups = b.uplinks();
    assert_eq!(ups.len(), 1);
    let up = ups[0].1;
    // Sent at the node's 40 ms, the downlink arrived at 27.3 ms: held 12.7 ms.
    assert_eq!(up.echo_t_us, (u32::MAX - 1_000).wrapping_add(12_700));
    // The IMU and the uplink share the pass (the period is 8 IMU periods): age 0.
    assert_eq!(up.imu_age_us, 0);
    assert!(up.samples > 0);
}

#[test]
fn a_silent_imu_is_counted_and_reported() {
    let mut b = Bench::new();
    b.run_us(20_000);
    b.node.parts_mut().3.imu_ok = false;
    b.node.parts_mut().3.pressure_pa = None;
    b.run_us(600_000);
    let ups = b.uplinks();
    let last = ups.last().unwrap().1;
    assert_eq!(last.samples, 0);
    assert_eq!(last.delta_angle_rad, [0.0; 3]);
    assert_eq!(last.status & status::IMU_LOST, status::IMU_LOST);
    assert_eq!(last.status & status::PRESSURE_LOST, status::PRESSURE_LOST);
    assert!(last.counters.imu_errors >= 200, "{:?}", last.counters);
}

#[test]
fn settings_out_of_range_are_refused() {
    let make = |c: NodeConfig| {
        let pwm = [Pwm::default(), Pwm::default(), Pwm::default()];
        Node::new(pwm, Port::default(), Clock::default(), SENSORS, c).err()
    };
    let d = NodeConfig::DEFAULT;
    assert_eq!(make(d), None);
    assert_eq!(
        make(NodeConfig {
            imu_period_us: 2_501,
            ..d
        }),
        Some(NodeConfigError::ImuRate)
    );
    assert_eq!(
        make(NodeConfig {
            imu_period_us: 0,
            ..d
        }),
        Some(NodeConfigError::ImuRate)
    );
    assert_eq!(
        make(NodeConfig {
            link_period_us: 1_000,
            ..d
        }),
        Some(NodeConfigError::LinkRate)
    );
    assert_eq!(
        make(NodeConfig {
            pwm_period_us: 1_800,
            ..d
        }),
        Some(NodeConfigError::PwmPeriod)
    );
    assert_eq!(
        make(NodeConfig {
            disarm_after_us: 100_000,
            ..d
        }),
        Some(NodeConfigError::DisarmTime)
    );
    assert_eq!(
        make(NodeConfig {
            disarm_after_us: 1_000_001,
            ..d
        }),
        Some(NodeConfigError::DisarmTime)
    );
}

#[test]
fn duty_is_the_pulse_over_the_period() {
    assert_eq!(duty_for_pulse_us(1500, 20_000, 20_000), 1500);
    assert_eq!(duty_for_pulse_us(1500, 20_000, 65_535), 4915); // 4915.1
    assert_eq!(duty_for_pulse_us(1900, 2_500, 1_000), 760);
    assert_eq!(duty_for_pulse_us(u16::MAX, 20_000, 20_000), 20_000);
}

#[test]
fn a_downlink_replayed_at_any_distance_is_refused() {
    let genuine = [1600, 1500, 1500];
    for distance in [
        1u32, 1_000, 0x7fff, 0x8000, 0x8001, 0xffff, 0x1_0000, 0x1_8000,
    ] {
        let mut b = Bench::new();
        b.arm(PULSES);
        let recorded = b.send_recorded(cmd([1900, 1100, 1900], 100, ArmCommand::Armed));
        for _ in 0..distance {
            b.send(cmd(genuine, 100, ArmCommand::Armed));
        }
        let before = b.node.counters();
        b.send_raw(&recorded);
        assert_eq!(b.out(), genuine, "replayed {distance} frames later");
        assert_eq!(
            b.node.counters().replayed,
            before.replayed + 1,
            "{distance}"
        );
        assert_eq!(b.node.counters().accepted, before.accepted, "{distance}");
        // The genuine topside's next frame is still taken.
        b.send(cmd([1700, 1500, 1500], 100, ArmCommand::Armed));
        assert_eq!(b.out(), [1700, 1500, 1500], "{distance}");
    }
}

mod dvl;
