//! The DVL's UART: USART2 (PA2 TX, PA3 RX; QEMU `-serial` 1) at the A50's default
//! 115,200 Bd 8N1, receive interrupt-driven into a 512-byte ring (a `wrz` report is under
//! 200 bytes, 15 a second at most: 44 ms of reports, two control periods), read by the loop
//! through `embedded-io` ([`crate::sensors::dvl::DvlPort`] parses it). Nothing is sent to
//! the DVL (its configuration is left as set through its web page).
//!
//! Not in the images of the `topside-board` feature: their USART2 is the node link.

use super::rx_ring::interrupt_rx_ring;
use stm32f4xx_hal::{pac::USART2, prelude::*};

/// The A50's default baud rate.
pub const DVL_BAUD: u32 = 115_200;
/// One byte's time on the wire at [`DVL_BAUD`] 8N1 (10 bits), microseconds.
pub const DVL_US_PER_BYTE: u32 = 10_000_000 / DVL_BAUD;

interrupt_rx_ring!(
    #[cfg(not(feature = "topside-board"))]
    DvlUart,
    USART2,
    512,
    DVL_RX_LOST
);

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
    let (_tx, rx) = serial.split();
    (DvlUart::start(rx), true)
}
