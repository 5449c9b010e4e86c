//! TDK InvenSense ICM-42688-P (datasheet DS-000347, rev. 1.8).
//!
//! Chosen for the Observer because it is the IMU of the Pixhawk 6 class of autopilots that
//! ArduSub runs on (the noise figures of the navigation issue's defaults are its: 2.8
//! mdps/sqrt(Hz), 70 ug/sqrt(Hz)), it has an SPI interface up to 24 MHz and one register map
//! for both sensors. The BMI088 needs two chip selects; the MPU-6000 is end of life.
//!
//! SPI mode 0 or 3; a register is read by sending its address with bit 7 set. Bring-up:
//! `WHO_AM_I` (0x75) must read 0x47; soft reset (`DEVICE_CONFIG` 0x11 = 0x01, then 1 ms);
//! gyro and accelerometer full scale and output data rate (`GYRO_CONFIG0` 0x4F,
//! `ACCEL_CONFIG0` 0x50); both sensors in low-noise mode (`PWR_MGMT0` 0x4E = 0x0F), after
//! which the gyro needs 45 ms before its data are valid. A sample is one burst read of 14
//! bytes from `TEMP_DATA1` (0x1D): temperature, accelerometer x/y/z, gyro x/y/z, each
//! big-endian `i16`. Temperature = raw / 132.48 + 25 degC. Axes are the chip's; the mounting
//! is the caller's (`docs/drivers.md`).

use embedded_hal::delay::DelayNs;
use embedded_hal::spi::{Operation, SpiDevice};

/// `WHO_AM_I` of the ICM-42688-P.
pub const WHO_AM_I_VALUE: u8 = 0x47;
/// Register addresses (bank 0).
pub mod reg {
    /// Soft reset (bit 0).
    pub const DEVICE_CONFIG: u8 = 0x11;
    /// First byte of the sample burst.
    pub const TEMP_DATA1: u8 = 0x1D;
    /// Power modes.
    pub const PWR_MGMT0: u8 = 0x4E;
    /// Gyro full scale (bits 7..5) and ODR (bits 3..0).
    pub const GYRO_CONFIG0: u8 = 0x4F;
    /// Accelerometer full scale (bits 7..5) and ODR (bits 3..0).
    pub const ACCEL_CONFIG0: u8 = 0x50;
    /// Identity.
    pub const WHO_AM_I: u8 = 0x75;
}
const READ: u8 = 0x80;
/// Gyro and accelerometer in low-noise mode.
const PWR_LOW_NOISE: u8 = 0x0F;

/// Gyro full scale.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GyroRange {
    /// +-2000 dps (16.4 LSB/dps).
    Dps2000 = 0,
    /// +-1000 dps.
    Dps1000 = 1,
    /// +-500 dps.
    Dps500 = 2,
    /// +-250 dps.
    Dps250 = 3,
}

impl GyroRange {
    /// Radians per second per LSB.
    pub fn rad_s_per_lsb(self) -> f32 {
        let dps = match self {
            GyroRange::Dps2000 => 2000.0,
            GyroRange::Dps1000 => 1000.0,
            GyroRange::Dps500 => 500.0,
            GyroRange::Dps250 => 250.0,
        };
        dps / 32768.0 * core::f32::consts::PI / 180.0
    }
}

/// Accelerometer full scale.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AccelRange {
    /// +-16 g (2048 LSB/g).
    G16 = 0,
    /// +-8 g.
    G8 = 1,
    /// +-4 g.
    G4 = 2,
    /// +-2 g.
    G2 = 3,
}

impl AccelRange {
    /// m/s^2 per LSB.
    pub fn m_s2_per_lsb(self) -> f32 {
        let g = match self {
            AccelRange::G16 => 16.0,
            AccelRange::G8 => 8.0,
            AccelRange::G4 => 4.0,
            AccelRange::G2 => 2.0,
        };
        g / 32768.0 * 9.806_65
    }
}

/// Output data rate (both sensors).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Odr {
    /// 1 kHz.
    Hz1000 = 6,
    /// 200 Hz.
    Hz200 = 7,
    /// 100 Hz.
    Hz100 = 8,
}

/// Configuration applied by [`Icm42688::new`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Config {
    /// Gyro full scale.
    pub gyro: GyroRange,
    /// Accelerometer full scale.
    pub accel: AccelRange,
    /// Output data rate.
    pub odr: Odr,
}

