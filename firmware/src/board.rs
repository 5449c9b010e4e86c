//! The STM32F405 boards: the only module that names the HAL (`stm32f4xx-hal` 0.23).
//!
//! Two variants of one chip:
//! - [`Variant::Stm32f4`]: the real board. HSE 8 MHz + PLL to 168 MHz, TIM2 as a 1 MHz
//!   clock, fixed-rate control at 50 Hz, telemetry at 10 Hz, IWDG at 250 ms.
//! - [`Variant::Qemu`]: QEMU `netduinoplus2`. Default clocks (QEMU 7.2 does not model the
//!   RCC: a PLL request hangs), TIM2 at prescaler 0 (one tick per instruction under
//!   `-icount shift=0`), lock-step on the host's time.
//!
//! Sensors (the real board only; QEMU models neither chip, the host sends readings over the
//! tether): the ICM-42688-P IMU on SPI2 (SCK PB13, MISO PB14, MOSI PB15, chip select PB12,
//! 8 MHz, mode 3), read at every control step; the MS5837-30BA on I2C1 (SCL PB8, SDA PB9,
//! 400 kHz), one conversion step per control step (start D1 / read D1 and start D2 / read D2,
//! then two idle passes: 10 Hz at OSR 8192, whose 18.08 ms fit in a 20 ms pass). A chip that
//! does not answer at boot is left out (logged); one that stops answering or reads out of
//! range gives no sample, and the estimator's timeouts raise `SENSOR_LOST` (neutral).
//!
//! The DVL (both): a Water Linked A50 on USART2 (PA2 / PA3, QEMU `-serial` 1) at 115,200 Bd,
//! its `wrz` reports parsed and gated on board ([`dvl_uart`], `sensors::dvl`). Health: on
//! the real board the power-sense module on ADC1 (PC0 voltage, PC1 current) and the leak
//! probe on PC2; on the emulated board the same readings from the host on USART3
//! ([`health_pins`]).
//!
//! Pins (both): TIM3 CH1/CH2/CH3 on PA6/PA7/PB0 drive the three ESCs (`F1x`, `F2x`, `F3z`);
//! USART1 on PA9 (TX) / PA10 (RX) at 115 200 Bd is the tether (QEMU `-serial` 0). Both ways
//! are interrupt-driven: receive into a 1 KiB ring, transmit from a 256-byte ring that the
//! application's frame queue fills as it empties (the loop never waits on the port).
#![allow(unsafe_code)]

pub mod dvl_uart;
pub mod health_pins;
mod rx_ring;

use crate::app::{App, Config, Monotonic, Timing};
use crate::health::{HarnessHealth, NoEnclosure, WithHealth};
use crate::protocol::Board;
use crate::sensors::dvl::{a50::VelocityGate, DvlPort, WithDvl};
use crate::sensors::{BusSensors, NoSensors, Sensors};
use crate::startup::{loop_pass, start_outputs, EscOutput, Watchdog};
use controller_core::controller::{Controller, Gains};
use controller_core::params::Vehicle;
use core::cell::RefCell;
use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::interrupt::Mutex;
use dvl_uart::{start_dvl_uart, DVL_US_PER_BYTE};
use health_pins::{AdcPowerSense, HealthUart};
use heapless::Deque;
use sensor_drivers::icm42688::{self, Icm42688};
use sensor_drivers::ms5837::{Ms5837, Osr};
use stm32f4xx_hal::{
    pac::{self, interrupt, TIM2, USART1},
    prelude::*,
    rcc::Config as RccConfig,
    serial::{Rx, Tx},
    timer::{Counter, ErasedChannel},
    watchdog::IndependentWatchdog,
};

/// An ESC's PWM output: a channel of TIM3.
type Pwm = ErasedChannel<pac::TIM3>;

/// Which board.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variant {
    /// STM32F405 hardware.
    Stm32f4,
    /// QEMU `netduinoplus2`.
    Qemu,
}

/// External crystal of the real board.
pub const HSE_HZ: u32 = 8_000_000;
/// System clock of the real board.
pub const SYSCLK_HZ: u32 = 168_000_000;
/// Tether baud rate.
pub const BAUD: u32 = 115_200;
/// Watchdog timeout, milliseconds.
pub const WATCHDOG_MS: u32 = 250;

