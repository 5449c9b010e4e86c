//! Everything that touches the emulated STM32F405: the TIM2 instruction counter, stack
//! painting, semihosting output and exit, the entry point and the fault handlers.
//!
//! The only module with `unsafe`: register and linker-symbol accesses, each with its reason.
#![allow(unsafe_code)]

use crate::bench::Platform;
use core::fmt;
use core::ptr::{addr_of, read_volatile, write_volatile};
use cortex_m_rt::{entry, exception, ExceptionFrame};
use cortex_m_semihosting::{debug, hprintln};

/// RCC APB1 peripheral clock enable register (RM0090 7.3.13); bit 0 = TIM2EN.
const RCC_APB1ENR: *mut u32 = 0x4002_3840 as *mut u32;
/// TIM2 (RM0090 18.4), a 32-bit general-purpose timer.
const TIM2_BASE: usize = 0x4000_0000;
const TIM2_CR1: *mut u32 = TIM2_BASE as *mut u32;
const TIM2_EGR: *mut u32 = (TIM2_BASE + 0x14) as *mut u32;
const TIM2_CNT: *mut u32 = (TIM2_BASE + 0x24) as *mut u32;
const TIM2_PSC: *mut u32 = (TIM2_BASE + 0x28) as *mut u32;
const TIM2_ARR: *mut u32 = (TIM2_BASE + 0x2C) as *mut u32;

/// Pattern painted into the free stack.
const PAINT: u32 = 0xDEAD_BEEF;
/// Room left unpainted below the stack pointer read in `paint_stack`. It is a leaf that
/// makes no call after reading SP, so a few bytes suffice; a measured section that goes no
/// deeper than this margin below the paint point reports at most this many bytes.
const PAINT_MARGIN: usize = 8;

extern "C" {
    /// Top of the stack (cortex-m-rt: end of RAM).
    static _stack_start: u32;
    /// Lowest address the stack may grow to (cortex-m-rt: end of .bss/.uninit).
    static _stack_end: u32;
}

fn stack_top() -> usize {
    // Only the address of the linker symbol is taken (safe); it is never read.
    addr_of!(_stack_start) as usize
}

fn stack_bottom() -> usize {
    addr_of!(_stack_end) as usize
}

/// Start TIM2 free-running: clock on, prescaler 0, auto-reload 0xFFFF_FFFF, counter enabled.
fn tim2_start() {
    // SAFETY: fixed, aligned STM32F405 register addresses (RM0090 memory map); single core,
    // no interrupts, nothing else owns RCC or TIM2 in this program.
    unsafe {
        write_volatile(RCC_APB1ENR, read_volatile(RCC_APB1ENR) | 1);
        write_volatile(TIM2_CR1, 0);
        write_volatile(TIM2_PSC, 0);
        write_volatile(TIM2_ARR, 0xFFFF_FFFF);
        write_volatile(TIM2_EGR, 1); // UG: load PSC and ARR now
        write_volatile(TIM2_CNT, 0);
        write_volatile(TIM2_CR1, 1); // CEN
    }
}

/// The emulated MCU as a bench platform.
struct Qemu {
    /// Stack pointer when the stack was last painted.
    painted_from: core::cell::Cell<usize>,
}

impl Platform for Qemu {
    #[inline(always)]
    fn now(&self) -> u32 {
        // SAFETY: read of the TIM2 counter register (see `tim2_start`).
        unsafe { read_volatile(TIM2_CNT) }
    }

    fn print(&self, args: fmt::Arguments<'_>) {
        hprintln!("{}", args);
    }

    #[inline(never)]
    fn paint_stack(&self) {
        let sp = cortex_m::register::msp::read() as usize;
        let end = sp.saturating_sub(PAINT_MARGIN) & !3;
        let mut a = stack_bottom();
        while a < end {
            // SAFETY: [stack_bottom, sp - margin) is RAM reserved for the stack and below the
            // live stack pointer; no interrupt or exception uses it (none are enabled), so
            // nothing live is overwritten. Word aligned by construction.
            unsafe { write_volatile(a as *mut u32, PAINT) };
            a += 4;
        }
        self.painted_from.set(sp);
    }

    fn stack_used_since_paint(&self) -> Option<u32> {
        let low = lowest_touched()?;
        Some(self.painted_from.get().saturating_sub(low) as u32)
    }

    fn stack_high_water(&self) -> Option<u32> {
        let low = lowest_touched()?;
        Some(stack_top().saturating_sub(low) as u32)
    }

    #[inline(never)]
    fn hw_sqrt(&self, x: f32) -> Option<f32> {
        let mut bits = x.to_bits();
        // SAFETY: FPU instructions on s0, which is saved and restored around them (the
        // `sreg` operand class needs a target feature that is unstable to name on ARM); the FPU
        // is enabled by cortex-m-rt for the eabihf target. Touches only the 4 bytes it pushes.
        unsafe {
            core::arch::asm!(
                "vpush {{s0}}",
                "vmov s0, {b}",
                "vsqrt.f32 s0, s0",
                "vmov {b}, s0",
                "vpop {{s0}}",
                b = inout(reg) bits,
            );
        }
        let r = f32::from_bits(bits);
        Some(r)
    }
}

/// Lowest stack address that no longer holds the paint pattern.
fn lowest_touched() -> Option<usize> {
    let mut a = stack_bottom();
    let top = stack_top();
    while a < top {
        // SAFETY: aligned word inside the stack region [stack_bottom, stack_top).
        if unsafe { read_volatile(a as *const u32) } != PAINT {
            return Some(a);
        }
        a += 4;
    }
    None
}

#[entry]
fn main() -> ! {
    tim2_start();
    let q = Qemu {
        painted_from: core::cell::Cell::new(stack_top()),
    };
    // Paint once from reset depth, so the absolute high-water covers the whole program.
    q.paint_stack();
    let ok = crate::run_all(&q);
    debug::exit(if ok {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    #[allow(clippy::empty_loop)]
    loop {}
}

#[exception]
unsafe fn HardFault(ef: &ExceptionFrame) -> ! {
    hprintln!("mcu-bench: HardFault at pc={:#010x}", ef.pc());
    debug::exit(debug::EXIT_FAILURE);
    #[allow(clippy::empty_loop)]
    loop {}
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo<'_>) -> ! {
    hprintln!("mcu-bench: panic: {}", info);
    debug::exit(debug::EXIT_FAILURE);
    #[allow(clippy::empty_loop)]
    loop {}
}
