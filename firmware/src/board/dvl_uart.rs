//! The DVL's UART: USART2 (PA2 TX, PA3 RX; QEMU `-serial` 1) at the A50's default
//! 115,200 Bd 8N1, receive interrupt-driven into a 512-byte ring (a `wrz` report is under
//! 200 bytes, 15 a second at most: 44 ms of reports, two control periods), read by the loop
//! through `embedded-io` ([`crate::sensors::dvl::DvlPort`] parses it). Nothing is sent to
//! the DVL (its configuration is left as set through its web page).
//!
//! Not in the images of the `topside-board` feature: their USART2 is the node link.

use core::cell::RefCell;
use core::sync::atomic::AtomicU32;
use cortex_m::interrupt::Mutex;
use heapless::Deque;
#[cfg(not(feature = "topside-board"))]
use stm32f4xx_hal::pac::interrupt;
use stm32f4xx_hal::{
    pac::{self, USART2},
    prelude::*,
    serial::Rx,
};

/// The A50's default baud rate.
pub const DVL_BAUD: u32 = 115_200;
/// One byte's time on the wire at [`DVL_BAUD`] 8N1 (10 bits), microseconds.
pub const DVL_US_PER_BYTE: u32 = 10_000_000 / DVL_BAUD;

/// The receive ring and the receiver, shared with the USART2 interrupt.
struct DvlRx {
    ring: Deque<u8, 512>,
    rx: Option<Rx<USART2>>,
}

static DVL_RX: Mutex<RefCell<DvlRx>> = Mutex::new(RefCell::new(DvlRx {
    ring: Deque::new(),
    rx: None,
}));

/// DVL bytes lost: the ring was full, or the USART reported an overrun or framing error
/// (the line they hit is then refused by its CRC-8).
pub static DVL_RX_LOST: AtomicU32 = AtomicU32::new(0);

fn with_dvl<R>(f: impl FnOnce(&mut DvlRx) -> R) -> Option<R> {
    cortex_m::interrupt::free(|cs| Some(f(&mut *DVL_RX.borrow(cs).try_borrow_mut().ok()?)))
}

#[cfg(not(feature = "topside-board"))]
#[interrupt]
fn USART2() {
    with_dvl(|d| {
        let Some(rx) = d.rx.as_mut() else {
            return;
        };
        loop {
            let lost = match rx.read() {
                Ok(b) => d.ring.push_back(b).is_err(),
                Err(nb::Error::WouldBlock) => break,
                Err(nb::Error::Other(_)) => true,
            };
            if lost {
                DVL_RX_LOST.fetch_add(1, core::sync::atomic::Ordering::Relaxed);
            }
        }
    });
}

/// The DVL's receive side, for the loop.
pub struct DvlUart;

/// Start USART2 (PA2, PA3) at [`DVL_BAUD`] with its receive interrupt. If the port cannot
/// be set up (`false`, logged by the caller) the UART reads nothing: the vehicle runs
/// without a DVL.
pub fn start_dvl_uart(
    usart: USART2,
    pins: (stm32f4xx_hal::gpio::PA2, stm32f4xx_hal::gpio::PA3),
    rcc: &mut stm32f4xx_hal::rcc::Rcc,
) -> (DvlUart, bool) {
    let Ok(serial) = usart.serial::<u8>(pins, DVL_BAUD.bps(), rcc) else {
        return (DvlUart, false);
    };
    let (_tx, mut rx) = serial.split();
    rx.listen();
    with_dvl(|d| d.rx = Some(rx));
    // SAFETY: the handler touches `DVL_RX` only inside critical sections, initialized above.
    #[allow(unsafe_code)]
    unsafe {
        cortex_m::peripheral::NVIC::unmask(pac::Interrupt::USART2)
    };
    (DvlUart, true)
}

impl embedded_io::ErrorType for DvlUart {
    type Error = core::convert::Infallible;
}

impl embedded_io::ReadReady for DvlUart {
    fn read_ready(&mut self) -> Result<bool, Self::Error> {
        Ok(with_dvl(|d| !d.ring.is_empty()).unwrap_or(false))
    }
}

impl embedded_io::Read for DvlUart {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        Ok(with_dvl(|d| {
            let mut n = 0;
            for b in buf.iter_mut() {
                let Some(x) = d.ring.pop_front() else { break };
                *b = x;
                n += 1;
            }
            n
        })
        .unwrap_or(0))
    }
}
