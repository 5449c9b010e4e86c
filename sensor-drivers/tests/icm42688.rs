//! ICM-42688-P against the datasheet: the exact SPI transactions of bring-up and of a burst
//! read, the conversion to SI units, and the failure paths.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use embedded_hal::spi::{ErrorKind, ErrorType, Operation, SpiDevice};
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::spi::{Mock, Transaction as T};
use sensor_drivers::icm42688::{reg, AccelRange, Config, Error, GyroRange, Icm42688, Odr};

fn read_reg(addr: u8, value: u8) -> Vec<T<u8>> {
    vec![
        T::transaction_start(),
        T::write_vec(vec![addr | 0x80]),
        T::read_vec(vec![value]),
        T::transaction_end(),
    ]
}

fn write_reg(addr: u8, value: u8) -> Vec<T<u8>> {
    vec![
        T::transaction_start(),
        T::write_vec(vec![addr, value]),
        T::transaction_end(),
    ]
}

fn bring_up(cfg: Config) -> Vec<T<u8>> {
    let mut v = read_reg(reg::WHO_AM_I, 0x47);
    v.extend(write_reg(reg::DEVICE_CONFIG, 0x01));
    v.extend(write_reg(
        reg::GYRO_CONFIG0,
        ((cfg.gyro as u8) << 5) | cfg.odr as u8,
    ));
    v.extend(write_reg(
        reg::ACCEL_CONFIG0,
        ((cfg.accel as u8) << 5) | cfg.odr as u8,
    ));
    v.extend(write_reg(reg::PWR_MGMT0, 0x0F));
    v
}

fn burst(words: [i16; 7]) -> Vec<T<u8>> {
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_be_bytes()).collect();
    vec![
        T::transaction_start(),
        T::write_vec(vec![0x1D | 0x80]),
        T::read_vec(bytes),
        T::transaction_end(),
    ]
}

#[test]
fn bring_up_writes_the_datasheet_registers() {
    let cfg = Config::default();
    let mut spi = Mock::new(&bring_up(cfg));
    let _imu = Icm42688::new(spi.clone(), &mut NoopDelay, cfg).unwrap();
    spi.done();
    // +-500 dps at 1 kHz: GYRO_CONFIG0 = 0b010_0_0110; +-4 g: ACCEL_CONFIG0 = 0b010_0_0110.
    assert_eq!(((cfg.gyro as u8) << 5) | cfg.odr as u8, 0x46);
    assert_eq!(((cfg.accel as u8) << 5) | cfg.odr as u8, 0x46);
}

#[test]
fn a_burst_is_converted_to_si_units() {
    let cfg = Config {
        gyro: GyroRange::Dps2000,
        accel: AccelRange::G16,
        odr: Odr::Hz100,
    };
    let mut ex = bring_up(cfg);
    // Temperature 0 -> 25 degC; accel z -2048 LSB = -1 g at +-16 g; gyro x 164 LSB = 10 dps.
    ex.extend(burst([0, 0, 0, -2048, 164, -164, 0]));
    // 132.48 LSB per degC: 1325 -> about 35 degC.
    ex.extend(burst([1325, 1024, 0, 0, 0, 0, 16]));
    let mut spi = Mock::new(&ex);
    let mut imu = Icm42688::new(spi.clone(), &mut NoopDelay, cfg).unwrap();
    let s = imu.read().unwrap();
    assert!((s.temperature_c - 25.0).abs() < 1e-6);
    assert!(
        (s.accel_m_s2[2] + 9.806_65).abs() < 1e-4,
        "{:?}",
        s.accel_m_s2
    );
    let ten_dps = 10.0f32.to_radians();
    assert!(
        (s.gyro_rad_s[0] - ten_dps).abs() < 1e-3 * ten_dps,
        "{:?}",
        s.gyro_rad_s
    );
    assert!((s.gyro_rad_s[1] + ten_dps).abs() < 1e-3 * ten_dps);
    let s = imu.read().unwrap();
    assert!((s.temperature_c - 35.0).abs() < 0.01);
    assert!((s.accel_m_s2[0] - 0.5 * 9.806_65).abs() < 1e-4);
    assert!(
        (s.gyro_rad_s[2] - 16.0 * 2000.0 / 32768.0 * core::f32::consts::PI / 180.0).abs() < 1e-7
    );
    spi.done();
}

#[test]
fn scale_factors_match_the_datasheet_sensitivities() {
    // Datasheet: 16.4 / 32.8 / 65.5 / 131 LSB/dps and 2048 / 4096 / 8192 / 16384 LSB/g.
    for (r, lsb_per_dps) in [
        (GyroRange::Dps2000, 16.384),
        (GyroRange::Dps1000, 32.768),
        (GyroRange::Dps500, 65.536),
        (GyroRange::Dps250, 131.072),
    ] {
        let per_lsb_dps = r.rad_s_per_lsb().to_degrees();
        assert!((1.0 / per_lsb_dps - lsb_per_dps).abs() < 1e-3, "{r:?}");
    }
    for (r, lsb_per_g) in [
        (AccelRange::G16, 2048.0),
        (AccelRange::G8, 4096.0),
        (AccelRange::G4, 8192.0),
        (AccelRange::G2, 16384.0),
    ] {
        assert!(
            (9.806_65 / r.m_s2_per_lsb() - lsb_per_g).abs() < 1e-2,
            "{r:?}"
        );
    }
}

#[test]
fn another_chip_is_refused_before_anything_is_written() {
    let mut spi = Mock::new(&read_reg(reg::WHO_AM_I, 0x6A));
    let e = Icm42688::new(spi.clone(), &mut NoopDelay, Config::default()).unwrap_err();
    assert!(matches!(e, Error::WrongChip { who_am_i: 0x6A }));
    spi.done();
}

#[test]
fn a_silent_bus_reads_as_the_wrong_chip() {
    // MISO stuck high or low: 0xFF or 0x00.
    for v in [0x00, 0xFF] {
        let mut spi = Mock::new(&read_reg(reg::WHO_AM_I, v));
        assert!(Icm42688::new(spi.clone(), &mut NoopDelay, Config::default()).is_err());
        spi.done();
    }
}

#[test]
fn railed_data_and_an_absurd_temperature_are_refused() {
    let cfg = Config::default();
    let mut ex = bring_up(cfg);
    ex.extend(burst([0, 0, 0, i16::MIN, 0, 0, 0])); // data not ready / saturated
    ex.extend(burst([0, 0, 0, 0, 0, i16::MAX, 0]));
    ex.extend(burst([-10_000, 0, 0, 0, 0, 0, 0])); // about -50 degC
    let mut spi = Mock::new(&ex);
    let mut imu = Icm42688::new(spi.clone(), &mut NoopDelay, cfg).unwrap();
    for _ in 0..3 {
        assert!(matches!(imu.read(), Err(Error::OutOfRange)));
    }
    spi.done();
}

/// An SPI device whose every transfer fails (the mock has no error injection for SPI).
#[derive(Debug)]
struct BrokenBus;

impl ErrorType for BrokenBus {
    type Error = ErrorKind;
}

impl SpiDevice for BrokenBus {
    fn transaction(&mut self, _ops: &mut [Operation<'_, u8>]) -> Result<(), ErrorKind> {
        Err(ErrorKind::Other)
    }
}

#[test]
fn a_bus_error_is_an_error_value() {
    let e = Icm42688::new(BrokenBus, &mut NoopDelay, Config::default()).unwrap_err();
    assert!(matches!(e, Error::Bus(ErrorKind::Other)));
}
