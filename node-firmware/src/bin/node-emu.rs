//! The emulated node (`docs/deployment.md`, "Emulating the topside layout"): the
//! node link on USART1, the host's sensors and clock on USART2 (`firmware::harness`), on QEMU
//! `netduinoplus2`, in the node's budget (32 KiB flash, 8 KiB RAM: `memory-node.x`).
//! defmt over semihosting; panics and HardFaults exit QEMU with a failure code.
//! On the host this binary is an empty stub so `cargo test --workspace` builds.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod image {
    use cortex_m as _;
    use defmt_semihosting as _;

    #[cortex_m_rt::entry]
    fn main() -> ! {
        node_firmware::emu_board::run()
    }

    firmware::emulated_fault_handlers!(with_location = false);
}

#[cfg(not(target_os = "none"))]
fn main() {
    println!("the node-emu image is built with --target thumbv7em-none-eabihf");
}