/// The tether's two rings, shared by the main loop and the USART1 interrupt.
struct Rings {
    /// Bytes received by the interrupt, waiting for the main loop.
    rx: Deque<u8, 1024>,
    /// Bytes the loop queued for sending, written to the data register by the interrupt.
    tx: Deque<u8, 256>,
}

/// A static of its own: all zeros at boot, so in `.bss`, not 1.3 KiB of `.data` initializer
/// in flash (as beside the `Option` below, whose `None` is not zero).
static RINGS: Mutex<RefCell<Rings>> = Mutex::new(RefCell::new(Rings {
    rx: Deque::new(),
    tx: Deque::new(),
}));
/// USART1's receiver and transmitter, owned by the interrupt once started.
static SERIAL: Mutex<RefCell<Option<Usart>>> = Mutex::new(RefCell::new(None));
/// Bytes lost: the ring was full, or the USART reported an overrun or framing error.
pub static RX_LOST: AtomicU32 = AtomicU32::new(0);

type Usart = (Rx<USART1>, Tx<USART1>);

/// Run `f` on the rings and the serial port in a critical section. `try_borrow_mut`, not
/// `borrow_mut`: every borrow of these cells is inside a critical section and ends with it,
/// so a borrow cannot fail (`None`), but `borrow_mut` would keep a panic path in the
/// interrupt (and the main loop) that the compiler cannot remove.
fn with_port<R>(f: impl FnOnce(&mut Rings, &mut Option<Usart>) -> R) -> Option<R> {
    cortex_m::interrupt::free(|cs| {
        let mut rings = RINGS.borrow(cs).try_borrow_mut().ok()?;
        let mut serial = SERIAL.borrow(cs).try_borrow_mut().ok()?;
        Some(f(&mut rings, &mut serial))
    })
}

#[interrupt]
fn USART1() {
    with_port(|rings, serial| {
        let Some((rx, tx)) = serial else {
            return;
        };
        send_queued(tx, &mut rings.tx);
        // Drain; an error (overrun, framing) is cleared by the read and the frame it hit is
        // dropped by the CRC.
        loop {
            let lost = match rx.read() {
                Ok(b) => rings.rx.push_back(b).is_err(),
                Err(nb::Error::WouldBlock) => break,
                Err(nb::Error::Other(_)) => true,
            };
            if lost {
                RX_LOST.fetch_add(1, Ordering::Relaxed);
            }
        }
    });
}

/// Move queued bytes to the data register while it is empty; stop the transmit interrupt
/// when the queue is empty (the next `write` starts it again).
fn send_queued(tx: &mut Tx<USART1>, out: &mut Deque<u8, 256>) {
    while tx.is_tx_empty() {
        let Some(b) = out.pop_front() else {
            tx.unlisten();
            return;
        };
        // Cannot block: the register is empty.
        let _ = embedded_hal_nb::serial::Write::write(tx, b);
    }
    tx.listen();
}

/// The tether: interrupt-driven both ways. The loop never waits on the port: `write` queues
/// what fits and the USART1 interrupt sends it, a byte each time the data register empties.
pub struct Tether;

/// Serial error (never produced: transmit blocks, receive errors are dropped by the CRC).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TetherError;

impl embedded_io::Error for TetherError {
    fn kind(&self) -> embedded_io::ErrorKind {
        embedded_io::ErrorKind::Other
    }
}

impl embedded_io::ErrorType for Tether {
    type Error = TetherError;
}

impl embedded_io::ReadReady for Tether {
    fn read_ready(&mut self) -> Result<bool, TetherError> {
        Ok(with_port(|rings, _| !rings.rx.is_empty()).unwrap_or(false))
    }
}

impl embedded_io::Read for Tether {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, TetherError> {
        Ok(with_port(|rings, _| {
            let n = buf.len().min(rings.rx.len());
            for b in buf.iter_mut().take(n) {
                *b = rings.rx.pop_front().unwrap_or(0);
            }
            n
        })
        .unwrap_or(0))
    }
}

impl embedded_io::WriteReady for Tether {
    fn write_ready(&mut self) -> Result<bool, TetherError> {
        Ok(with_port(|rings, _| !rings.tx.is_full()).unwrap_or(false))
    }
}

impl embedded_io::Write for Tether {
    /// Queue what fits (at least one byte after `write_ready`) and start the interrupt.
    fn write(&mut self, buf: &[u8]) -> Result<usize, TetherError> {
        Ok(with_port(|rings, serial| {
            let n = buf
                .iter()
                .take_while(|&&b| rings.tx.push_back(b).is_ok())
                .count();
            if let Some((_, tx)) = serial {
                send_queued(tx, &mut rings.tx);
            }
            n
        })
        .unwrap_or(0))
    }

