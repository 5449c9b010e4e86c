//! The topside image on QEMU `netduinoplus2` (`docs/deployment.md`, "Emulating the
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
    use defmt_semihosting as _;

    #[cortex_m_rt::entry]
    fn main() -> ! {
        firmware::topside_emu_board::run()
    }

    firmware::emulated_fault_handlers!(with_location = true);
}

#[cfg(not(target_os = "none"))]
fn main() {
    println!("the topside-emu image is built with --target thumbv7em-none-eabihf");
}
