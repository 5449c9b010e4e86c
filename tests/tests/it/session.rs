//! A scripted session through the firmware library on the host, fixed-rate timing on a fake
//! clock: boot, heartbeats, arm, set the paper reference, track it in the horizontal plane
//! with the paper XY law while a simulated plant (the core's f32 XY model, driven by the
//! recorded PWM pulse widths) streams `NavState`; lose the link (neutral, then disarm);
//! recover (re-arm explicitly, track again). Every telemetry frame is parsed and checked.

// Test code: a failed expectation should stop the test.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use controller_core::reference::{PaperPolynomial, Reference};
use firmware::protocol::{
    fault, Board, Command, Law, Mode, NavSample, Plane, Reply, Status, Telemetry,
};
use firmware::Config;
use rov_tests::{app, pulses_us, TestApp, Topside, XyPlant};

const PERIOD_US: u64 = 20_000;

struct Session {
    app: TestApp,
    clock: rov_tests::FakeClock,
    top: Topside,
    plant: XyPlant,
    telemetry: Vec<Telemetry>,
    /// The answers to the heartbeats.
    statuses: Vec<Status>,
    acks: Vec<u16>,
    nacks: usize,
}

impl Session {
    /// One control period: optional heartbeat and nav, one tick, plant step with the pulses
    /// the PWM outputs hold.
    fn period(&mut self, heartbeat: bool, nav: bool) {
        self.clock.advance_us(PERIOD_US);
        let now = self.clock.get_us();
        let mut frames = Vec::new();
        if heartbeat {
            frames.extend(self.top.frame(&Command::Heartbeat { t_us: now }).1);
        }
        if nav {
            let cmd = Command::Nav(NavSample {
                t_us: now,
                state: self.plant.nav(),
            });
            frames.extend(self.top.frame(&cmd).1);
        }
        self.app.parts_mut().1.rx.extend(frames);
        self.app.tick();
        self.collect();
        let p = pulses_us(&mut self.app);
        for x in p {
            assert!((1100.0..=1900.0).contains(&x), "pulse {x}");
        }
        self.plant.step(p, PERIOD_US as f32 * 1e-6);
    }

    fn collect(&mut self) {
        for r in self.top.replies(&mut self.app) {
            match r {
                Reply::Telemetry(t) => {
                    // The reported pulses are the ones on the outputs.
                    let p = pulses_us(&mut self.app);
                    for (a, b) in t.pulse_us.iter().zip(p) {
                        assert!((f32::from(*a) - b).abs() <= 1.0, "{t:?} vs {p:?}");
                    }
                    self.telemetry.push(t);
                }
                Reply::Status(st) => {
                    assert_eq!(st.link.dropped.total(), 0);
                    self.statuses.push(st);
                }
                Reply::Ack { seq } => self.acks.push(seq),
                Reply::Nack { .. } => self.nacks += 1,
                Reply::Hello { .. } | Reply::Session { .. } => {}
            }
        }
    }

    fn command(&mut self, cmd: &Command) -> u16 {
        let (seq, f) = self.top.frame(cmd);
        self.app.parts_mut().1.rx.extend(f);
        self.app.tick();
        self.collect();
        assert!(self.acks.contains(&seq), "{cmd:?} not acked");
        seq
    }

    fn error_m(&self, r: &[f32; 3]) -> f32 {
        let s = &self.plant.state;
        ((s.x_m - r[0]).powi(2) + (s.y_m - r[1]).powi(2)).sqrt()
    }
}

