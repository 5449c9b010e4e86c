//! A USART's receiver drained by its interrupt into a ring that the loop reads through
//! `embedded-io`, never waiting: the DVL's USART2 and the emulated board's health inputs on
//! USART3. (QEMU hands a USART the next byte only after its data register is read, and only
//! between its own main-loop turns: read once per control step, a polled port would take a
//! byte or two a step.)

/// Define `$port`, a receive-only port on `$usart` (`stm32f4xx_hal::pac::$usart`) with a
/// `$len`-byte ring: its interrupt handler, `$port::start(rx)` (listens and unmasks the
/// interrupt) and `embedded_io::{Read, ReadReady}`. Bytes lost (ring full, overrun, framing
/// error) are counted in `$lost`. Attributes before the arguments go on the interrupt
/// handler (a `cfg` for an image whose USART is another role's).
macro_rules! interrupt_rx_ring {
    ($(#[$handler_attr:meta])* $port:ident, $usart:ident, $len:literal, $lost:ident) => {
        /// A receive-only port drained by its interrupt into a ring.
        pub struct $port;

        /// Bytes lost on this port: the ring was full, or the USART reported an overrun or
        /// framing error (the line or frame they hit is refused by its check).
        pub static $lost: core::sync::atomic::AtomicU32 = core::sync::atomic::AtomicU32::new(0);

        mod ring {
            use core::cell::RefCell;
            use cortex_m::interrupt::Mutex;
            use heapless::Deque;
            use stm32f4xx_hal::{pac::$usart, serial::Rx};

            pub(super) struct Ring {
                pub(super) bytes: Deque<u8, $len>,
                pub(super) rx: Option<Rx<$usart>>,
            }

            pub(super) static RING: Mutex<RefCell<Ring>> = Mutex::new(RefCell::new(Ring {
                bytes: Deque::new(),
                rx: None,
            }));

            pub(super) fn with<R>(f: impl FnOnce(&mut Ring) -> R) -> Option<R> {
                cortex_m::interrupt::free(|cs| Some(f(&mut *RING.borrow(cs).try_borrow_mut().ok()?)))
            }
        }

        // The `interrupt` attribute names the vector through `interrupt` in scope.
        #[allow(unused_imports)]
        use stm32f4xx_hal::pac::interrupt;

        $(#[$handler_attr])*
        #[interrupt]
        fn $usart() {
            ring::with(|r| {
                let Some(rx) = r.rx.as_mut() else {
                    return;
                };
                loop {
                    let lost = match embedded_hal_nb::serial::Read::read(rx) {
                        Ok(b) => r.bytes.push_back(b).is_err(),
                        Err(nb::Error::WouldBlock) => break,
                        Err(nb::Error::Other(_)) => true,
                    };
                    if lost {
                        $lost.fetch_add(1, core::sync::atomic::Ordering::Relaxed);
                    }
                }
            });
        }

        impl $port {
            /// Take `rx` (its receive interrupt on) and unmask the USART's interrupt.
            pub fn start(mut rx: stm32f4xx_hal::serial::Rx<stm32f4xx_hal::pac::$usart>) -> Self {
                use stm32f4xx_hal::prelude::*;
                rx.listen();
                ring::with(|r| r.rx = Some(rx));
                // SAFETY: the handler touches the ring only inside critical sections, and it
                // is initialized above.
                #[allow(unsafe_code)]
                unsafe {
                    cortex_m::peripheral::NVIC::unmask(stm32f4xx_hal::pac::Interrupt::$usart)
                };
                $port
            }
        }

        impl embedded_io::ErrorType for $port {
            type Error = core::convert::Infallible;
        }

        impl embedded_io::ReadReady for $port {
            fn read_ready(&mut self) -> Result<bool, Self::Error> {
                Ok(ring::with(|r| !r.bytes.is_empty()).unwrap_or(false))
            }
        }

        impl embedded_io::Read for $port {
            fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
                Ok(ring::with(|r| {
                    let mut n = 0;
                    for b in buf.iter_mut() {
                        let Some(x) = r.bytes.pop_front() else { break };
                        *b = x;
                        n += 1;
                    }
                    n
                })
                .unwrap_or(0))
            }
        }
    };
}

pub(crate) use interrupt_rx_ring;
