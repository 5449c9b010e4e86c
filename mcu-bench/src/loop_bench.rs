//! One full iteration of the firmware's loop, through the firmware library's own code:
//! [`firmware::App::tick`] in lock-step timing reads one `NavState` frame from the serial
//! port, decodes it (COBS, CRC-32, postcard), runs the autopilot's step (failsafes, reference,
//! control law, allocation, PWM map), writes the three duties and encodes and writes the
//! `Telemetry` frame. The serial port, PWM outputs and clock are fakes in RAM. The loop is
//! closed: the `NavState` each iteration reads is the state of the core's planar model of the
//! vehicle (`crate::plant`) after one control period under the forces of the last iteration,
//! from a start 0.3 / -0.2 / 0.2 m off the paper reference (a `CLOSEDLOOP` line reports where
//! it ended).
//!
//! Also timed alone: decoding one `NavState` frame and encoding one `Telemetry` frame.

use crate::bench::{Bench, Platform, CALLS};
use crate::plant::Plant;
use controller_core::controller::{Controller, Gains};
use controller_core::params::Vehicle;
use controller_core::reference::{PaperPolynomial, Reference};
use controller_core::state::{BodyForces, NavState};
use core::convert::Infallible;
use core::sync::atomic::{AtomicU32, Ordering};
use firmware::protocol::{
    encode, Board, Command, Decoded, FrameDecoder, Law, Mode, NavSample, Plane, Reply, Telemetry,
    MAX_FRAME_LEN,
};
use firmware::{App, Config, Monotonic};

/// A PWM output that keeps the duty (a timer channel at 1 MHz, 50 Hz: 20,000 counts).
pub(crate) struct FakePwm(pub(crate) u16);

impl embedded_hal::pwm::ErrorType for FakePwm {
    type Error = Infallible;
}

impl embedded_hal::pwm::SetDutyCycle for FakePwm {
    fn max_duty_cycle(&self) -> u16 {
        20_000
    }
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Infallible> {
        self.0 = duty;
        Ok(())
    }
}

/// A serial port in RAM: bytes queued for the firmware, bytes it wrote.
///
/// Not the host's shared fake port (`host_sim::tether::in_process::SimSerial`, which the tests use as
/// `rov_tests::FakeSerial`): that one keeps its bytes in a `VecDeque`/`Vec`, which needs an
/// allocator this `no_std` image has not, and lives in a std crate; and this port's copies are
/// part of the measured loop (docs/hil-and-mcu-cost.md), so they stay fixed-size and fixed.
pub(crate) struct FakeSerial {
    rx: [u8; 2 * MAX_FRAME_LEN],
    rx_len: usize,
    rx_pos: usize,
    tx: [u8; 2 * MAX_FRAME_LEN],
    tx_len: usize,
}

impl FakeSerial {
    pub(crate) const fn new() -> Self {
        Self {
            rx: [0; 2 * MAX_FRAME_LEN],
            rx_len: 0,
            rx_pos: 0,
            tx: [0; 2 * MAX_FRAME_LEN],
            tx_len: 0,
        }
    }

    /// Add a frame behind those not read yet (the replies written so far are kept).
    pub(crate) fn append(&mut self, frame: &[u8]) {
        if self.rx_pos >= self.rx_len {
            (self.rx_pos, self.rx_len) = (0, 0);
        }
        let end = (self.rx_len + frame.len()).min(self.rx.len());
        if let (Some(d), Some(s)) = (
            self.rx.get_mut(self.rx_len..end),
            frame.get(..end - self.rx_len),
        ) {
            d.copy_from_slice(s);
        }
        self.rx_len = end;
    }

    /// Forget the bytes written.
    pub(crate) fn clear_tx(&mut self) {
        self.tx_len = 0;
    }

    /// Queue one frame for the firmware (replacing whatever was left).
    fn load(&mut self, frame: &[u8]) {
        let n = frame.len().min(self.rx.len());
        if let (Some(d), Some(s)) = (self.rx.get_mut(..n), frame.get(..n)) {
            d.copy_from_slice(s);
        }
        self.rx_len = n;
        self.rx_pos = 0;
        self.tx_len = 0;
    }
}

impl embedded_io::ErrorType for FakeSerial {
    type Error = Infallible;
}

impl embedded_io::Read for FakeSerial {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let src = self.rx.get(self.rx_pos..self.rx_len).unwrap_or(&[]);
        let n = src.len().min(buf.len());
        if let (Some(d), Some(s)) = (buf.get_mut(..n), src.get(..n)) {
            d.copy_from_slice(s);
        }
        self.rx_pos += n;
        Ok(n)
    }
}

