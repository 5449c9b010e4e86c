//! Firmware image for QEMU `netduinoplus2` (an emulated STM32F405): defmt over semihosting,
//! panics and HardFaults exit QEMU through semihosting with a failure code, lock-step with
//! the host. See `docs/protocol.md` for how to run and drive it.
//! On the host this binary is an empty stub so `cargo test --workspace` builds.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod image {
    use cortex_m as _;
    use defmt_semihosting as _;

    #[cortex_m_rt::entry]
    fn main() -> ! {
        firmware::board::run(firmware::board::Variant::Qemu)
    }

    firmware::emulated_fault_handlers!(with_location = true);
}

#[cfg(not(target_os = "none"))]
fn main() {
    println!("the qemu image is built with --target thumbv7em-none-eabihf");
}