    fn flush(&mut self) -> Result<(), TetherError> {
        Ok(())
    }
}

/// Bytes received on USART1 and not yet read by the loop (the emulated layout's harness
/// counts what has arrived: read, waiting here, and [`RX_LOST`]).
pub fn tether_rx_pending() -> u32 {
    with_port(|rings, _| rings.rx.len() as u32).unwrap_or(0)
}

/// TIM2 as a free-running 32-bit counter at `FREQ` Hz, extended to 64 bits.
pub struct Tim2Clock<const FREQ: u32> {
    counter: Counter<TIM2, FREQ>,
    last: u32,
    total: u64,
}

impl<const FREQ: u32> Tim2Clock<FREQ> {
    /// Auto-reload: the counter counts 0..=ARR.
    const ARR: u32 = u32::MAX - 1;

    /// Start the counter free-running over its whole range (resets the MCU if it cannot).
    pub fn start(mut counter: Counter<TIM2, FREQ>) -> Self {
        if counter
            .start(fugit::TimerDurationU32::<FREQ>::from_ticks(u32::MAX))
            .is_err()
        {
            halt()
        }
        Self {
            counter,
            last: 0,
            total: 0,
        }
    }

    fn raw(&self) -> u32 {
        self.counter.now().ticks()
    }

    fn update(&mut self) -> u64 {
        let now = self.raw();
        let d = if now >= self.last {
            now - self.last
        } else {
            (Self::ARR - self.last) + now + 1
        };
        self.last = now;
        self.total += u64::from(d);
        self.total
    }
}

impl<const FREQ: u32> Monotonic for Tim2Clock<FREQ> {
    fn now_us(&mut self) -> u64 {
        let t = self.update();
        t / (u64::from(FREQ) / 1_000_000).max(1)
    }

    fn ticks(&mut self) -> u32 {
        self.raw()
    }
}

impl EscOutput for Pwm {
    fn enable(&mut self) {
        Pwm::enable(self);
    }
}

impl Watchdog for IndependentWatchdog {
    fn feed(&mut self) {
        IndependentWatchdog::feed(self);
    }
}

fn halt() -> ! {
    cortex_m::peripheral::SCB::sys_reset()
}

