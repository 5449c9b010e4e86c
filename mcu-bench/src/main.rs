//! `mcu-bench`: instruction counts and stack use of the control path on an emulated
//! Cortex-M4F (QEMU `netduinoplus2`, an STM32F405, run with `-icount shift=0,align=off,sleep=off`
//! so TIM2 advances exactly one tick per instruction).
//!
//! Run it with `scripts/mcu-cost.sh`. On the host this builds to a smoke run of the same
//! measurements with a nanosecond clock, so `cargo test` / `cargo clippy --workspace` keep
//! working; the numbers that matter are the ones from QEMU.
#![cfg_attr(target_os = "none", no_std, no_main)]

mod bench;
mod instruments_bench;
mod loop_bench;
mod nav_bench;
mod onboard_bench;
mod plant;
#[cfg(feature = "topside")]
mod topside_bench;

#[cfg(target_os = "none")]
mod board;

/// Run every measurement: the core's items, the estimator's, the loop's. Returns false if
/// the controller could not be built. The three modules share only [`bench`]'s timing.
pub fn run_all<P: bench::Platform>(p: &P) -> bool {
    let b = bench::Bench::new(p);
    p.print(format_args!(
        "mcu-bench: {} calls per item, counter overhead {} ticks subtracted",
        bench::CALLS,
        b.overhead()
    ));
    if !bench::run_core(&b, p) {
        return false;
    }
    nav_bench::run_nav(&b, p);
    loop_bench::run_loop(&b, p);
    onboard_bench::run_onboard(&b, p);
    instruments_bench::run_instruments(&b, p);
    #[cfg(feature = "topside")]
    topside_bench::run_topside(&b, p);
    if let Some(hw) = p.stack_high_water() {
        p.print(format_args!(
            "STACK high_water={hw} (from the top of RAM, whole bench program incl. its own frames)"
        ));
    }
    true
}

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
    if !run_all(&Host(std::time::Instant::now())) {
        std::process::exit(1);
    }
}
