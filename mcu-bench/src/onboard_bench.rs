//! The board's whole loop iteration with the on-board estimator: the
//! firmware library's [`App::tick`] in fixed-rate mode (50 Hz control, 10 Hz telemetry) with
//! [`BusSensors`], the real ICM-42688-P and MS5837-30BA drivers on SPI and I2C buses in RAM
//! (the bus transfers themselves take no time here; on the board the SPI burst is ~20 us at
//! 8 MHz and the I2C reads ~100 us at 400 kHz, waits the instruction count does not see).
//!
//! Each timed iteration is one control period: the frames that arrived from the surface in it
//! are decoded and handled (a heartbeat answered by a `Status` and a compass heading at 10 Hz,
//! a DVL velocity at 5 Hz, a USBL fix at 1 Hz, 0.3 s late), the IMU is read and predicts, the
//! pressure sensor advances its conversion cycle (a depth every fifth pass), the 3-D tracking
//! law holds the launch point, the PWM is written, and `Telemetry` goes out at 10 Hz. The
//! schedule lines them up: every 50th pass has all of them at once, which is the `max`.

use crate::bench::{Bench, Platform, CALLS};
use crate::loop_bench::{frame, open_session, FakePwm, FakeSerial};
use controller_core::controller::{Controller, Gains};
use controller_core::nav::onboard::{OnboardConfig, PressureDepth};
use controller_core::nav::{DvlFix, HeadingFix, PositionFix, GRAVITY_M_S2};
use controller_core::params::Vehicle;
use controller_core::state::NavState;
use core::cell::Cell;
use core::convert::Infallible;
use embedded_hal::i2c::{ErrorType as I2cErrorType, I2c, Operation as I2cOp};
use embedded_hal::spi::{ErrorType as SpiErrorType, Operation, SpiDevice};
use firmware::protocol::{fault, Board, Command, Mode, MAX_FRAME_LEN};
use firmware::{App, BusSensors, Config, Monotonic, Sensors};
use sensor_drivers::icm42688::{self, Icm42688};
use sensor_drivers::ms5837::{Ms5837, Osr};

/// An ICM-42688-P on a bus in RAM: `WHO_AM_I` = 0x47, then level samples (1 g up on the
/// chip's z axis) with a small gyro signal that changes every read.
pub(crate) struct FakeImuBus {
    reads: u32,
}

impl SpiErrorType for FakeImuBus {
    type Error = Infallible;
}

