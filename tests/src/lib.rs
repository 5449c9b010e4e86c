//! Shared helpers for the cross-crate tests: fake PWM outputs, serial port and clock that
//! record every call, a topside link (the protocol's session client) that frames commands and
//! parses replies, and a small horizontal-plane plant driven by the recorded PWM duties.

// Test helpers: a broken fixture should stop the test.
#![allow(clippy::expect_used, clippy::panic)]

use controller_core::alloc::PwmMap;
use controller_core::controller::{Controller, Gains};
use controller_core::model::{rk4_step, xy};
use controller_core::params::Vehicle;
use controller_core::state::{BodyForces, NavState, XyState};
use firmware::protocol::{Client, Command, Event, NackReason, Reply};
use firmware::{App, Config, Monotonic};
use std::cell::RefCell;
use std::convert::Infallible;
use std::rc::Rc;

/// A PWM output that records every duty written.
#[derive(Debug, Clone)]
pub struct FakePwm {
    /// Largest duty.
    pub max: u16,
    /// Every duty written, in order.
    pub writes: Vec<u16>,
}

impl FakePwm {
    /// An output with `max` duty steps.
    pub fn new(max: u16) -> Self {
        Self {
            max,
            writes: Vec::new(),
        }
    }

    /// The latest duty written.
    pub fn duty(&self) -> Option<u16> {
        self.writes.last().copied()
    }
}

impl embedded_hal::pwm::ErrorType for FakePwm {
    type Error = Infallible;
}

impl embedded_hal::pwm::SetDutyCycle for FakePwm {
    fn max_duty_cycle(&self) -> u16 {
        self.max
    }

    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Infallible> {
        assert!(duty <= self.max, "duty {duty} above max {}", self.max);
        self.writes.push(duty);
        Ok(())
    }
}

/// A serial port: bytes queued by the test are read by the firmware; bytes written by the
/// firmware are kept. The in-process firmware's port, the same type.
pub use host_sim::tether::in_process::SimSerial as FakeSerial;

/// A clock the test sets; shared so the test can move it while the app owns a copy.
#[derive(Debug, Default, Clone)]
pub struct FakeClock(pub Rc<RefCell<u64>>);

impl FakeClock {
    /// Set the time, microseconds.
    pub fn set_us(&self, t: u64) {
        *self.0.borrow_mut() = t;
    }

    /// Advance by `dt` microseconds.
    pub fn advance_us(&self, dt: u64) {
        *self.0.borrow_mut() += dt;
    }

    /// Current time.
    pub fn get_us(&self) -> u64 {
        *self.0.borrow()
    }
}

impl Monotonic for FakeClock {
    fn now_us(&mut self) -> u64 {
        *self.0.borrow()
    }
}

/// The application under test.
pub type TestApp = App<FakePwm, FakeSerial, FakeClock>;

/// 50 Hz PWM with 1 us per duty step (like the board's TIM3).
pub const PWM_MAX_DUTY: u16 = 20_000;

/// The Observer's default controller.
pub fn controller() -> Controller {
    Controller::new(Vehicle::observer(), Gains::default()).expect("valid default gains")
}

/// An app with fakes and the given config; returns the clock handle too.
pub fn app(config: Config) -> (TestApp, FakeClock) {
    let clock = FakeClock::default();
    let pwm = [
        FakePwm::new(PWM_MAX_DUTY),
        FakePwm::new(PWM_MAX_DUTY),
        FakePwm::new(PWM_MAX_DUTY),
    ];
    let app = App::new(
        pwm,
        FakeSerial::default(),
        clock.clone(),
        controller(),
        config,
    )
    .expect("valid config");
    (app, clock)
}

/// Topside side of the link: the protocol's session [`Client`] on the app's fake serial
/// port. Its session is opened on the first [`send`](Self::send) or
/// [`deliver`](Self::deliver), or by [`open`](Self::open). The client's clock is not used:
/// these tests read every answer at once.
#[derive(Debug, Default)]
pub struct Topside {
    /// Sessions this topside opened (its nonces).
    pub opened: u32,
    /// The session.
    pub client: Client,
}

impl Topside {
    /// The session the vehicle gave (0: none yet).
    pub fn session(&self) -> u32 {
        self.client.session()
    }

    /// The sequence number the next command will carry.
    pub fn next_seq(&self) -> u16 {
        self.client.next_seq()
    }

    /// Frame a command in the session; returns (its sequence number, the bytes).
    pub fn frame(&mut self, cmd: &Command) -> (u16, Vec<u8>) {
        let sent = self
            .client
            .send(cmd, 0)
            .unwrap_or_else(|e| panic!("{cmd:?} not framed: {e}"));
        (sent.seq, sent.frame.bytes().to_vec())
    }

