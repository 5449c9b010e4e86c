//! The emulated topside board (`docs/deployment.md`, "Emulating the topside
//! layout"): the topside image on QEMU `netduinoplus2`, as [`crate::board::Variant::Qemu`]
//! is the onboard image there. The same [`App`] over the node link as the surface board
//! ([`crate::topside_board`]); what differs is the board:
//!
//! - default clocks, no PLL (QEMU 7.2 does not model the RCC); panics and HardFaults exit
//!   QEMU through semihosting with a failure code (the `topside-emu` binary);
//! - USART1 (QEMU `-serial` 0): the tether to the PC, today's protocol, the interrupt-driven
//!   [`crate::board::Tether`];
//! - USART2 (`-serial` 1): the node link, the interrupt-driven [`NodePort`];
//! - USART3 (`-serial` 2): the harness, received into an interrupt-driven ring (the core
//!   sleeps while it waits for a step), sent polled: the host is the clock
//!   ([`crate::harness::TopsideStep`]). The App runs fixed-rate, as on the surface board (a
//!   step on each accepted uplink, the 25 ms fallback period), on the host's time
//!   ([`HostClock`]); TIM2 gives the App's loop figures (instructions under `-icount
//!   shift=0`, as `scripts/mcu-cost.sh` runs it);
//! - no watchdog: the host paces the board, and may pause it.

use crate::app::{App, Config, Timing};
use crate::board::health_pins::HealthUart;
use crate::board::{sleep_unless, start_tether, tether_rx_pending, Tim2Clock, RX_LOST};
use crate::harness::uart::{wait_for, HarnessUart};
use crate::harness::{
    topside_pass, CountingPort, HarnessDecoder, HostClock, TopsideReport, TopsideStep,
};
use crate::protocol::Board;
use crate::topside_board::{
    node_rx_pending, start_node_port, FALLBACK_PERIOD_US, NODE_BAUD, NODE_RX_LOST,
};
use crate::topside_link::{NodeBridge, TopsideConfig, TopsideLink};
use crate::Monotonic;
use controller_core::controller::{Controller, Gains};
use controller_core::params::Vehicle;
use core::cell::Cell;
use core::sync::atomic::Ordering;
use embedded_io::ReadReady;
use stm32f4xx_hal::{pac, prelude::*};

fn halt() -> ! {
    cortex_m::peripheral::SCB::sys_reset()
}

/// The topside's node-link session on the emulated board: QEMU models no unique id, so the
/// boot's TIM2 count (the instruction count under `-icount`, else the host's nanoseconds
/// since QEMU started) mixed, never 0.
fn session(ticks: u32) -> u32 {
    (ticks.wrapping_mul(0x9E37_79B9) ^ 0x2570_0000).max(1)
}

/// Bring the emulated surface board up and serve the host's steps forever.
pub fn run() -> ! {
    let Some(dp) = pac::Peripherals::take() else {
        halt()
    };
    let mut rcc = dp.RCC.constrain();
    let gpioa = dp.GPIOA.split(&mut rcc);
    let gpiob = dp.GPIOB.split(&mut rcc);
    let tether = start_tether(dp.USART1, (gpioa.pa9, gpioa.pa10), &mut rcc);
    let node_port = start_node_port(dp.USART2, (gpioa.pa2, gpioa.pa3), &mut rcc);
    let Ok(harness) = dp
        .USART3
        .serial::<u8>((gpiob.pb10, gpiob.pb11), NODE_BAUD.bps(), &mut rcc)
    else {
        halt()
    };
    let (tx, rx) = harness.split();
    // The harness's receive ring is the onboard image's USART3 ring (its health inputs).
    let mut harness = HarnessUart::new(HealthUart::start(rx), tx);
    // Default clocks: the timer clock is 16 MHz, prescaler 0, one tick an instruction.
    let mut tim2 = Tim2Clock::start(dp.TIM2.counter::<16_000_000>(&mut rcc));
    let ticks = tim2.ticks();
    let now_us = Cell::new(0u64);
    let config = Config {
        timing: Timing::FixedRate {
            control_period_us: FALLBACK_PERIOD_US,
            telemetry_period_us: 100_000,
        },
        ..Config::fixed_rate(Board::QemuNetduinoPlus2)
    };
    let bridge = NodeBridge::new(config.pwm_period_us());
    let Ok(controller) = Controller::new(Vehicle::observer(), Gains::default()) else {
        halt()
    };
    let Ok(mut app) = App::with_sensors(
        bridge.thrusters(),
        CountingPort::new(tether),
        HostClock::new(&now_us, tim2),
        controller,
        config,
        bridge.sensors(),
    ) else {
        halt()
    };
    let mut link = TopsideLink::new(
        &bridge,
        CountingPort::new(node_port),
        TopsideConfig::new(session(ticks)),
    );
    app.hello();
    let mut uplink_steps = 0u32;
    // The harness's hello: the host waits for it before it sends (bytes sent before the
    // receiver is enabled are lost in QEMU).
    harness.send(&TopsideReport {
        t_us: 0,
        tether_rx_bytes: 0,
        tether_tx_bytes: app.parts_mut().1.written_bytes(),
        link_rx_bytes: 0,
        link_tx_bytes: 0,
        uplink_steps,
        refused: None,
    });
    defmt::info!("topside-emu ready: tether USART1, node link USART2, harness USART3");
    let mut decoder = HarnessDecoder::<TopsideStep>::new();
    loop {
        let step = harness.recv(&mut decoder, |rx| {
            sleep_unless(|| rx.read_ready().ok() == Some(true))
        });
        let tether_in = wait_for(step.tether_rx_bytes, || {
            app.parts_mut()
                .1
                .read_bytes()
                .wrapping_add(tether_rx_pending())
                .wrapping_add(RX_LOST.load(Ordering::Relaxed))
        });
        let link_in = wait_for(step.link_rx_bytes, || {
            link.serial_mut()
                .read_bytes()
                .wrapping_add(node_rx_pending())
                .wrapping_add(NODE_RX_LOST.load(Ordering::Relaxed))
        });
        let report = topside_pass(
            &mut app,
            &mut link,
            &now_us,
            &step,
            tether_in,
            link_in,
            &mut uplink_steps,
        );
        harness.send(&report);
    }
}
