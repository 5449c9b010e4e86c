//! The board's start-up order and watchdog, on the host with recording
//! fakes: `firmware::start_outputs` (what `board.rs` calls on TIM3's three channels) writes the
//! ESC's neutral duty before it enables any output, and `firmware::loop_pass` (the board's
//! loop body) feeds the watchdog only after a pass that came back, so a stuck pass lets the
//! watchdog's window run out.

// Test code: a failed expectation should stop the test.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use firmware::protocol::Board;
use firmware::{loop_pass, start_outputs, Config, EscOutput, Watchdog};
use rov_tests::{app, FakeClock, PWM_MAX_DUTY};
use std::cell::RefCell;
use std::convert::Infallible;
use std::rc::Rc;

/// What happened to the outputs, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Call {
    Duty(usize, u16),
    Enable(usize),
}

/// A timer channel that logs every register write into a shared list.
struct RecordingChannel {
    index: usize,
    log: Rc<RefCell<Vec<Call>>>,
}

impl embedded_hal::pwm::ErrorType for RecordingChannel {
    type Error = Infallible;
}

impl embedded_hal::pwm::SetDutyCycle for RecordingChannel {
    fn max_duty_cycle(&self) -> u16 {
        PWM_MAX_DUTY
    }

    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Infallible> {
        self.log.borrow_mut().push(Call::Duty(self.index, duty));
        Ok(())
    }
}

impl EscOutput for RecordingChannel {
    fn enable(&mut self) {
        self.log.borrow_mut().push(Call::Enable(self.index));
    }
}

#[test]
fn neutral_duty_is_written_before_any_output_is_enabled() {
    let log = Rc::new(RefCell::new(Vec::new()));
    let mut pwm = [0, 1, 2].map(|index| RecordingChannel {
        index,
        log: log.clone(),
    });
    let cfg = Config::fixed_rate(Board::Stm32f4);
    assert!(start_outputs(&mut pwm, cfg.pwm_period_us()));
    let log = log.borrow();
    println!("start-up sequence: {log:?}");
    // 1500 us of the 20 000 us period at 1 us per step.
    let neutral = 1_500;
    let first_enable = log
        .iter()
        .position(|c| matches!(c, Call::Enable(_)))
        .expect("outputs enabled");
    for ch in 0..3 {
        let duty_at = log
            .iter()
            .position(|c| *c == Call::Duty(ch, neutral))
            .unwrap_or_else(|| panic!("channel {ch} never got the neutral duty"));
        assert!(
            duty_at < first_enable,
            "channel {ch}: neutral written after an output was enabled: {log:?}"
        );
        assert!(log.contains(&Call::Enable(ch)), "channel {ch} not enabled");
    }
    // No other duty before the enables.
    assert!(log[..first_enable]
        .iter()
        .all(|c| matches!(c, Call::Duty(_, d) if *d == neutral)));
}

/// An independent watchdog on the test's clock: it bites when fed later than its window
/// after the previous feed (the IWDG's 250 ms on the board).
struct FakeWatchdog {
    clock: FakeClock,
    window_us: u64,
    last_feed_us: u64,
    feeds: u32,
    bites: u32,
}

impl FakeWatchdog {
    /// Whether it has run out by now (checked as the hardware would, continuously).
    fn expired(&self) -> bool {
        self.clock.get_us() - self.last_feed_us > self.window_us
    }
}

impl Watchdog for FakeWatchdog {
    fn feed(&mut self) {
        if self.expired() {
            self.bites += 1;
        }
        self.feeds += 1;
        self.last_feed_us = self.clock.get_us();
    }
}

#[test]
fn the_loop_feeds_the_watchdog_and_a_stuck_pass_lets_it_bite() {
    let (mut a, c) = app(Config::fixed_rate(Board::Stm32f4));
    let mut wd = FakeWatchdog {
        clock: c.clone(),
        window_us: 250_000,
        last_feed_us: 0,
        feeds: 0,
        bites: 0,
    };
    // 10 s of loop passes of 1 ms: fed every pass, never bitten.
    for _ in 0..10_000 {
        c.advance_us(1_000);
        loop_pass(&mut a, &mut wd);
        assert!(!wd.expired());
    }
    assert_eq!((wd.feeds, wd.bites), (10_000, 0));
    // A pass stuck for 300 ms (the clock runs while `tick` does not come back): the window
    // runs out before the feed.
    let stuck = StuckTick(c.clone());
    stuck.run(&mut a, &mut wd, 300_000);
    assert_eq!(
        wd.bites, 1,
        "a 300 ms pass must let the 250 ms watchdog bite"
    );
    // A slow but not stuck pass (200 ms) does not.
    stuck.run(&mut a, &mut wd, 200_000);
    assert_eq!(wd.bites, 1);
}

/// A pass that takes `us` microseconds: the clock moves while the loop body runs, as if a
/// peripheral held it; the feed comes after.
struct StuckTick(FakeClock);

impl StuckTick {
    fn run(&self, a: &mut rov_tests::TestApp, wd: &mut FakeWatchdog, us: u64) {
        // What `loop_pass` does, with the time spent inside `tick` made visible: the watchdog
        // is not fed until the pass is over.
        let fed_before = wd.feeds;
        self.0.advance_us(us);
        assert_eq!(wd.feeds, fed_before, "fed during the pass");
        loop_pass(a, wd);
    }
}
