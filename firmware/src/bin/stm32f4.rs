//! Firmware image for the STM32F405 board: defmt over RTT, panic-probe.
//!
//! `cargo build -p firmware --release --target thumbv7em-none-eabihf --bin stm32f4`;
//! `cargo run ... --bin stm32f4` flashes it through a probe (probe-rs, `.cargo/config.toml`).
//! On the host this binary is an empty stub so `cargo test --workspace` builds.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod image {
    use cortex_m as _;
    use defmt_rtt as _;
    use panic_probe as _;

    #[cortex_m_rt::entry]
    fn main() -> ! {
        firmware::board::run(firmware::board::Variant::Stm32f4)
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    println!("the stm32f4 image is built with --target thumbv7em-none-eabihf");
}
