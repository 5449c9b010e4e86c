//! The vehicle's own navigation sensors as the loop sees them: the [`Sensors`] trait, read
//! just before each control step (fixed-rate mode) while the on-board estimator runs;
//! [`NoSensors`] for the emulated board and the host (the readings come over the tether), and
//! [`BusSensors`], the ICM-42688-P and the MS5837-30BA drivers (`sensor-drivers`) on any
//! `embedded-hal` SPI device and I2C bus (the STM32F4 board's wiring is in `board.rs`);
//! [`dvl`]: a DVL on a UART added to any of them.

pub mod dvl;

use controller_core::nav::DvlFix;
pub use controller_core::nav::ImuSample;
use embedded_hal::i2c::I2c;
use embedded_hal::spi::SpiDevice;
use sensor_drivers::icm42688::Icm42688;
use sensor_drivers::ms5837::{Conversion, Ms5837};

/// The vehicle's own navigation sensors, read by the loop just before each control step
/// (fixed-rate mode) while the on-board estimator runs.
pub trait Sensors {
    /// One IMU sample (body axes) made now, or `None` when the IMU did not answer or its
    /// reading was refused (the estimator's `SENSOR_LOST` timeout then runs).
    fn imu(&mut self, now_us: u64) -> Option<ImuSample>;
    /// A new absolute pressure (Pa) when one is ready (the sensor's own rate), else `None`.
    fn pressure_pa(&mut self, now_us: u64) -> Option<f32>;
    /// A new DVL velocity admitted since the last call (its own time of validity), else
    /// `None`; none on a board without a DVL port ([`dvl::WithDvl`] adds one).
    fn dvl(&mut self, _now_us: u64) -> Option<DvlFix> {
        None
    }
    /// DVL lines and reports refused so far (bad checksum, malformed, no bottom lock, a poor
    /// figure of merit, over-long); 0 without a DVL port.
    fn dvl_refused(&self) -> u32 {
        0
    }
    /// The health inputs read now (the power-sense module's ADC pins, the leak probe, the
    /// enclosure's sensor), or `None` on a board without them
    /// (`health::WithHealth` adds them).
    fn health(&mut self, _now_us: u64) -> Option<crate::protocol::HealthSample> {
        None
    }
    /// True on a board with sensors of its own: the tether's `Imu` and `Pressure` are then
    /// refused (`OwnSensors`), so that the surface cannot feed the estimator on a real
    /// vehicle.
    fn own_sensors(&self) -> bool {
        true
    }

    /// Fault bits of the sensors' own link, ORed into the reported faults (the topside
    /// layout's node link, `topside_link::fault`); none for sensors on the MCU's buses.
    fn faults(&self) -> u16 {
        0
    }
}

/// No sensors on the MCU's buses: the emulated board and the host, where the readings come
/// over the tether (`Imu`, `Pressure`).
#[derive(Debug, Clone, Copy, Default)]
pub struct NoSensors;

impl Sensors for NoSensors {
    fn imu(&mut self, _now_us: u64) -> Option<ImuSample> {
        None
    }

    fn pressure_pa(&mut self, _now_us: u64) -> Option<f32> {
        None
    }

    fn own_sensors(&self) -> bool {
        false
    }
}

/// The IMU and the pressure sensor on the MCU's buses, either of which may be absent (not
/// found at boot). The pressure sensor advances one step of its conversion cycle per control
/// step: start D1 / read D1 and start D2 / read D2 / two idle passes, so a pressure every fifth
/// step (10 Hz at 50 Hz) without waiting; at OSR 8192 a conversion takes 18.08 ms, less than a
/// 20 ms step.
pub struct BusSensors<S, I> {
    imu: Option<Icm42688<S>>,
    baro: Option<Ms5837<I>>,
    /// Step of the pressure sensor's conversion cycle (0..5).
    phase: u8,
    d1: u32,
}

impl<S: SpiDevice, I: I2c> Sensors for BusSensors<S, I> {
    /// The chip is mounted x forward, component side up: body axes (x forward, y right,
    /// z down) are `(x, -y, -z)` of the chip's.
    fn imu(&mut self, now_us: u64) -> Option<ImuSample> {
        let s = self.imu.as_mut()?.read().ok()?;
        let body = |v: [f32; 3]| [v[0], -v[1], -v[2]];
        Some(ImuSample {
            t_us: now_us,
            gyro_rad_s: body(s.gyro_rad_s),
            accel_m_s2: body(s.accel_m_s2),
        })
    }

    fn pressure_pa(&mut self, _now_us: u64) -> Option<f32> {
        let baro = self.baro.as_mut()?;
        let phase = self.phase;
        self.phase = (self.phase + 1) % 5;
        match phase {
            0 => baro.start(Conversion::Pressure).ok().and(None),
            1 => {
                self.d1 = baro.read_adc().ok()?;
                baro.start(Conversion::Temperature).ok().and(None)
            }
            2 => {
                let d2 = baro.read_adc().ok()?;
                baro.reading(self.d1, d2).ok().map(|r| r.pressure_pa)
            }
            _ => None,
        }
    }
}

impl<S, I> BusSensors<S, I> {
    /// The sensors found at boot.
    pub fn new(imu: Option<Icm42688<S>>, baro: Option<Ms5837<I>>) -> Self {
        Self {
            imu,
            baro,
            phase: 0,
            d1: 0,
        }
    }
}
