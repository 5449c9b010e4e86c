//! TE Connectivity MS5837-30BA (datasheet MS5837-30BA, rev. C2, 12/2019).
//!
//! I2C address `0x76`. The sequence: `reset` (0x1E, then 2.8 ms while the PROM reloads);
//! read the seven PROM words (0xA0..0xAC, big-endian) and check their CRC-4 (word 0, bits
//! 15..12) and the product type (word 0, bits 11..5 = 0b001_1010 for the 30BA26); then for
//! each reading start a D1 (pressure) and a D2 (temperature) conversion at an oversampling
//! ratio, wait its conversion time, and read the 24-bit ADC (0x00). The compensation is the
//! datasheet's, in 64-bit integers with its divisions by powers of two as arithmetic shifts
//! (which reproduce its worked example: TEMP = 1981, P = 39998):
//!
//! ```text
//! dT = D2 - C5 2^8                    TEMP = 2000 + dT C6 / 2^23          (0.01 degC)
//! OFF = C2 2^16 + C4 dT / 2^7         SENS = C1 2^15 + C3 dT / 2^8
//! second order, TEMP < 20 degC:  Ti = 3 dT^2 / 2^33, OFFi = 3 (TEMP - 2000)^2 / 2,
//!                                SENSi = 5 (TEMP - 2000)^2 / 2^3
//!      and below -15 degC also:  OFFi += 7 (TEMP + 1500)^2, SENSi += 4 (TEMP + 1500)^2
//! second order, TEMP >= 20 degC: Ti = 2 dT^2 / 2^37, OFFi = (TEMP - 2000)^2 / 2^4, SENSi = 0
//! P = (D1 (SENS - SENSi) / 2^21 - (OFF - OFFi)) / 2^13   (0.1 mbar)
//! ```
//!
//! Depth from pressure: `(P - P_surface) / (rho g)`, with the fluid density and the surface
//! pressure settable ([`DepthConfig`]).

use embedded_hal::delay::DelayNs;
use embedded_hal::i2c::I2c;

/// The sensor's I2C address.
pub const ADDRESS: u8 = 0x76;
const CMD_RESET: u8 = 0x1E;
const CMD_CONVERT_D1: u8 = 0x40;
const CMD_CONVERT_D2: u8 = 0x50;
const CMD_ADC_READ: u8 = 0x00;
const CMD_PROM_READ: u8 = 0xA0;
/// Product type of the MS5837-30BA26 (PROM word 0, bits 11..5).
pub const PRODUCT_30BA26: u16 = 0x1A;
/// Time the PROM takes to reload after a reset (datasheet: 2.8 ms).
const RESET_TIME_US: u32 = 2_800;

/// Oversampling ratio: resolution against conversion time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Osr {
    /// 256: 0.6 ms.
    Osr256,
    /// 512: 1.17 ms.
    Osr512,
    /// 1024: 2.28 ms.
    Osr1024,
    /// 2048: 4.54 ms.
    Osr2048,
    /// 4096: 9.04 ms.
    Osr4096,
    /// 8192: 18.08 ms (0.2 mbar, 2 mm of water).
    Osr8192,
}

impl Osr {
    /// Offset added to the conversion command.
    fn code(self) -> u8 {
        match self {
            Osr::Osr256 => 0x0,
            Osr::Osr512 => 0x2,
            Osr::Osr1024 => 0x4,
            Osr::Osr2048 => 0x6,
            Osr::Osr4096 => 0x8,
            Osr::Osr8192 => 0xA,
        }
    }

    /// The datasheet's maximum conversion time (us).
    pub fn conversion_time_us(self) -> u32 {
        match self {
            Osr::Osr256 => 600,
            Osr::Osr512 => 1_170,
            Osr::Osr1024 => 2_280,
            Osr::Osr2048 => 4_540,
            Osr::Osr4096 => 9_040,
            Osr::Osr8192 => 18_080,
        }
    }
}

