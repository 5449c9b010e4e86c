//! `mcu-bench`: instruction counts and stack use of the control path on an emulated
//! Cortex-M4F (QEMU `netduinoplus2`, an STM32F405, run with `-icount shift=0,align=off,sleep=off`
//! so TIM2 advances exactly one tick per instruction).
//!
//! Run it with `scripts/mcu-cost.sh`. On the host this builds to a smoke run of the same
//! measurements with a nanosecond clock, so `cargo test` / `cargo clippy --workspace` keep
//! working; the numbers that matter are the ones from QEMU.
#![cfg_attr(target_os = "none", no_std, no_main)]

mod bench;
mod loop_bench;
mod nav_bench;
mod plant;

#[cfg(target_os = "none")]
mod board;

#[cfg(not(target_os = "none"))]
fn main() {
    struct Host(std::time::Instant);
    impl bench::Platform for Host {
        fn now(&self) -> u32 {
            self.0.elapsed().as_nanos() as u32
        }
        fn print(&self, args: core::fmt::Arguments<'_>) {
            println!("{args}");
        }
        fn paint_stack(&self) {}
        fn stack_used_since_paint(&self) -> Option<u32> {
            None
        }
        fn stack_high_water(&self) -> Option<u32> {
            None
        }
    }
    println!("mcu-bench on the host: nanoseconds, not instructions (run scripts/mcu-cost.sh)");
    if !bench::run_all(&Host(std::time::Instant::now())) {
        std::process::exit(1);
    }
}