impl embedded_io::WriteReady for FakeSerial {
    /// Always ready: this port takes every byte at once.
    fn write_ready(&mut self) -> Result<bool, Infallible> {
        Ok(true)
    }
}

impl embedded_io::ReadReady for FakeSerial {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(self.rx_pos < self.rx_len)
    }
}

impl embedded_io::Write for FakeSerial {
    /// One copy, like handing the frame to a DMA transfer or a TX ring; the firmware's
    /// cost, not the driver's, is what the loop figure measures.
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        let end = (self.tx_len + buf.len()).min(self.tx.len());
        let n = end - self.tx_len;
        if let (Some(d), Some(s)) = (self.tx.get_mut(self.tx_len..end), buf.get(..n)) {
            d.copy_from_slice(s);
        }
        self.tx_len = end;
        Ok(buf.len())
    }
    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

/// The platform's counter as the firmware's clock (only `ticks` matters in lock-step).
struct Clock<'a, P: Platform>(&'a P);

impl<P: Platform> Monotonic for Clock<'_, P> {
    fn now_us(&mut self) -> u64 {
        u64::from(self.0.now())
    }
    fn ticks(&mut self) -> u32 {
        self.0.now()
    }
}

type BenchApp<'a, P> = App<FakePwm, FakeSerial, Clock<'a, P>>;

/// Control period of the lock-step loop (50 Hz).
const PERIOD_US: u64 = 20_000;

/// The session the bench's frames carry: the one [`open_session`] opened last.
static SESSION: AtomicU32 = AtomicU32::new(0);

/// Frame of `cmd` into `buf` in the session opened last; empty if it does not fit (never for
/// these commands).
pub(crate) fn frame<'b>(seq: u16, cmd: &Command, buf: &'b mut [u8; MAX_FRAME_LEN]) -> &'b [u8] {
    match encode(SESSION.load(Ordering::Relaxed), seq, cmd, buf) {
        Ok(f) => f,
        Err(_) => &[],
    }
}

/// Open a session with `app` as the host's link does (`OpenSession` with sequence number 0,
/// answered by `Reply::Session`); later frames carry it, numbered from 1. Untimed.
pub(crate) fn open_session<
    P: embedded_hal::pwm::SetDutyCycle,
    C: Monotonic,
    N: firmware::Sensors,
>(
    app: &mut App<P, FakeSerial, C, N>,
) {
    let mut buf = [0u8; MAX_FRAME_LEN];
    SESSION.store(0, Ordering::Relaxed);
    let f = frame(0, &Command::OpenSession { nonce: 0xB0A7 }, &mut buf);
    app.parts_mut().1.load(f);
    app.tick();
    let (_, serial, _) = app.parts_mut();
    let mut dec = FrameDecoder::<Reply>::new();
    for &b in serial.tx.get(..serial.tx_len).unwrap_or(&[]) {
        if let Some(Decoded::Frame {
            msg: Reply::Session { session, .. },
            ..
        }) = dec.push(b)
        {
            SESSION.store(session, Ordering::Relaxed);
        }
    }
    serial.clear_tx();
}

/// Hand one command to the app (untimed); returns true if it answered with an `Ack` or a
/// `Telemetry` (i.e. did not refuse it).
fn feed<P: Platform>(app: &mut BenchApp<'_, P>, seq: u16, cmd: &Command) -> bool {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let f = frame(seq, cmd, &mut buf);
    app.parts_mut().1.load(f);
    app.tick();
    let (_, serial, _) = app.parts_mut();
    let mut dec = FrameDecoder::<Reply>::new();
    let mut ok = matches!(cmd, Command::Heartbeat { .. });
    for &b in serial.tx.get(..serial.tx_len).unwrap_or(&[]) {
        if let Some(Decoded::Frame { msg, .. }) = dec.push(b) {
            ok = matches!(
                msg,
                Reply::Ack { .. } | Reply::Telemetry(_) | Reply::Status(_)
            );
        }
    }
    ok
}

/// One closed-loop loop item: the firmware and the vehicle it steers.
struct LoopSim<'a, P: Platform> {
    app: BenchApp<'a, P>,
    plant: Plant,
    /// The forces the thrusters made in the last iteration.
    forces: BodyForces,
}

