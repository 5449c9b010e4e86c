//! The node image (issue 25, docs/deployment.md): the vehicle's thin electronics in the
//! paper's layout, where the control loop runs at the surface. IMU and pressure up, pulse
//! widths down the node link; nothing of the controller core. Built for QEMU
//! `netduinoplus2` into the node budget (32 KiB flash, 8 KiB RAM: `memory-node.x`).
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
        node_firmware::board::run()
    }

    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        defmt::error!("node panic");
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
        defmt::error!("node HardFault at pc {=u32:#x}", ef.pc());
        debug::exit(EXIT_FAILURE);
        loop {
            cortex_m::asm::bkpt();
        }
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    println!("the node image is built with --target thumbv7em-none-eabihf");
}
