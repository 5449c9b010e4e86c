//! The board's start-up order and its loop, as code the host can test: the ESC
//! outputs get the ESC's neutral duty before any of them is enabled, and the watchdog is fed
//! only by a loop pass that came back. `board.rs` drives the STM32F4's TIM3 channels and IWDG
//! through these two traits; `tests/tests/board_startup.rs` (rov-tests) drives recording fakes.

use crate::app::{duty_for_pulse, App, Monotonic};
use crate::sensors::Sensors;
use controller_core::alloc::{PwmMap, ESC_NEUTRAL_US};
use embedded_hal::pwm::SetDutyCycle;
use embedded_io::{Read, ReadReady, Write, WriteReady};

/// A PWM output that is enabled (its pin driven) separately from setting its duty, like a
/// timer channel: until enabled it drives no pulse at all.
pub trait EscOutput: SetDutyCycle {
    /// Start driving the pin with the duty set.
    fn enable(&mut self);
}

/// A watchdog the main loop feeds.
pub trait Watchdog {
    /// Restart its countdown.
    fn feed(&mut self);
}

/// Set the ESC's neutral ([`ESC_NEUTRAL_US`]) on the three outputs, then enable them: an ESC
/// never sees a pulse the firmware did not choose (a timer channel enabled first would drive
/// its reset duty, 0 or whatever was left, until the neutral is written). Returns whether every
/// output took its duty.
pub fn start_outputs<P: EscOutput>(pwm: &mut [P; 3], period_us: u32) -> bool {
    let mut ok = true;
    let map = PwmMap {
        min_us: ESC_NEUTRAL_US,
        neutral_us: ESC_NEUTRAL_US,
        max_us: ESC_NEUTRAL_US,
        deadband_us: 0.0,
        linear_fraction: 0.0,
        max_forward_n: 1.0,
        max_reverse_n: 1.0,
    };
    for p in pwm.iter_mut() {
        let d = duty_for_pulse(ESC_NEUTRAL_US, &map, period_us, p.max_duty_cycle());
        ok &= p.set_duty_cycle(d).is_ok();
    }
    pwm.iter_mut().for_each(EscOutput::enable);
    ok
}

/// One pass of the board's main loop: the application's `tick`, then the watchdog. The feed
/// comes after the pass returns, so a pass stuck longer than the watchdog's window (a hung
/// peripheral, an endless loop) lets it reset the MCU, whose boot writes neutral.
#[inline(always)]
pub fn loop_pass<P, S, C, N, W>(app: &mut App<P, S, C, N>, watchdog: &mut W)
where
    P: SetDutyCycle,
    S: Read + ReadReady + Write + WriteReady,
    C: Monotonic,
    N: Sensors,
    W: Watchdog,
{
    app.tick();
    watchdog.feed();
}
