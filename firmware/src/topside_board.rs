//! The topside image's board: the onboard image's STM32F405 board in the surface
//! box, running the same [`App`] with its thrusters and sensors at the far end of the node
//! link ([`crate::topside_link`]).
//!
//! - USART1 (PA9/PA10, 115,200 Bd): the tether to the PC, today's protocol unchanged
//!   ([`crate::board::Tether`]): `host-sim topside` cannot tell this board from a vehicle;
//! - USART2 (PA2 TX / PA3 RX, 115,200 Bd): the node link, interrupt-driven both ways
//!   ([`NodePort`]);
//! - HSE 8 MHz + PLL to 168 MHz, TIM2 at 1 MHz, IWDG at 250 ms, as the onboard image; no ESC
//!   and no sensor on this board.
//!
//! The loop: `App::tick` (the tether, the fallback control period, telemetry), then the node
//! link; an accepted uplink runs the control step at once (`App::step_now`) and its pulses go
//! down in the next downlink.
#![allow(unsafe_code)]

use crate::app::{App, Config, Monotonic, Timing};
use crate::board::{start_tether, Tim2Clock, HSE_HZ, SYSCLK_HZ, WATCHDOG_MS};
use crate::protocol::Board;
use crate::topside_link::{NodeBridge, TopsideConfig, TopsideLink};
use controller_core::controller::{Controller, Gains};
use controller_core::params::Vehicle;
use core::cell::RefCell;
use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::interrupt::Mutex;
use heapless::Deque;
use stm32f4xx_hal::{
    pac::{self, interrupt, USART2},
    prelude::*,
    rcc::Config as RccConfig,
    serial::{Rx, Tx},
    watchdog::IndependentWatchdog,
};

/// The App's own control period, the fallback when no uplink arrives, microseconds.
pub const FALLBACK_PERIOD_US: u32 = 25_000;

/// The node link's baud rate.
pub const NODE_BAUD: u32 = crate::node_link::LINK_BAUD;

/// The node link's rings (a frame is at most 86 bytes) and USART2, shared with its
/// interrupt.
struct Link {
    rx: Deque<u8, 256>,
    tx: Deque<u8, 128>,
    usart: Option<(Rx<USART2>, Tx<USART2>)>,
}

/// Rings and port in one cell (the `None` is not zero: this static is in `.data`).
static LINK: Mutex<RefCell<Link>> = Mutex::new(RefCell::new(Link {
    rx: Deque::new(),
    tx: Deque::new(),
    usart: None,
}));

/// Node-link bytes lost: the receive ring was full, or the USART reported an overrun or
/// framing error.
pub static NODE_RX_LOST: AtomicU32 = AtomicU32::new(0);

/// Run `f` on the link in a critical section (`try_borrow_mut`: no panic path; inside the
/// critical section the borrow cannot fail).
fn with_link<R>(f: impl FnOnce(&mut Link) -> R) -> Option<R> {
    cortex_m::interrupt::free(|cs| Some(f(&mut *LINK.borrow(cs).try_borrow_mut().ok()?)))
}

#[interrupt]
fn USART2() {
    with_link(|l| {
        let Some((rx, tx)) = l.usart.as_mut() else {
            return;
        };
        send_queued(tx, &mut l.tx);
        loop {
            let lost = match rx.read() {
                Ok(b) => l.rx.push_back(b).is_err(),
                Err(nb::Error::WouldBlock) => break,
                // Overrun or framing error: cleared by the read; the CRC drops the frame.
                Err(nb::Error::Other(_)) => true,
            };
            if lost {
                NODE_RX_LOST.fetch_add(1, Ordering::Relaxed);
            }
        }
    });
}

fn send_queued(tx: &mut Tx<USART2>, out: &mut Deque<u8, 128>) {
    while tx.is_tx_empty() {
        let Some(b) = out.pop_front() else {
            tx.unlisten();
            return;
        };
        let _ = embedded_hal_nb::serial::Write::write(tx, b);
    }
    tx.listen();
}

/// The node link's port, interrupt-driven both ways; never waits.
pub struct NodePort;

/// Bytes received on the node link and not yet read by the loop (the emulated layout's
/// harness counts what has arrived: read, waiting here, and [`NODE_RX_LOST`]).
pub fn node_rx_pending() -> u32 {
    with_link(|l| l.rx.len() as u32).unwrap_or(0)
}