/// Bring the board up and run the application forever.
pub fn run(variant: Variant) -> ! {
    let Some(dp) = pac::Peripherals::take() else {
        halt()
    };
    let mut rcc = match variant {
        Variant::Stm32f4 => dp.RCC.freeze(
            RccConfig::hse(HSE_HZ.Hz())
                .sysclk(SYSCLK_HZ.Hz())
                .pclk1(42.MHz()),
        ),
        // No PLL: QEMU does not model the RCC.
        Variant::Qemu => dp.RCC.constrain(),
    };
    defmt::info!(
        "boot {} sysclk {} Hz",
        match variant {
            Variant::Stm32f4 => "stm32f4",
            Variant::Qemu => "qemu-netduinoplus2",
        },
        rcc.clocks.sysclk().raw()
    );

    // Watchdog first: everything below must finish within its window.
    let mut watchdog = IndependentWatchdog::new(dp.IWDG);
    // Freeze it while a debugger halts the core (probe-rs sessions), run it otherwise.
    watchdog.stop_on_debug(&dp.DBGMCU, true);
    watchdog.start(WATCHDOG_MS.millis());

    let gpioa = dp.GPIOA.split(&mut rcc);
    let gpiob = dp.GPIOB.split(&mut rcc);

    // ESC PWM on TIM3, 1 us resolution.
    let config = match variant {
        Variant::Stm32f4 => Config::fixed_rate(Board::Stm32f4),
        Variant::Qemu => Config::lockstep(Board::QemuNetduinoPlus2),
    };
    let (_pwm, (ch1, ch2, ch3, _)) = dp.TIM3.pwm_us(config.pwm_period_us().micros(), &mut rcc);
    let mut pwm = [
        ch1.with(gpioa.pa6).erase(),
        ch2.with(gpioa.pa7).erase(),
        ch3.with(gpiob.pb0).erase(),
    ];
    // Neutral duty first, then the outputs on.
    if !start_outputs(&mut pwm, config.pwm_period_us()) {
        halt()
    }

    // Tether on USART1.
    let serial = match dp
        .USART1
        .serial::<u8>((gpioa.pa9, gpioa.pa10), BAUD.bps(), &mut rcc)
    {
        Ok(s) => s,
        Err(_) => halt(),
    };
    let (tx, mut rx) = serial.split();
    rx.listen();
    with_port(|_, serial| *serial = Some((rx, tx)));
    // SAFETY: the handler above only touches `RINGS` and `SERIAL` inside critical sections,
    // initialized; unmasking cannot break a critical section in progress (there is none).
    unsafe { cortex_m::peripheral::NVIC::unmask(pac::Interrupt::USART1) };
    let tether = Tether;

    // The DVL on USART2, on both boards.
    let (dvl_uart, dvl_ok) = start_dvl_uart(dp.USART2, (gpioa.pa2, gpioa.pa3), &mut rcc);
    defmt::info!("DVL port {}", dvl_ok);
    let dvl = DvlPort::new(dvl_uart, VelocityGate::default(), DVL_US_PER_BYTE);

    match variant {
        Variant::Stm32f4 => {
            // The sensors: SPI2 + PB12 chip select for the IMU, I2C1 for the pressure sensor;
            // TIM5 as the drivers' start-up delay.
            let mut delay = dp.TIM5.delay_us(&mut rcc);
            let spi = dp.SPI2.spi(
                (Some(gpiob.pb13), Some(gpiob.pb14), Some(gpiob.pb15)),
                embedded_hal::spi::MODE_3,
                8.MHz(),
                &mut rcc,
            );
            let imu = embedded_hal_bus::spi::ExclusiveDevice::new_no_delay(
                spi,
                gpiob.pb12.into_push_pull_output(),
            )
            .ok()
            .and_then(|dev| Icm42688::new(dev, &mut delay, icm42688::Config::default()).ok());
            let i2c = dp.I2C1.i2c((gpiob.pb8, gpiob.pb9), 400.kHz(), &mut rcc);
            let baro = Ms5837::new(i2c, &mut delay, Osr::Osr8192).ok();
            defmt::info!(
                "sensors: IMU {}, pressure {}",
                imu.is_some(),
                baro.is_some()
            );
            let gpioc = dp.GPIOC.split(&mut rcc);
            let power = AdcPowerSense::new(
                dp.ADC1,
                gpioc.pc0.into_analog(),
                gpioc.pc1.into_analog(),
                &mut rcc,
            );
            let leak = gpioc.pc2.into_pull_down_input();
            let sensors = WithHealth::new(
                WithDvl {
                    inner: BusSensors::new(imu, baro),
                    dvl,
                },
                power,
                Some(leak),
                NoEnclosure,
            );
            let clock = Tim2Clock::start(dp.TIM2.counter::<1_000_000>(&mut rcc));
            main_loop(pwm, tether, clock, config, sensors, watchdog)
        }
        Variant::Qemu => {
            // Default clocks: the timer clock is 16 MHz, so the prescaler is 0.
            let clock = Tim2Clock::start(dp.TIM2.counter::<16_000_000>(&mut rcc));
            // The health inputs from the host on USART3.
            let Ok(health) = dp
                .USART3
                .serial::<u8>((gpiob.pb10, gpiob.pb11), BAUD.bps(), &mut rcc)
            else {
                halt()
            };
            let (_tx, health_rx) = health.split();
            let sensors = HarnessHealth::new(
                WithDvl {
                    inner: NoSensors,
                    dvl,
                },
                HealthUart::start(health_rx),
            );
            main_loop(pwm, tether, clock, config, sensors, watchdog)
        }
    }
}

/// The controller and the application, built in a frame of their own (resets the MCU on a
/// settings error).
///
/// Not inlined and returning the `App` itself (not a `Result`), for the stack: built inline,
/// the ~1.3 KiB `App` was moved twice (the constructor's value, the `Result`, the loop's
/// variable) inside `main_loop`'s frame, which lives forever, and the 0.5 KiB `Controller` sat
/// in `run`'s. Here the temporaries are freed before the loop starts and the `App` is written
/// straight into `main_loop`'s variable (docs/firmware.md, "Flash and RAM").
#[inline(never)]
fn build_app<C, N>(
    pwm: [Pwm; 3],
    tether: Tether,
    clock: C,
    config: Config,
    sensors: N,
) -> App<Pwm, Tether, C, N>
where
    C: Monotonic,
    N: Sensors,
{
    let Ok(controller) = Controller::new(Vehicle::observer(), Gains::default()) else {
        halt()
    };
    match App::with_sensors(pwm, tether, clock, controller, config, sensors) {
        Ok(app) => app,
        Err(_) => halt(),
    }
}

