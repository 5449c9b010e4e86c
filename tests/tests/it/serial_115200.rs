//! The tether never stalls the loop: the firmware's `App` on a serial port
//! model that takes one byte every 86.8 us (115,200 Bd, 8N1), in fixed-rate mode (50 Hz
//! control, 10 Hz telemetry, a `Status` for every heartbeat). The loop runs every 50 us of
//! simulated time. Checked: the application never writes to the port when it is not ready
//! (a write that would wait), every control step starts within one loop pass of its due time
//! (the jitter, printed), and every frame sent arrives whole.

// Test code: a failed expectation should stop the test.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use controller_core::state::NavState;
use firmware::protocol::{
    encode, Board, Command, Decoded, FrameDecoder, NavSample, Reply, MAX_FRAME_LEN,
};
use firmware::{App, Config};
use rov_tests::{controller, FakeClock, FakePwm, PWM_MAX_DUTY};
use std::cell::RefCell;
use std::collections::VecDeque;
use std::convert::Infallible;
use std::rc::Rc;

/// One byte time at 115,200 Bd with a start and a stop bit (us).
const BYTE_US: f64 = 10.0 / 115_200.0 * 1e6;

/// A UART at 115,200 Bd: its data register takes one byte when the previous one has gone.
#[derive(Debug, Default)]
struct Uart {
    clock: FakeClock,
    rx: VecDeque<u8>,
    tx: Vec<u8>,
    /// When the data register is free again (us).
    free_at_us: f64,
    /// Writes attempted while the register was busy (a blocking port would have waited).
    busy_writes: u32,
}

#[derive(Debug, Clone, Default)]
struct Port(Rc<RefCell<Uart>>);

impl embedded_io::ErrorType for Port {
    type Error = Infallible;
}

impl embedded_io::Read for Port {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let mut u = self.0.borrow_mut();
        let n = buf.len().min(u.rx.len());
        for (b, x) in buf.iter_mut().zip(u.rx.drain(..n)) {
            *b = x;
        }
        Ok(n)
    }
}

impl embedded_io::ReadReady for Port {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(!self.0.borrow().rx.is_empty())
    }
}

impl embedded_io::WriteReady for Port {
    fn write_ready(&mut self) -> Result<bool, Infallible> {
        let u = self.0.borrow();
        Ok(u.clock.get_us() as f64 >= u.free_at_us)
    }
}

impl embedded_io::Write for Port {
    /// Takes one byte when the register is free; a write while it is busy is counted (that
    /// is where a blocking driver waits) and takes the byte when it frees.
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        let mut u = self.0.borrow_mut();
        let now = u.clock.get_us() as f64;
        if now < u.free_at_us {
            u.busy_writes += 1;
        }
        let start = now.max(u.free_at_us);
        u.free_at_us = start + BYTE_US;
        u.tx.push(buf[0]);
        Ok(1)
    }

    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

fn frame(session: u32, seq: u16, cmd: &Command) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME_LEN];
    encode(session, seq, cmd, &mut out).unwrap().to_vec()
}

/// The App in fixed-rate mode on a 115,200 Bd port, both timed by one fake clock.
fn fixed_rate_app() -> (App<FakePwm, Port, FakeClock>, Port, FakeClock) {
    let clock = FakeClock::default();
    let port = Port::default();
    port.0.borrow_mut().clock = clock.clone();
    let pwm = [
        FakePwm::new(PWM_MAX_DUTY),
        FakePwm::new(PWM_MAX_DUTY),
        FakePwm::new(PWM_MAX_DUTY),
    ];
    let app = App::new(
        pwm,
        port.clone(),
        clock.clone(),
        controller(),
        Config::fixed_rate(Board::Host),
    )
    .unwrap();
    (app, port, clock)
}