/// USART2 (PA2 TX, PA3 RX) as the interrupt-driven node link at [`NODE_BAUD`]. Resets the
/// MCU if the port cannot be set up.
pub fn start_node_port(
    usart: USART2,
    pins: (stm32f4xx_hal::gpio::PA2, stm32f4xx_hal::gpio::PA3),
    rcc: &mut stm32f4xx_hal::rcc::Rcc,
) -> NodePort {
    let Ok(node) = usart.serial::<u8>(pins, NODE_BAUD.bps(), rcc) else {
        halt()
    };
    let (tx, mut rx) = node.split();
    rx.listen();
    with_link(|l| l.usart = Some((rx, tx)));
    // SAFETY: the handler touches `LINK` only inside critical sections, initialized above.
    unsafe { cortex_m::peripheral::NVIC::unmask(pac::Interrupt::USART2) };
    NodePort
}

impl embedded_io::ErrorType for NodePort {
    type Error = core::convert::Infallible;
}

impl embedded_io::ReadReady for NodePort {
    fn read_ready(&mut self) -> Result<bool, Self::Error> {
        Ok(with_link(|l| !l.rx.is_empty()).unwrap_or(false))
    }
}

impl embedded_io::Read for NodePort {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        Ok(with_link(|l| {
            let mut n = 0;
            for b in buf.iter_mut() {
                let Some(x) = l.rx.pop_front() else { break };
                *b = x;
                n += 1;
            }
            n
        })
        .unwrap_or(0))
    }
}

impl embedded_io::WriteReady for NodePort {
    fn write_ready(&mut self) -> Result<bool, Self::Error> {
        Ok(with_link(|l| !l.tx.is_full()).unwrap_or(false))
    }
}

impl embedded_io::Write for NodePort {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        Ok(with_link(|l| {
            let n = buf
                .iter()
                .take_while(|&&b| l.tx.push_back(b).is_ok())
                .count();
            if let Some((_, tx)) = l.usart.as_mut() {
                send_queued(tx, &mut l.tx);
            }
            n
        })
        .unwrap_or(0))
    }

    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

fn halt() -> ! {
    cortex_m::peripheral::SCB::sys_reset()
}

/// The topside's session: the MCU's 96-bit unique id folded, mixed with the clock at the
/// end of the set-up (so a restarted topside is, with near certainty, a new session), never 0.
fn session(clock_ticks: u32) -> u32 {
    /// STM32F4 unique device id (RM0090 39.1).
    const UID: *const u32 = 0x1FFF_7A10 as *const u32;
    let mut s = clock_ticks.wrapping_mul(0x9E37_79B9);
    for i in 0..3 {
        // SAFETY: the three aligned words of the read-only unique id (RM0090 39.1).
        let w = unsafe { core::ptr::read_volatile(UID.wrapping_add(i)) };
        s = (s ^ w).wrapping_mul(0x85EB_CA6B).rotate_left(13);
    }
    s.max(1)
}

/// Bring the surface board up and run the topside forever.
pub fn run() -> ! {
    let Some(dp) = pac::Peripherals::take() else {
        halt()
    };
    let mut rcc = dp.RCC.freeze(
        RccConfig::hse(HSE_HZ.Hz())
            .sysclk(SYSCLK_HZ.Hz())
            .pclk1(42.MHz()),
    );
    let mut watchdog = IndependentWatchdog::new(dp.IWDG);
    watchdog.stop_on_debug(&dp.DBGMCU, true);
    watchdog.start(WATCHDOG_MS.millis());
    let gpioa = dp.GPIOA.split(&mut rcc);
    let tether = start_tether(dp.USART1, (gpioa.pa9, gpioa.pa10), &mut rcc);
    let node_port = start_node_port(dp.USART2, (gpioa.pa2, gpioa.pa3), &mut rcc);
    let clock = Tim2Clock::start(dp.TIM2.counter::<1_000_000>(&mut rcc));
    // The step runs when an uplink arrives (every 20 ms); the App's own period is the
    // fallback, longer than the link's so that a slightly late uplink does not find a step
    // just run by the fallback.
    let config = Config {
        timing: Timing::FixedRate {
            control_period_us: FALLBACK_PERIOD_US,
            telemetry_period_us: 100_000,
        },
        ..Config::fixed_rate(Board::Stm32f4)
    };
    let bridge = NodeBridge::new(config.pwm_period_us());
    let Ok(controller) = Controller::new(Vehicle::observer(), Gains::default()) else {
        halt()
    };
    let Ok(mut app) = App::with_sensors(
        bridge.thrusters(),
        tether,
        clock,
        controller,
        config,
        bridge.sensors(),
    ) else {
        halt()
    };
    let ticks = app.parts_mut().2.now_us() as u32;
    let mut link = TopsideLink::new(&bridge, node_port, TopsideConfig::new(session(ticks)));
    app.hello();
    defmt::info!("topside ready: the node link on USART2");
    loop {
        app.tick();
        let now = app.now_us();
        let armed = app.autopilot().armed();
        if link.poll(now, armed) {
            app.step_now();
        }
        link.send_if_due(now, armed);
        watchdog.feed();
    }
}
