//! The node image (docs/deployment.md): the vehicle's thin electronics in the
//! paper's layout, where the control loop runs at the surface. IMU and pressure up, pulse
//! widths down the node link; nothing of the controller core. Built for QEMU
//! `netduinoplus2` into the node budget (32 KiB flash, 8 KiB RAM: `memory-node.x`).
//! On the host this binary is an empty stub so `cargo test --workspace` builds.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod image {
    use cortex_m as _;
    use defmt_semihosting as _;

    #[cortex_m_rt::entry]
    fn main() -> ! {
        node_firmware::board::run()
    }

    firmware::emulated_fault_handlers!(with_location = false);
}

#[cfg(not(target_os = "none"))]
fn main() {
    println!("the node image is built with --target thumbv7em-none-eabihf");
}