impl SpiDevice for FakeImuBus {
    fn transaction(&mut self, ops: &mut [Operation<'_, u8>]) -> Result<(), Infallible> {
        for op in ops.iter_mut() {
            if let Operation::Read(buf) = op {
                if let [who_am_i] = buf {
                    *who_am_i = 0x47;
                    continue;
                }
                self.reads = self.reads.wrapping_add(1);
                let g = (self.reads % 7) as i16 - 3;
                // Temperature 25 degC, accel (0, 0, +1 g), gyro a few LSB.
                let one_g = GRAVITY_M_S2 / icm42688::Config::default().accel.m_s2_per_lsb();
                let words: [i16; 7] = [0, 3, -2, one_g as i16, g, -g, 2 * g];
                for (pair, w) in buf.chunks_mut(2).zip(words) {
                    pair.copy_from_slice(&w.to_be_bytes());
                }
            }
        }
        Ok(())
    }
}

/// An MS5837-30BA on a bus in RAM: the datasheet's example PROM and conversions.
pub(crate) struct FakeBaroBus {
    last_cmd: u8,
}

/// The datasheet's example: word 0 (CRC 9, product 0x1A), C1..C6, D1, D2.
const PROM: [u16; 7] = [0x9340, 34982, 36352, 20328, 22354, 26646, 26146];
const D1: u32 = 4_958_179;
const D2: u32 = 6_815_414;

impl I2cErrorType for FakeBaroBus {
    type Error = Infallible;
}

impl I2c for FakeBaroBus {
    fn transaction(&mut self, _addr: u8, ops: &mut [I2cOp<'_>]) -> Result<(), Infallible> {
        let mut cmd = self.last_cmd;
        for op in ops.iter_mut() {
            match op {
                I2cOp::Write(b) => {
                    cmd = b.first().copied().unwrap_or(0);
                    if cmd & 0xF0 == 0x40 || cmd & 0xF0 == 0x50 {
                        self.last_cmd = cmd;
                    }
                }
                I2cOp::Read(buf) => {
                    if (0xA0..0xAE).contains(&cmd) {
                        let w = PROM.get(usize::from((cmd - 0xA0) / 2)).copied();
                        buf.copy_from_slice(&w.unwrap_or(0).to_be_bytes());
                    } else {
                        let v = if self.last_cmd & 0xF0 == 0x40 { D1 } else { D2 };
                        buf.copy_from_slice(&v.to_be_bytes()[1..]);
                    }
                }
            }
        }
        Ok(())
    }
}

/// The bench's IMU and pressure sensor on their buses in RAM.
pub(crate) type BenchBusSensors = BusSensors<FakeImuBus, FakeBaroBus>;

/// The drivers' start-up waits, skipped.
struct NoWait;

impl embedded_hal::delay::DelayNs for NoWait {
    fn delay_ns(&mut self, _ns: u32) {}
}

/// The firmware's clock: simulated microseconds set by the bench, the platform's counter
/// for the loop's own timing.
pub(crate) struct SimClock<'a, P: Platform> {
    p: &'a P,
    now_us: &'a Cell<u64>,
}

impl<P: Platform> Monotonic for SimClock<'_, P> {
    fn now_us(&mut self) -> u64 {
        self.now_us.get()
    }
    fn ticks(&mut self) -> u32 {
        self.p.now()
    }
}

/// Run `loop.onboard_3d`: the DVL's velocities come from the surface over the tether.
pub fn run_onboard<P: Platform>(b: &Bench<'_, P>, p: &P) {
    run_onboard_with(b, p, "loop.onboard_3d", true, |bus| bus, |_, _, _| ());
}

