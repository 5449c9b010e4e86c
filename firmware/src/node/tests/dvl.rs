//! The node's DVL: its port read in the passes that seal no uplink, an admitted velocity
//! in the next uplink with its age, a refused line counted.

use super::*;
use crate::sensors::dvl::{a50, a50::VelocityGate, DvlPort, WithDvl};
use std::cell::RefCell;

/// The DVL's UART: the test writes lines into it.
#[derive(Debug, Clone, Default)]
struct DvlUart(Rc<RefCell<VecDeque<u8>>>);

impl embedded_io::ErrorType for DvlUart {
    type Error = Infallible;
}
impl Read for DvlUart {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let mut q = self.0.borrow_mut();
        let n = buf.len().min(q.len());
        for (b, x) in buf.iter_mut().zip(q.drain(..n)) {
            *b = x;
        }
        Ok(n)
    }
}
impl ReadReady for DvlUart {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(!self.0.borrow().is_empty())
    }
}

type DvlNode = Node<Pwm, Port, Clock, WithDvl<FakeSensors, DvlUart>>;

fn wrz(body: &str) -> String {
    let covered = format!("wrz,{body}");
    format!(
        "{covered}*{:02x}\r\n",
        a50::CRC8.checksum(covered.as_bytes())
    )
}

/// Lock, 0.25 m/s surge, -0.1 m/s sway, 0.01 m/s figure of merit, 50 ms from validity to
/// transmission.
const GOOD: &str = "0.250,-0.100,0.010,y,3.20,0.010,1e-4;0;0;0;1e-4;0;0;0;1e-4,1767225600000000,1767225600050000,200.00,0";

struct DvlBench {
    node: DvlNode,
    clock: Rc<Cell<u64>>,
    uart: DvlUart,
}

impl DvlBench {
    /// The node booted at 1 s (so that a report's time of validity, 50 ms before its
    /// arrival, is after the boot).
    fn new() -> Self {
        let clock = Clock::default();
        let t = clock.0.clone();
        t.set(1_000_000);
        let uart = DvlUart::default();
        let sensors = WithDvl {
            inner: SENSORS,
            // No wire time (an in-memory UART); 64 bytes and one line a pass, as the node
            // images.
            dvl: DvlPort::new(uart.clone(), VelocityGate::default(), 0).with_poll_limits(64, 1),
        };
        let pwm = [Pwm::default(), Pwm::default(), Pwm::default()];
        let node = Node::new(pwm, Port::default(), clock, sensors, NodeConfig::DEFAULT).unwrap();
        Self {
            node,
            clock: t,
            uart,
        }
    }

    /// Tick at each IMU time (2.5 ms) up to and including `t_us`.
    fn run_to(&mut self, t_us: u64) {
        while self.clock.get() < t_us {
            self.clock.set(self.clock.get() + 2_500);
            self.node.tick();
        }
    }

    fn write(&self, text: &str) {
        self.uart.0.borrow_mut().extend(text.as_bytes());
    }

    fn uplinks(&mut self) -> Vec<Uplink> {
        let tx = std::mem::take(&mut self.node.parts_mut().1.tx);
        let mut d = LinkDecoder::<Uplink>::new();
        tx.iter()
            .filter_map(|&b| d.push(b))
            .map(|f| match f {
                LinkFrame::Frame { msg, .. } => msg,
                LinkFrame::Dropped(r) => panic!("uplink dropped: {r:?}"),
            })
            .collect()
    }
}

#[test]
fn an_admitted_report_rides_in_the_next_uplink_with_its_age() {
    let mut b = DvlBench::new();
    b.run_to(1_002_500);
    // The whole line waits after the pass at 2.5 ms: read 64 bytes a pass, it ends in the
    // second pass after (7.5 ms), stamped 50 ms before (the DVL's own latency); the uplink
    // at 20 ms says 62.5 ms, rounded to 63.
    let line = wrz(GOOD);
    assert!((65..=128).contains(&line.len()), "{}", line.len());
    b.write(&line);
    b.run_to(1_020_000);
    let ups = b.uplinks();
    assert_eq!(ups.len(), 1);
    assert_eq!(
        ups[0].dvl,
        Some(UplinkDvl {
            age_ms: 63,
            velocity_mm_s: [250, -100],
            std_mm_s: 10,
        })
    );
    assert_eq!(ups[0].counters.dvl_refused, 0);
    // Once: the next uplink has none.
    b.run_to(1_040_000);
    assert_eq!(b.uplinks()[0].dvl, None);
}

#[test]
fn the_pass_that_seals_an_uplink_reads_no_dvl_byte() {
    let mut b = DvlBench::new();
    b.run_to(1_017_500);
    let line = wrz(GOOD);
    b.write(&line);
    // The uplink's pass at 20 ms leaves the line in the UART.
    b.run_to(1_020_000);
    assert_eq!(b.uart.0.borrow().len(), line.len());
    assert_eq!(b.uplinks()[0].dvl, None);
    // Parsed in the two passes after it (ended at 25 ms), in the 40 ms uplink: 65 ms old.
    b.run_to(1_025_000);
    assert!(b.uart.0.borrow().is_empty());
    b.run_to(1_040_000);
    let up = b.uplinks()[0];
    assert_eq!(
        up.dvl.map(|d| (d.age_ms, d.velocity_mm_s)),
        Some((65, [250, -100]))
    );
}

#[test]
fn refused_lines_are_counted_in_the_uplink_and_send_nothing() {
    let mut b = DvlBench::new();
    b.run_to(1_002_500);
    // A bad checksum (one digit changed), no bottom lock, then garbage.
    let mut bad = wrz(GOOD);
    bad.replace_range(5..6, "3");
    b.write(&bad);
    b.write(&wrz("0.000,0.000,0.000,n,-1.00,2.707,0;0;0;0;0;0;0;0;0,1767225600000000,1767225600000000,1075.51,1"));
    b.write("$GPGGA,garbage\r\n");
    b.run_to(1_040_000);
    let ups = b.uplinks();
    assert_eq!(ups.len(), 2);
    assert!(ups.iter().all(|u| u.dvl.is_none()), "{ups:?}");
    assert_eq!(ups[1].counters.dvl_refused, 3, "{:?}", ups[1].counters);
    // A good line after them is taken.
    b.write(&wrz(GOOD));
    b.run_to(1_060_000);
    let up = b.uplinks()[0];
    assert!(up.dvl.is_some());
    assert_eq!(up.counters.dvl_refused, 3);
}