    /// Open a session with the app (the handshake, through its receive path, no `tick`);
    /// returns the replies other than the answer.
    pub fn open<N: firmware::Sensors>(
        &mut self,
        app: &mut App<FakePwm, FakeSerial, FakeClock, N>,
    ) -> Vec<Reply> {
        self.opened += 1;
        let nonce = 0x5EED_0000 ^ self.opened;
        let f = self.client.open(nonce, 0).expect("fits");
        app.on_bytes(f.bytes());
        let rest: Vec<Reply> = self
            .replies(app)
            .into_iter()
            .filter(|r| !matches!(r, Reply::Session { nonce: n, .. } if *n == nonce))
            .collect();
        assert_ne!(self.session(), 0, "no session opened: {rest:?}");
        rest
    }

    /// Queue a command to the app and let it read it (one `tick`); returns the replies.
    pub fn send(&mut self, app: &mut TestApp, cmd: &Command) -> (u16, Vec<Reply>) {
        if self.client.needs_session() {
            self.open(app);
        }
        let (seq, f) = self.frame(cmd);
        app.parts_mut().1.rx.extend(f);
        app.tick();
        (seq, self.replies(app))
    }

    /// Feed a command byte by byte to the app's receive path, without a `tick` (no control
    /// step runs); returns the replies.
    pub fn deliver(&mut self, app: &mut TestApp, cmd: &Command) -> (u16, Vec<Reply>) {
        if self.client.needs_session() {
            self.open(app);
        }
        let (seq, f) = self.frame(cmd);
        for b in f {
            app.on_bytes(&[b]);
        }
        (seq, self.replies(app))
    }

    /// Take and parse everything the app wrote. Panics on a dropped reply frame.
    pub fn replies<N: firmware::Sensors>(
        &mut self,
        app: &mut App<FakePwm, FakeSerial, FakeClock, N>,
    ) -> Vec<Reply> {
        let bytes = std::mem::take(&mut app.parts_mut().1.tx);
        let mut rest = bytes.as_slice();
        let mut out = Vec::new();
        while let Some(e) = self.client.receive(&mut rest) {
            match e {
                Event::Reply { reply, .. } => out.push(reply),
                Event::Dropped { reason, .. } => panic!("reply dropped: {reason:?}"),
                Event::TimedOut { .. } | Event::OpenTimedOut { .. } => {}
            }
        }
        out
    }
}

/// Pulse widths (us) the app's PWM outputs are set to, from the recorded duties.
pub fn pulses_us(app: &mut TestApp) -> [f32; 3] {
    let (pwm, _, _) = app.parts_mut();
    let period = 20_000.0f32;
    let p = |o: &FakePwm| f32::from(o.duty().unwrap_or(0)) * period / f32::from(o.max);
    pwm.each_ref().map(p)
}

/// Horizontal-plane plant (the core's f32 model, RK4) driven by ESC pulse widths.
#[derive(Debug, Clone)]
pub struct XyPlant {
    /// Vehicle.
    pub vehicle: Vehicle,
    /// State.
    pub state: XyState,
    /// ESC model.
    pub pwm: PwmMap,
}

impl Default for XyPlant {
    fn default() -> Self {
        let vehicle = Vehicle::observer();
        Self {
            pwm: PwmMap::for_vehicle(&vehicle),
            vehicle,
            state: XyState::default(),
        }
    }
}

impl XyPlant {
    /// Advance `dt_s` with the thrust the three pulse widths make.
    pub fn step(&mut self, pulses_us: [f32; 3], dt_s: f32) {
        let f1 = self.pwm.thrust_n(pulses_us[0]);
        let f2 = self.pwm.thrust_n(pulses_us[1]);
        let l = self.vehicle.params().thruster_lever_arm_m;
        let forces = BodyForces {
            surge_n: f1 + f2,
            yaw_n_m: l * (f1 - f2),
            heave_n: 0.0,
        };
        let v = self.vehicle;
        self.state = rk4_step(|s| xy::derivative(&v, s, &forces), &self.state, dt_s);
    }

    /// The navigation state the estimator would report.
    pub fn nav(&self) -> NavState {
        let s = &self.state;
        NavState {
            x_m: s.x_m,
            y_m: s.y_m,
            yaw_rad: s.yaw_rad,
            u_m_s: s.u_m_s,
            v_m_s: s.v_m_s,
            r_rad_s: s.r_rad_s,
            ..NavState::default()
        }
    }
}

/// The reason the vehicle refused the frame `seq`, if it refused it.
pub fn nacked(replies: &[Reply], seq: u16) -> Option<NackReason> {
    replies.iter().find_map(|r| match r {
        Reply::Nack { seq: s, reason } if *s == seq => Some(*reason),
        _ => None,
    })
}