#[test]
fn arm_track_lose_link_recover() {
    let (app, clock) = app(Config::fixed_rate(Board::Host));
    let mut s = Session {
        app,
        clock,
        top: Topside::default(),
        plant: XyPlant::default(),
        telemetry: Vec::new(),
        statuses: Vec::new(),
        acks: Vec::new(),
        nacks: 0,
    };
    s.app.hello();
    s.collect();
    s.top.open(&mut s.app);
    // Link up, idle.
    for _ in 0..10 {
        s.period(true, true);
    }
    assert!(!s.app.autopilot().armed());
    let reference = PaperPolynomial {
        h_r_m: 4.0,
        t_f_s: 40.0,
    };
    let start = s.clock.get_us() + 100_000;
    s.command(&Command::SetReference {
        reference: Reference::Paper(reference),
        start_us: Some(start),
    });
    s.command(&Command::Arm);
    s.command(&Command::SetMode(Mode::Track {
        plane: Plane::Xy,
        law: Law::Paper,
    }));
    // Track for t_f + 20 s.
    let mut worst = 0.0f32;
    let steps = (60_000_000 / PERIOD_US) as usize;
    for _ in 0..steps {
        s.period(true, true);
        let t = (s.clock.get_us().saturating_sub(start)) as f32 * 1e-6;
        let r = reference.sample(t).pos_m;
        worst = worst.max(s.error_m(&r));
    }
    let final_err = s.error_m(&[4.0, 4.0, 0.0]);
    let last = *s.telemetry.last().unwrap();
    println!(
        "tracking: worst {worst:.3} m, final {final_err:.4} m, plant {:?}, steps {}",
        s.plant.state,
        s.statuses.last().unwrap().steps
    );
    assert!(last.armed);
    assert_eq!(
        last.mode,
        Mode::Track {
            plane: Plane::Xy,
            law: Law::Paper
        }
    );
    assert_eq!(last.faults & (fault::HEARTBEAT_LOST | fault::NAV_STALE), 0);
    assert!(final_err < 0.25, "final error {final_err} m");
    // The telemetry's errors are the law's view of the same thing.
    assert!((last.errors.x_m.hypot(last.errors.y_m) - final_err).abs() < 0.05);
    assert!(s.telemetry.len() >= steps / 5 - 2, "telemetry at 10 Hz");

    // Lose the link: nothing arrives for 1.5 s.
    let lost_at = s.clock.get_us();
    let n_before = s.telemetry.len();
    for _ in 0..75 {
        s.period(false, false);
    }
    let during: Vec<Telemetry> = s.telemetry[n_before..].to_vec();
    assert!(during.len() >= 7);
    for t in &during {
        let age = t.t_us - lost_at;
        if age >= 500_000 {
            assert_ne!(t.faults & fault::HEARTBEAT_LOST, 0, "age {age}");
            assert_eq!(t.pulse_us, [1500; 3], "age {age}");
        }
        if age > 200_000 {
            // Tracking stops on stale nav even before the heartbeat timeout.
            assert_eq!(t.pulse_us, [1500; 3], "age {age}");
        }
        assert_eq!(t.armed, age < 1_000_000, "age {age}");
        if age >= 1_000_000 {
            assert_ne!(t.faults & fault::LINK_DISARMED, 0);
        }
    }
    // Link back: still disarmed until Arm.
    for _ in 0..10 {
        s.period(true, true);
    }
    assert!(!s.app.autopilot().armed());
    assert_eq!(pulses_us(&mut s.app), [1500.0; 3]);
    // The disarm forgot the reference (a re-arming resumes nothing); the surface
    // sends what it wants now, the end point of the path.
    s.command(&Command::SetReference {
        reference: Reference::Hold {
            pos_m: [4.0, 4.0, 0.0],
        },
        start_us: None,
    });
    s.command(&Command::Arm);
    for _ in 0..(20_000_000 / PERIOD_US) {
        s.period(true, true);
    }
    let final_err = s.error_m(&[4.0, 4.0, 0.0]);
    let last = *s.telemetry.last().unwrap();
    println!(
        "after recovery: error {final_err:.4} m, link {:?}",
        s.statuses.last().unwrap().link
    );
    assert!(last.armed);
    assert_eq!(
        last.faults & (fault::LINK_DISARMED | fault::HEARTBEAT_LOST),
        0
    );
    assert!(final_err < 0.25);
    assert_eq!(s.nacks, 0);
}
