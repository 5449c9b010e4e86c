//! The emulated node (`docs/deployment.md`, "Emulating the topside layout"): the
//! [`Node`] role on QEMU `netduinoplus2` with its sensors and its clock supplied by the host
//! (the plant), as [`crate::board`] is the node on the real part.
//!
//! - USART1 (QEMU `-serial` 0): the node link, the interrupt-driven
//!   [`firmware::board::Tether`] at 115,200 Bd;
//! - USART2 (`-serial` 1): the harness ([`firmware::harness`]), received into an
//!   interrupt-driven ring (the onboard image's DVL ring; the core sleeps while it waits
//!   for a step), sent polled: each
//!   [`NodeStep`] gives the node its time, an IMU sample and a pressure; the node runs at that
//!   time and answers with a [`NodeReport`], the pulses it applies;
//! - USART3 (`-serial` 2, PB10 / PB11): the DVL, its A50 `wrz` lines as the instrument sends
//!   them, into a 256-byte interrupt-driven ring (the emulated onboard board's receive-only
//!   USART3 port, [`firmware::board::health_pins::HealthUart`]), read by the node image's
//!   [`DvlPort`] ([`crate::board::node_dvl_port`]); its bytes are not counted in the step (a
//!   line that reaches the node after its step is read at the next one, stamped then);
//! - ESCs: TIM3 CH1/CH2/CH3 on PA6/PA7/PB0, as the real node (QEMU drives no pin; the report
//!   is what the host reads);
//! - default clocks (no PLL), no watchdog (the host paces the node and may pause it).

use core::cell::Cell;
use core::sync::atomic::Ordering;
use embedded_io::ReadReady;
use firmware::board::dvl_uart::{DvlUart, DVL_US_PER_BYTE};
use firmware::board::health_pins::HealthUart;
use firmware::board::{sleep_unless, start_tether, tether_rx_pending, Tim2Clock, RX_LOST};
use firmware::harness::uart::{wait_for, HarnessUart};
use firmware::harness::{
    node_pass, CountingPort, HarnessDecoder, HarnessInputs, HostClock, NodeReport, NodeStep,
};
use firmware::node::{Node, NodeConfig};
use firmware::node_link::LINK_BAUD;
use firmware::sensors::dvl::{a50::VelocityGate, DvlPort, WithDvl};
use stm32f4xx_hal::{
    pac::{self, TIM3},
    prelude::*,
    timer::ErasedChannel,
};

/// An ESC output.
type Pwm = ErasedChannel<TIM3>;

fn halt() -> ! {
    cortex_m::peripheral::SCB::sys_reset()
}

/// Bring the emulated node up and serve the host's steps forever.
pub fn run() -> ! {
    let Some(dp) = pac::Peripherals::take() else {
        halt()
    };
    let mut rcc = dp.RCC.constrain();
    let gpioa = dp.GPIOA.split(&mut rcc);
    let gpiob = dp.GPIOB.split(&mut rcc);
    let config = NodeConfig::DEFAULT;
    let (_pwm, (ch1, ch2, ch3, _)) = dp.TIM3.pwm_us(config.pwm_period_us.micros(), &mut rcc);
    let pwm: [Pwm; 3] = [
        ch1.with(gpioa.pa6).erase(),
        ch2.with(gpioa.pa7).erase(),
        ch3.with(gpiob.pb0).erase(),
    ];
    let tether = start_tether(dp.USART1, (gpioa.pa9, gpioa.pa10), &mut rcc);
    let Ok(harness) = dp
        .USART2
        .serial::<u8>((gpioa.pa2, gpioa.pa3), LINK_BAUD.bps(), &mut rcc)
    else {
        halt()
    };
    let (tx, rx) = harness.split();
    // The harness's receive ring is the onboard image's USART2 ring (its DVL's).
    let mut harness = HarnessUart::new(DvlUart::start(rx), tx);
    let Ok(dvl) = dp
        .USART3
        .serial::<u8>((gpiob.pb10, gpiob.pb11), LINK_BAUD.bps(), &mut rcc)
    else {
        halt()
    };
    let (_dvl_tx, dvl_rx) = dvl.split();
    let dvl = crate::board::node_dvl_port(DvlPort::new(
        HealthUart::start(dvl_rx),
        VelocityGate::default(),
        DVL_US_PER_BYTE,
    ));
    let tim2 = Tim2Clock::start(dp.TIM2.counter::<16_000_000>(&mut rcc));
    let now_us = Cell::new(0u64);
    let inputs = HarnessInputs::new();
    let mut node = match Node::new(
        pwm,
        CountingPort::new(tether),
        HostClock::new(&now_us, tim2),
        WithDvl {
            inner: inputs.sensors(),
            dvl,
        },
        config,
    ) {
        Ok(n) => n,
        Err(_) => halt(),
    };
    // Neutral is written (by `Node::new`); now the outputs may drive the ESCs.
    node.parts_mut().0.iter_mut().for_each(Pwm::enable);
    // The hello: the host waits for it before it sends (QEMU drops bytes that arrive before
    // the receiver is enabled).
    harness.send(&NodeReport {
        t_us: 0,
        pulse_us: node.output_us(),
        status: node.status(0),
        accepted: 0,
        link_rx_bytes: 0,
        link_tx_bytes: 0,
        refused: None,
    });
    defmt::info!("node-emu ready: node link USART1, harness USART2");
    let mut decoder = HarnessDecoder::<NodeStep>::new();
    loop {
        let step = harness.recv(&mut decoder, |rx| {
            sleep_unless(|| rx.read_ready().ok() == Some(true))
        });
        let received = wait_for(step.link_rx_bytes, || {
            node.parts_mut()
                .1
                .read_bytes()
                .wrapping_add(tether_rx_pending())
                .wrapping_add(RX_LOST.load(Ordering::Relaxed))
        });
        let report = node_pass(&mut node, &now_us, &inputs, &step, received);
        harness.send(&report);
    }
}