/// The model that moves the vehicle for a firmware plane.
fn plant_plane(plane: Plane) -> crate::plant::Plane {
    match plane {
        Plane::Xz => crate::plant::Plane::Xz,
        _ => crate::plant::Plane::Xy3d,
    }
}

/// A navigation state near the paper reference at `t_s`.
fn nav_at(t_s: f32, jitter: f32) -> NavState {
    let r = PaperPolynomial::PAPER.sample(t_s);
    let [x, y, z] = r.pos_m;
    let [vx, vy, vz] = r.vel_m_s;
    NavState {
        x_m: x + 0.3 * jitter,
        y_m: y - 0.2 * jitter,
        z_m: z + 0.1 * jitter,
        pitch_rad: 0.05 * jitter,
        yaw_rad: 0.785 + 0.2 * jitter,
        u_m_s: controller_core::math::sqrt(vx * vx + vy * vy) + 0.05 * jitter,
        w_m_s: vz,
        r_rad_s: 0.02 * jitter,
        ..NavState::default()
    }
}

/// Loop iterations for each tracking mode of the firmware, plus decode and encode alone.
pub fn run_loop<P: Platform>(b: &Bench<'_, P>, p: &P) {
    // Decode one NavState frame.
    let mut dec = FrameDecoder::<Command>::new();
    let mut n_ok = 0u32;
    b.run(
        "protocol.decode_nav",
        CALLS,
        |i| {
            let mut out = [0u8; MAX_FRAME_LEN];
            let cmd = Command::Nav(NavSample {
                t_us: u64::from(i) * PERIOD_US,
                state: nav_at(i as f32 * 0.2, jitter(i)),
            });
            let n = frame(i as u16, &cmd, &mut out).len();
            (out, n)
        },
        |(buf, n)| {
            // As the loop reads it: the bytes of the frame handed to the decoder.
            let mut got = None;
            let mut src = buf.get(..*n).unwrap_or(&[]);
            while !src.is_empty() {
                if let Some(d) = dec.push_slice(&mut src) {
                    got = Some(d);
                }
            }
            if let Some(Decoded::Frame { .. }) = got {
                n_ok += 1;
            }
            n_ok
        },
    );
    if n_ok != CALLS {
        p.print(format_args!(
            "WARN protocol.decode_nav decoded {n_ok} of {CALLS}"
        ));
    }

    // Encode one Telemetry frame.
    let mut seq = 0u16;
    b.run(
        "protocol.encode_telemetry",
        CALLS,
        |i| {
            let mut t = Telemetry {
                t_us: u64::from(i) * PERIOD_US,
                armed: true,
                loop_ticks: 2_000 + i,
                ..Telemetry::default()
            };
            t.thrust_n = [jitter(i) * 30.0, -jitter(i) * 20.0, 5.0];
            t.pulse_us = [1500 + i as u16 % 300, 1500 - i as u16 % 300, 1600];
            t.errors.x_m = 0.01 * jitter(i);
            t
        },
        |t| {
            let mut out = [0u8; MAX_FRAME_LEN];
            seq = seq.wrapping_add(1);
            encode(1, seq, &Reply::Telemetry(*t), &mut out)
                .map(|f| f.len())
                .unwrap_or(0)
        },
    );

    let modes: [(&str, Plane, Law); 5] = [
        ("paper_xz", Plane::Xz, Law::Paper),
        ("paper_xy", Plane::Xy, Law::Paper),
        ("tracking_xz", Plane::Xz, Law::Tracking),
        ("tracking_xy", Plane::Xy, Law::Tracking),
        ("tracking_3d", Plane::ThreeD, Law::Tracking),
    ];
    for (name, plane, law) in modes {
        let Ok(controller) = Controller::new(Vehicle::observer(), Gains::default()) else {
            p.print(format_args!("mcu-bench: Controller::new failed"));
            return;
        };
        let pwm = [FakePwm(0), FakePwm(0), FakePwm(0)];
        let Ok(mut app) = App::new(
            pwm,
            FakeSerial::new(),
            Clock(p),
            controller,
            Config::lockstep(Board::Host),
        ) else {
            p.print(format_args!("mcu-bench: App::new failed"));
            return;
        };
        // Boot sequence as the host sends it: heartbeat, a NavState, reference, mode, arm.
        let mut seq = 0u16;
        let mut next = || {
            seq = seq.wrapping_add(1);
            seq
        };
        // The vehicle starts off the reference and is steered by the firmware in closed loop
        // (the core's planar model, `crate::plant`, untimed between the iterations).
        let start = crate::bench::offset_start(&PaperPolynomial::PAPER.sample(0.0));
        let setup = [
            Command::Heartbeat { t_us: 0 },
            Command::Nav(NavSample {
                t_us: 0,
                state: start,
            }),
            Command::SetReference {
                reference: Reference::Paper(PaperPolynomial::PAPER),
                start_us: Some(0),
            },
            Command::SetMode(Mode::Track { plane, law }),
            Command::Arm,
        ];
        let mut refused = 0u32;
        open_session(&mut app);
        for cmd in setup.iter() {
            if !feed(&mut app, next(), cmd) {
                refused += 1;
            }
        }
        let mut buf = [0u8; 40];
        let label = crate::bench::join(&mut buf, "loop.", name);
        let mut disarmed = 0u32;
        let mut no_law = 0u32;
        let mut no_reply = 0u32;
        let mut hb = [0u8; MAX_FRAME_LEN];
        let mut sim = LoopSim {
            app,
            plant: Plant::new(Vehicle::observer(), plant_plane(plane), start),
            forces: BodyForces::default(),
        };
        b.run_state(
            label,
            CALLS,
            &mut sim,
            |sim, i| {
                let t_us = u64::from(i + 1) * PERIOD_US;
                // The vehicle moves one period under the last thrust.
                let f = sim.forces;
                sim.plant.advance(&f, PERIOD_US as f32 * 1e-6);
                // The heartbeat of this period, outside the timed region.
                let f = frame(next(), &Command::Heartbeat { t_us }, &mut hb);
                sim.app.parts_mut().1.load(f);
                sim.app.tick();
                // The NavState frame the timed iteration will read.
                let mut out = [0u8; MAX_FRAME_LEN];
                let cmd = Command::Nav(NavSample {
                    t_us,
                    state: *sim.plant.nav(),
                });
                let f = frame(next(), &cmd, &mut out);
                sim.app.parts_mut().1.load(f);
            },
            |sim| sim.app.tick(),
            |sim| {
                let app = &mut sim.app;
                if app.parts_mut().1.tx_len == 0 {
                    no_reply += 1;
                }
                if !app.autopilot().armed() {
                    disarmed += 1;
                }
                if !app.last_output().law_ran {
                    no_law += 1;
                }
                sim.forces = app.last_output().allocation.achieved;
            },
        );
        let mut app = sim.app;
        // Where the closed loop ended, against the reference.
        let n = sim.plant.nav();
        let [x, y, z] = PaperPolynomial::PAPER
            .sample(CALLS as f32 * PERIOD_US as f32 * 1e-6)
            .pos_m;
        // The components the law steers: XZ (x, z), XY (x, y), 3-D (x, y, z).
        let (ex, ey, ez) = (n.x_m - x, n.y_m - y, n.z_m - z);
        let (ey, ez, axes) = match plane {
            Plane::Xz => (0.0, ez, "x, z"),
            Plane::Xy => (ey, 0.0, "x, y"),
            Plane::ThreeD => (ey, ez, "x, y, z"),
        };
        let err = controller_core::math::sqrt(ex * ex + ey * ey + ez * ez);
        p.print(format_args!(
            "CLOSEDLOOP {label} after {:.2} s: position error ({axes}) {err:.4} m, from (0.3, -0.2, 0.2) m off",
            CALLS as f32 * PERIOD_US as f32 * 1e-6,
        ));
        if name == "tracking_3d" {
            // The answer to a heartbeat (a tick that reads one `Heartbeat` and sends the
            // `Status`): not part of a control iteration, here so its cost is known too.
            b.run_state(
                "protocol.heartbeat_status",
                CALLS,
                &mut app,
                |app, i| {
                    let t_us = u64::from(CALLS + i + 1) * PERIOD_US;
                    let f = frame(next(), &Command::Heartbeat { t_us }, &mut hb);
                    app.parts_mut().1.load(f);
                },
                |app| app.tick(),
                |app| {
                    if app.parts_mut().1.tx_len == 0 {
                        no_reply += 1;
                    }
                },
            );
        }
        if refused + disarmed + no_law + no_reply > 0 {
            p.print(format_args!(
                "WARN loop.{name}: setup commands refused {refused}, iterations disarmed \
                 {disarmed}, without the law {no_law}, without telemetry {no_reply}"
            ));
        }
    }
}

/// A value in [-1, 1] that changes every call.
fn jitter(i: u32) -> f32 {
    let x = i.wrapping_mul(2_654_435_761) >> 8;
    (x as f32) * (2.0 / 16_777_216.0) - 1.0
}