/// Why a reading failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Error<E> {
    /// The I2C bus failed.
    Bus(E),
    /// The PROM's CRC-4 does not match its contents.
    PromCrc {
        /// CRC stored in the PROM.
        stored: u8,
        /// CRC computed over the PROM.
        computed: u8,
    },
    /// The PROM names another product (e.g. an MS5837-02BA).
    WrongChip {
        /// Product type read (word 0, bits 11..5).
        product: u16,
    },
    /// The ADC returned 0: a conversion was not finished or was interrupted.
    NotConverted,
    /// The compensated reading is outside the sensor's range (0..30 bar, -20..85 degC, with
    /// margin): the sensor or the bus is not telling the truth.
    OutOfRange,
}

/// The factory calibration words C1..C6.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Calibration {
    /// `C1..C6` (`c[0]` is C1).
    pub c: [u16; 6],
}

/// One compensated reading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    /// Absolute pressure (Pa).
    pub pressure_pa: f32,
    /// Temperature (degC).
    pub temperature_c: f32,
    /// Raw compensated pressure (0.1 mbar) and temperature (0.01 degC), as the datasheet gives them.
    pub raw: (i32, i32),
}

/// Fluid and surface for depth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthConfig {
    /// Fluid density (kg/m^3): 1029 sea water, 997 fresh water.
    pub density_kg_m3: f32,
    /// Pressure at the surface (Pa), measured before the dive or 101325.
    pub surface_pressure_pa: f32,
    /// Gravity (m/s^2).
    pub gravity_m_s2: f32,
}

impl Default for DepthConfig {
    fn default() -> Self {
        Self {
            density_kg_m3: 1029.0,
            surface_pressure_pa: 101_325.0,
            gravity_m_s2: 9.806_65,
        }
    }
}

impl DepthConfig {
    /// Depth below the surface (m) of a pressure.
    pub fn depth_m(&self, pressure_pa: f32) -> f32 {
        (pressure_pa - self.surface_pressure_pa) / (self.density_kg_m3 * self.gravity_m_s2)
    }
}

/// The datasheet's CRC-4 over the eight PROM words (word 0's CRC bits and word 7 as zero).
pub fn crc4(prom: &[u16; 7]) -> u8 {
    let mut words = [0u16; 8];
    words[..7].copy_from_slice(prom);
    words[0] &= 0x0FFF;
    let mut rem: u16 = 0;
    for byte in words.iter().flat_map(|w| w.to_be_bytes()) {
        rem ^= u16::from(byte);
        for _ in 0..8 {
            rem = if rem & 0x8000 != 0 {
                (rem << 1) ^ 0x3000
            } else {
                rem << 1
            };
        }
    }
    ((rem >> 12) & 0xF) as u8
}

/// Compensate the raw `d1` (pressure) and `d2` (temperature) with first- and second-order
/// terms; returns (pressure in 0.1 mbar, temperature in 0.01 degC).
pub fn compensate(cal: &Calibration, d1: u32, d2: u32) -> (i32, i32) {
    let c = cal.c.map(i64::from);
    let (d1, d2) = (i64::from(d1), i64::from(d2));
    let dt = d2 - (c[4] << 8);
    let temp = 2000 + ((dt * c[5]) >> 23);
    let off = (c[1] << 16) + ((c[3] * dt) >> 7);
    let sens = (c[0] << 15) + ((c[2] * dt) >> 8);
    let (ti, offi, sensi) = if temp < 2000 {
        let t2 = (temp - 2000) * (temp - 2000);
        let (mut offi, mut sensi) = ((3 * t2) >> 1, (5 * t2) >> 3);
        if temp < -1500 {
            let t3 = (temp + 1500) * (temp + 1500);
            offi += 7 * t3;
            sensi += 4 * t3;
        }
        ((3 * dt * dt) >> 33, offi, sensi)
    } else {
        let t2 = (temp - 2000) * (temp - 2000);
        ((2 * dt * dt) >> 37, t2 >> 4, 0)
    };
    let p = (((d1 * (sens - sensi)) >> 21) - (off - offi)) >> 13;
    (p as i32, (temp - ti) as i32)
}

/// Which conversion [`Ms5837::start`] starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Conversion {
    /// D1, the raw pressure.
    Pressure,
    /// D2, the raw temperature.
    Temperature,
}