fn main_loop<C, N>(
    pwm: [Pwm; 3],
    tether: Tether,
    clock: C,
    config: Config,
    sensors: N,
    mut watchdog: IndependentWatchdog,
) -> !
where
    C: Monotonic,
    N: Sensors,
{
    let mut app = build_app(pwm, tether, clock, config, sensors);
    app.hello();
    defmt::info!(
        "ready: {}, PWM {} Hz, duties {}",
        if config.timing == Timing::LockStep {
            "lock-step"
        } else {
            "fixed-rate"
        },
        config.pwm_hz,
        app.duties()
    );
    let mut armed = false;
    let mut faults = 0u16;
    let mut next_status_us = 0u64;
    loop {
        loop_pass(&mut app, &mut watchdog);
        // Lock-step (the emulated board): the firmware's time moves only with the host's
        // frames, so with no tether byte waiting and every reply handed to the port there
        // is nothing to do until an interrupt (a byte on one of the UARTs, the transmit ring
        // emptying).
        if config.timing == Timing::LockStep {
            let replies_sent = app.replies_sent();
            sleep_unless(|| !replies_sent || tether_rx_pending() > 0);
        }
        // Once a second while armed: what a pilot watching the defmt log wants to see.
        if app.autopilot().armed() && app.now_us() >= next_status_us {
            let now = app.now_us();
            next_status_us = now + 1_000_000;
            let e = app.last_output().errors;
            // Display only, so micromath's cheap approximations are enough here (its sqrt is
            // an approximation of a few per cent by its documentation; not measured here);
            // the laws use controller-core's accurate f32 maths.
            let err_m = micromath::F32Ext::sqrt(e.x_m * e.x_m + e.y_m * e.y_m + e.z_m * e.z_m);
            defmt::info!(
                "t {=u64:us}: position error ~{=f32} m, yaw error ~{=f32} deg, duties {}",
                now,
                err_m,
                e.yaw_rad * (180.0 / core::f32::consts::PI),
                app.duties()
            );
        }
        let a = app.autopilot().armed();
        let f = app.last_output().faults & !crate::protocol::fault::SATURATED;
        if a != armed || f != faults {
            let l = app.link_stats();
            defmt::info!(
                "armed {} faults {=u16:#x} rx {} dropped {} duties {}",
                a,
                f,
                l.rx_frames,
                l.dropped.total(),
                app.duties()
            );
            armed = a;
            faults = f;
        }
    }
}

/// Sleep until an interrupt (WFI) unless `work_waiting()`. The check and the WFI share a
/// critical section: an interrupt raised between them stays pending, ends the WFI at once,
/// and its handler runs when the section ends. Under QEMU a halted core costs the host
/// nothing, where a polling loop keeps a host core busy. For the emulated images only,
/// whose clock is the host's frames: a sleeping core does not feed the watchdog, and the
/// real board's fixed-rate loop must poll its clock.
pub fn sleep_unless(work_waiting: impl FnOnce() -> bool) {
    cortex_m::interrupt::free(|_| {
        if !work_waiting() {
            cortex_m::asm::wfi();
        }
    });
}

/// USART1 as the interrupt-driven [`Tether`] (for the node image; the onboard
/// image sets it up the same way in [`run`]). Resets the MCU if the port cannot be set up.
pub fn start_tether(
    usart: USART1,
    pins: (stm32f4xx_hal::gpio::PA9, stm32f4xx_hal::gpio::PA10),
    rcc: &mut stm32f4xx_hal::rcc::Rcc,
) -> Tether {
    let Ok(serial) = usart.serial::<u8>(pins, BAUD.bps(), rcc) else {
        halt()
    };
    let (tx, mut rx) = serial.split();
    rx.listen();
    with_port(|_, serial| *serial = Some((rx, tx)));
    // SAFETY: as in `run`: the handler only touches `RINGS` and `SERIAL` inside critical
    // sections, initialized just above.
    unsafe { cortex_m::peripheral::NVIC::unmask(pac::Interrupt::USART1) };
    Tether
}