#[test]
fn no_loop_iteration_waits_on_a_115200_baud_port() {
    let (mut app, port, clock) = fixed_rate_app();
    app.hello();
    let tick_us = 50;
    // The session (protocol version 6), opened as the host's link does; its answer comes
    // down the slow line within a few milliseconds.
    app.on_bytes(&frame(0, 0, &Command::OpenSession { nonce: 1 }));
    let mut session = None;
    for _ in 0..2_000 {
        clock.advance_us(tick_us);
        app.tick();
        let mut d = FrameDecoder::<Reply>::new();
        let tx = port.0.borrow().tx.clone();
        session = tx.iter().find_map(|&b| match d.push(b) {
            Some(Decoded::Frame {
                msg: Reply::Session { session, .. },
                ..
            }) => Some(session),
            _ => None,
        });
        if session.is_some() {
            break;
        }
    }
    let session = session.expect("a session");
    // The run starts at the next 100 ms.
    let t0 = clock.get_us().next_multiple_of(100_000);
    while clock.get_us() < t0 {
        clock.advance_us(tick_us);
        app.tick();
    }
    let mut seq = 1u16;
    let mut pass = 0u32;
    let run_us = 5_000_000;
    while clock.get_us() < t0 + run_us {
        let t = clock.get_us();
        // The surface: a heartbeat every 100 ms (answered by a Status) and a state every
        // 20 ms, as bytes arriving on the line.
        if t % 100_000 == 0 {
            port.0
                .borrow_mut()
                .rx
                .extend(frame(session, seq, &Command::Heartbeat { t_us: t }));
            seq += 1;
        }
        if t % 20_000 == 0 {
            let nav = Command::Nav(NavSample {
                t_us: t,
                state: NavState::default(),
            });
            port.0.borrow_mut().rx.extend(frame(session, seq, &nav));
            seq += 1;
        }
        app.tick();
        pass += 1;
        clock.advance_us(tick_us);
    }
    // Let the queue drain, then read everything the firmware sent.
    for _ in 0..2_000 {
        clock.advance_us(tick_us);
        app.tick();
    }
    let u = port.0.borrow();
    let mut d = FrameDecoder::<Reply>::new();
    let (mut telemetry, mut status) = (0, 0);
    for &b in &u.tx {
        match d.push(b) {
            Some(Decoded::Frame {
                msg: Reply::Telemetry(_),
                ..
            }) => telemetry += 1,
            Some(Decoded::Frame {
                msg: Reply::Status(_),
                ..
            }) => status += 1,
            Some(Decoded::Dropped { reason, .. }) => panic!("a frame arrived broken: {reason:?}"),
            _ => {}
        }
    }
    let st = app.status(clock.get_us(), 0);
    let line_busy = u.tx.len() as f64 * BYTE_US / run_us as f64;
    println!(
        "{pass} loop passes of {tick_us} us; {} bytes sent ({:.0} % of the line), {telemetry} \
         telemetry and {status} status frames, all whole; writes to a busy port: {}; control \
         steps {}, latest start after its due time (jitter): {} us; queue drops {}",
        u.tx.len(),
        100.0 * line_busy,
        u.busy_writes,
        st.steps,
        st.control_late_max_us,
        st.link.tx_dropped
    );
    assert_eq!(
        u.busy_writes, 0,
        "the loop wrote to a busy port (it would have waited)"
    );
    assert!(
        st.control_late_max_us <= tick_us as u32,
        "jitter {} us",
        st.control_late_max_us
    );
    assert_eq!(st.overruns, 0);
    assert_eq!(st.link.tx_dropped, 0);
    assert!(
        telemetry >= 49,
        "{telemetry} telemetry frames in 5 s at 10 Hz"
    );
    assert!(status >= 49, "{status} status frames in 5 s at 10 Hz");
    assert!(
        st.steps >= 249,
        "{} control steps in 5 s at 50 Hz",
        st.steps
    );
}

/// `App::replies_sent` (the emulated board sleeps only when it holds): false while a reply is
/// queued or partly handed to a port that takes one byte at a time, true once the port has
/// taken every byte, and then every frame on the line is whole.
#[test]
fn replies_are_sent_only_once_the_port_has_taken_their_last_byte() {
    let (mut app, port, clock) = fixed_rate_app();
    app.hello();
    assert!(!app.replies_sent(), "the hello left in one write");
    let mut ticks = 0;
    while !app.replies_sent() {
        ticks += 1;
        assert!(ticks < 2_000, "replies still unsent after 100 ms");
        clock.advance_us(50);
        app.tick();
    }
    let mut d = FrameDecoder::<Reply>::new();
    let tx = port.0.borrow().tx.clone();
    let mut frames = 0;
    let mut last_frame_end = 0;
    for (i, &b) in tx.iter().enumerate() {
        match d.push(b) {
            Some(Decoded::Frame { .. }) => {
                frames += 1;
                last_frame_end = i + 1;
            }
            Some(other) => panic!("not a whole frame on the line: {other:?}"),
            None => {}
        }
    }
    assert!(frames >= 1, "no frame sent");
    assert_eq!(last_frame_end, tx.len(), "a frame cut short on the line");
}
