//! Topside image (docs/deployment.md): the STM32F405 board in the surface box runs
//! the App; its thrusters and sensors are the node link on USART2. defmt over RTT, panic-probe.
//!
//! `cargo build -p firmware --release --target thumbv7em-none-eabihf --bin topside`;
//! `cargo run ... --bin topside` flashes it through a probe (probe-rs, `.cargo/config.toml`).
//! On the host this binary is an empty stub so `cargo test --workspace` builds.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod image {
    use cortex_m as _;
    use defmt_rtt as _;
    use panic_probe as _;

    #[cortex_m_rt::entry]
    fn main() -> ! {
        firmware::topside_board::run()
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    println!("the topside image is built with --target thumbv7em-none-eabihf");
}
