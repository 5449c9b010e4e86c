//! What every image for QEMU shares (`qemu`, `topside-emu`, `node-emu`, and `node`, which is
//! built for the emulated `netduinoplus2` too): a panic or a HardFault is logged through
//! defmt and ends QEMU through semihosting with a failure code, so that the host's test sees
//! a failure instead of a hung emulator (`../shared/QEMU_NOTES.md`: panic-probe and
//! defmt-rtt need a debug probe and hang under QEMU).

use cortex_m_semihosting::debug::{self, EXIT_FAILURE};

/// End the emulation with a failure code. Without a semihosting host (a real board with no
/// debugger) the call traps; the breakpoint loop then keeps the outputs where the watchdog
/// reset will put them back to neutral.
pub fn exit_failure() -> ! {
    debug::exit(EXIT_FAILURE);
    loop {
        cortex_m::asm::bkpt();
    }
}

/// The panic handler and the HardFault handler of an emulated image, defined in the binary
/// that invokes it (a `#[panic_handler]` and an `#[exception]` must live in the final
/// crate). The binary depends on `defmt` and `cortex-m-rt` itself. `with_location = false`
/// logs a panic without its file and line: reading them keeps every panic site's file name
/// in flash (+3,000 B on the 32 KiB node image, measured 2026-11-26).
#[macro_export]
macro_rules! emulated_fault_handlers {
    (with_location = $with_location:literal) => {
        #[panic_handler]
        fn panic(info: &core::panic::PanicInfo) -> ! {
            match info.location().filter(|_| $with_location) {
                Some(l) => defmt::error!("panic at {=str}:{=u32}", l.file(), l.line()),
                None => defmt::error!("panic"),
            }
            $crate::emulated::exit_failure()
        }

        // cortex-m-rt requires the HardFault handler to be declared `unsafe`.
        // SAFETY: it only logs and exits through semihosting; it never returns.
        #[allow(unsafe_code)]
        #[cortex_m_rt::exception]
        unsafe fn HardFault(ef: &cortex_m_rt::ExceptionFrame) -> ! {
            defmt::error!("HardFault at pc {=u32:#x}", ef.pc());
            $crate::emulated::exit_failure()
        }
    };
}