/// The driver: an I2C bus, the calibration read at `new`, the oversampling ratio.
#[derive(Debug)]
pub struct Ms5837<I> {
    i2c: I,
    cal: Calibration,
    osr: Osr,
}

impl<I: I2c> Ms5837<I> {
    /// Reset the sensor, read and check its PROM (CRC-4 and product type).
    pub fn new(mut i2c: I, delay: &mut impl DelayNs, osr: Osr) -> Result<Self, Error<I::Error>> {
        i2c.write(ADDRESS, &[CMD_RESET]).map_err(Error::Bus)?;
        delay.delay_us(RESET_TIME_US);
        let mut prom = [0u16; 7];
        for (k, w) in prom.iter_mut().enumerate() {
            let mut b = [0u8; 2];
            i2c.write_read(ADDRESS, &[CMD_PROM_READ + 2 * k as u8], &mut b)
                .map_err(Error::Bus)?;
            *w = u16::from_be_bytes(b);
        }
        let stored = (prom[0] >> 12) as u8;
        let computed = crc4(&prom);
        if stored != computed {
            return Err(Error::PromCrc { stored, computed });
        }
        let product = (prom[0] >> 5) & 0x7F;
        if product != PRODUCT_30BA26 {
            return Err(Error::WrongChip { product });
        }
        let mut c = [0u16; 6];
        c.copy_from_slice(&prom[1..7]);
        Ok(Self {
            i2c,
            cal: Calibration { c },
            osr,
        })
    }

    /// The calibration words.
    pub fn calibration(&self) -> Calibration {
        self.cal
    }

    /// Give the bus back.
    pub fn release(self) -> I {
        self.i2c
    }

    /// Start a conversion without waiting: `Pressure` (D1) or `Temperature` (D2), at the
    /// driver's oversampling. Read it with [`read_adc`](Self::read_adc) after
    /// [`Osr::conversion_time_us`]: a loop that must not wait starts one, goes on, and reads
    /// it on a later pass.
    pub fn start(&mut self, what: Conversion) -> Result<(), Error<I::Error>> {
        let cmd = match what {
            Conversion::Pressure => CMD_CONVERT_D1,
            Conversion::Temperature => CMD_CONVERT_D2,
        };
        self.i2c
            .write(ADDRESS, &[cmd + self.osr.code()])
            .map_err(Error::Bus)
    }

    /// The result of the last conversion started; `NotConverted` when it was read too early
    /// (the sensor answers 0).
    pub fn read_adc(&mut self) -> Result<u32, Error<I::Error>> {
        let mut b = [0u8; 3];
        self.i2c
            .write_read(ADDRESS, &[CMD_ADC_READ], &mut b)
            .map_err(Error::Bus)?;
        let v = u32::from_be_bytes([0, b[0], b[1], b[2]]);
        if v == 0 {
            return Err(Error::NotConverted);
        }
        Ok(v)
    }

    /// A compensated reading from the raw pressure `d1` and temperature `d2`; a pressure or
    /// temperature outside the sensor's range (0-30 bar, -20-85 degC, 10 % margin) is a fault.
    pub fn reading(&self, d1: u32, d2: u32) -> Result<Reading, Error<I::Error>> {
        let (p, t) = compensate(&self.cal, d1, d2);
        if !(-1_000..=330_000).contains(&p) || !(-4_000..=9_500).contains(&t) {
            return Err(Error::OutOfRange);
        }
        Ok(Reading {
            pressure_pa: p as f32 * 10.0,
            temperature_c: t as f32 * 0.01,
            raw: (p, t),
        })
    }

    fn convert(
        &mut self,
        what: Conversion,
        delay: &mut impl DelayNs,
    ) -> Result<u32, Error<I::Error>> {
        self.start(what)?;
        delay.delay_us(self.osr.conversion_time_us());
        self.read_adc()
    }

    /// One compensated reading, waiting for it: a D1 and a D2 conversion (2 x the
    /// conversion time).
    pub fn read(&mut self, delay: &mut impl DelayNs) -> Result<Reading, Error<I::Error>> {
        let d1 = self.convert(Conversion::Pressure, delay)?;
        let d2 = self.convert(Conversion::Temperature, delay)?;
        self.reading(d1, d2)
    }
}