impl Default for Config {
    /// +-500 dps and +-4 g (an ROV turns and accelerates slowly), 1 kHz.
    fn default() -> Self {
        Self {
            gyro: GyroRange::Dps500,
            accel: AccelRange::G4,
            odr: Odr::Hz1000,
        }
    }
}

/// Why an operation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Error<E> {
    /// The SPI bus failed.
    Bus(E),
    /// `WHO_AM_I` is not 0x47: another chip, or nothing, answers.
    WrongChip {
        /// What was read.
        who_am_i: u8,
    },
    /// A sample at full scale on some axis, or a temperature outside -40..85 degC: the
    /// reading is not trusted.
    OutOfRange,
}

/// One sample, chip axes, SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Angular rate (rad/s).
    pub gyro_rad_s: [f32; 3],
    /// Specific force (m/s^2).
    pub accel_m_s2: [f32; 3],
    /// Die temperature (degC).
    pub temperature_c: f32,
}

/// The driver.
#[derive(Debug)]
pub struct Icm42688<S> {
    spi: S,
    cfg: Config,
}

impl<S: SpiDevice> Icm42688<S> {
    /// Check the identity, reset, configure and start both sensors in low-noise mode.
    pub fn new(spi: S, delay: &mut impl DelayNs, cfg: Config) -> Result<Self, Error<S::Error>> {
        let mut d = Self { spi, cfg };
        let who_am_i = d.read_reg(reg::WHO_AM_I)?;
        if who_am_i != WHO_AM_I_VALUE {
            return Err(Error::WrongChip { who_am_i });
        }
        d.write_reg(reg::DEVICE_CONFIG, 0x01)?;
        delay.delay_ms(1);
        d.write_reg(reg::GYRO_CONFIG0, ((cfg.gyro as u8) << 5) | cfg.odr as u8)?;
        d.write_reg(reg::ACCEL_CONFIG0, ((cfg.accel as u8) << 5) | cfg.odr as u8)?;
        d.write_reg(reg::PWR_MGMT0, PWR_LOW_NOISE)?;
        // The gyro's start-up time before its output is valid.
        delay.delay_ms(45);
        Ok(d)
    }

    /// Give the bus back.
    pub fn release(self) -> S {
        self.spi
    }

    fn read_reg(&mut self, addr: u8) -> Result<u8, Error<S::Error>> {
        let mut b = [0u8; 1];
        self.spi
            .transaction(&mut [Operation::Write(&[addr | READ]), Operation::Read(&mut b)])
            .map_err(Error::Bus)?;
        Ok(b[0])
    }

    fn write_reg(&mut self, addr: u8, value: u8) -> Result<(), Error<S::Error>> {
        self.spi.write(&[addr, value]).map_err(Error::Bus)
    }

    /// One sample (a 14-byte burst read).
    pub fn read(&mut self) -> Result<Sample, Error<S::Error>> {
        let mut b = [0u8; 14];
        self.spi
            .transaction(&mut [
                Operation::Write(&[reg::TEMP_DATA1 | READ]),
                Operation::Read(&mut b),
            ])
            .map_err(Error::Bus)?;
        let mut words = [0i16; 7];
        let (pairs, _) = b.as_chunks::<2>();
        for (w, pair) in words.iter_mut().zip(pairs) {
            *w = i16::from_be_bytes(*pair);
        }
        let [t, ax, ay, az, gx, gy, gz] = words;
        // A rail value is saturation (or a bus stuck at 0xFF / a sensor not sampling: the
        // ICM-42688-P reports -32768 for data not ready).
        let railed = |v: i16| v == i16::MIN || v == i16::MAX;
        if words.iter().skip(1).any(|&v| railed(v)) {
            return Err(Error::OutOfRange);
        }
        let temperature_c = f32::from(t) / 132.48 + 25.0;
        if !(-40.0..=85.0).contains(&temperature_c) {
            return Err(Error::OutOfRange);
        }
        let g = self.cfg.gyro.rad_s_per_lsb();
        let a = self.cfg.accel.m_s2_per_lsb();
        Ok(Sample {
            gyro_rad_s: [gx, gy, gz].map(|v| f32::from(v) * g),
            accel_m_s2: [ax, ay, az].map(|v| f32::from(v) * a),
            temperature_c,
        })
    }
}