/// Run one onboard loop item named `name`: `wrap` adds ports to the bus sensors (the DVL's
/// UART, the health inputs), `feed(i, t_us)` queues their bytes before pass `i` (untimed);
/// `dvl_over_tether` sends the DVL's velocity as a tether frame instead.
pub(crate) fn run_onboard_with<P: Platform, N: Sensors>(
    b: &Bench<'_, P>,
    p: &P,
    name: &str,
    dvl_over_tether: bool,
    wrap: impl FnOnce(BenchBusSensors) -> N,
    mut feed: impl FnMut(&mut App<FakePwm, FakeSerial, SimClock<'_, P>, N>, u32, u64),
) {
    let now_us = Cell::new(0u64);
    let Ok(imu) = Icm42688::new(
        FakeImuBus { reads: 0 },
        &mut NoWait,
        icm42688::Config::default(),
    ) else {
        p.print(format_args!("mcu-bench: the IMU driver did not start"));
        return;
    };
    let Ok(baro) = Ms5837::new(FakeBaroBus { last_cmd: 0 }, &mut NoWait, Osr::Osr8192) else {
        p.print(format_args!("mcu-bench: the pressure driver did not start"));
        return;
    };
    let Ok(controller) = Controller::new(Vehicle::observer(), Gains::default()) else {
        return;
    };
    let Ok(mut app) = App::with_sensors(
        [FakePwm(0), FakePwm(0), FakePwm(0)],
        FakeSerial::new(),
        SimClock { p, now_us: &now_us },
        controller,
        Config::fixed_rate(Board::Host),
        wrap(BusSensors::new(Some(imu), Some(baro))),
    ) else {
        return;
    };
    // The launch point at the depth of the example pressure (39.998 bar absolute).
    let z0 = PressureDepth::SEA_WATER.depth_m(399_980.0);
    let initial = NavState {
        z_m: z0,
        ..NavState::default()
    };
    let mut seq = 0u16;
    let mut buf = [0u8; MAX_FRAME_LEN];
    open_session(&mut app);
    for cmd in [
        Command::Heartbeat { t_us: 0 },
        Command::StartNav {
            t_us: 0,
            initial,
            config: OnboardConfig::default(),
        },
        Command::SetMode(Mode::Hold),
        Command::Arm,
    ] {
        seq = seq.wrapping_add(1);
        app.parts_mut().1.append(frame(seq, &cmd, &mut buf));
        app.tick();
    }
    let (mut disarmed, mut lost, mut no_law) = (0u32, 0u32, 0u32);
    b.run_state(
        name,
        CALLS,
        &mut app,
        |app, i| {
            let t_us = u64::from(i + 1) * 20_000;
            now_us.set(t_us);
            let serial = app.parts_mut().1;
            serial.clear_tx();
            surface_frames(serial, &mut seq, i, t_us, dvl_over_tether);
            feed(app, i, t_us);
        },
        |app| app.tick(),
        |app| {
            let out = app.last_output();
            if out.faults & fault::SENSOR_LOST != 0 {
                lost += 1;
            }
            if !out.law_ran {
                no_law += 1;
            }
            if !app.autopilot().armed() {
                disarmed += 1;
            }
        },
    );
    let health = app
        .autopilot()
        .onboard_nav()
        .map(|o| o.estimator().health())
        .unwrap_or_default();
    let est = app.autopilot().nav_state();
    p.print(format_args!(
        "ONBOARD {name}: {} IMU samples, {} depths, {} headings, {} DVL, {} USBL fused; \
         estimate ({:.3}, {:.3}, {:.3}) m vs launch (0, 0, {z0:.3}); sensor-lost passes {lost}, \
         disarmed {disarmed}, without the law {no_law}",
        health.imu_samples,
        health.depth_fused,
        health.heading_fused,
        health.dvl_fused,
        health.position_fused,
        est.x_m,
        est.y_m,
        est.z_m
    ));
    if lost + disarmed + no_law > 0 {
        p.print(format_args!(
            "WARN {name}: sensor-lost {lost}, disarmed {disarmed}, no law {no_law}"
        ));
    }
}

/// The surface's frames before control pass `i` at `t_us` (the estimator's inputs from the
/// PC, as a dive sends them): a heartbeat and a compass heading every 5th pass, a DVL
/// velocity every 10th (unless `dvl` is false: the DVL is on the board's UART), a USBL fix
/// 0.3 s old every 50th. Shared by the onboard and the topside loop benches, so both time the
/// same load.
pub(crate) fn surface_frames(serial: &mut FakeSerial, seq: &mut u16, i: u32, t_us: u64, dvl: bool) {
    let mut send = |cmd: &Command| {
        *seq = seq.wrapping_add(1);
        let mut out = [0u8; MAX_FRAME_LEN];
        serial.append(frame(*seq, cmd, &mut out));
    };
    if i.is_multiple_of(5) {
        send(&Command::Heartbeat { t_us });
        send(&Command::Compass(HeadingFix {
            t_us,
            yaw_rad: 0.001 * (i % 3) as f32,
            std_rad: 0.02,
        }));
    }
    if dvl && i.is_multiple_of(10) {
        send(&Command::DvlFix(DvlFix {
            t_us,
            velocity_m_s: [0.001, -0.001],
            std_m_s: 0.01,
        }));
    }
    if i.is_multiple_of(50) && t_us > 300_000 {
        send(&Command::UsblFix(PositionFix {
            t_us: t_us - 300_000,
            north_m: 0.02,
            east_m: -0.02,
            std_m: 0.3,
        }));
    }
}
