//! The topside image on QEMU `netduinoplus2` (issue 25, `docs/deployment.md`, "Emulating the
//! topside layout"): the App at the surface, the tether on USART1, the node link on USART2,
//! the host's clock on USART3 (`firmware::harness`). defmt over semihosting; panics and
//! HardFaults exit QEMU with a failure code.
//!
//! `cargo build -p firmware --release --target thumbv7em-none-eabihf --features topside-board --bin topside-emu`.
//! On the host this binary is an empty stub so `cargo test --workspace` builds.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod image {
    use cortex_m as _;
    use cortex_m_rt::{exception, ExceptionFrame};
    use cortex_m_semihosting::debug::{self, EXIT_FAILURE};
    use defmt_semihosting as _;

    #[cortex_m_rt::entry]
    fn main() -> ! {
        firmware::topside_emu_board::run()
    }

    #[panic_handler]
    fn panic(info: &core::panic::PanicInfo) -> ! {
        match info.location() {
            Some(l) => defmt::error!("panic at {=str}:{=u32}", l.file(), l.line()),
            None => defmt::error!("panic"),
        }
        debug::exit(EXIT_FAILURE);
        loop {
            cortex_m::asm::bkpt();
        }
    }

    // cortex-m-rt requires the HardFault handler to be declared `unsafe`.
    // SAFETY: it only logs and exits through semihosting; it never returns.
    #[allow(unsafe_code)]
    #[exception]
    unsafe fn HardFault(ef: &ExceptionFrame) -> ! {
        defmt::error!("HardFault at pc {=u32:#x}", ef.pc());
        debug::exit(EXIT_FAILURE);
        loop {
            cortex_m::asm::bkpt();
        }
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    println!("the topside-emu image is built with --target thumbv7em-none-eabihf");
}
