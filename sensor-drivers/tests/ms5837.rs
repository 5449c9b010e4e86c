//! MS5837-30BA against the datasheet: the exact I2C transactions, the worked example of the
//! compensation, and the failure paths.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use embedded_hal::i2c::ErrorKind;
use embedded_hal_mock::eh1::delay::{CheckedDelay, NoopDelay, Transaction as D};
use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};
use sensor_drivers::ms5837::{
    compensate, crc4, Calibration, Conversion, DepthConfig, Error, Ms5837, Osr, ADDRESS,
};

/// The datasheet's example coefficients C1..C6.
const C: [u16; 6] = [34982, 36352, 20328, 22354, 26646, 26146];
/// Word 0: CRC 9 (computed with the datasheet's C routine, in Python), product 0x1A.
const WORD0: u16 = 0x9340;
/// The datasheet's example conversions.
const D1: u32 = 4_958_179;
const D2: u32 = 6_815_414;

fn prom_reads(word0: u16) -> Vec<T> {
    let mut v = vec![T::write(ADDRESS, vec![0x1E])];
    let words = [word0, C[0], C[1], C[2], C[3], C[4], C[5]];
    for (k, w) in words.iter().enumerate() {
        v.push(T::write_read(
            ADDRESS,
            vec![0xA0 + 2 * k as u8],
            w.to_be_bytes().to_vec(),
        ));
    }
    v
}

fn adc(cmd: u8, value: u32) -> [T; 2] {
    [
        T::write(ADDRESS, vec![cmd]),
        T::write_read(ADDRESS, vec![0x00], value.to_be_bytes()[1..].to_vec()),
    ]
}

#[test]
fn crc4_of_the_example_prom_is_the_datasheet_routine_s() {
    assert_eq!(crc4(&[WORD0, C[0], C[1], C[2], C[3], C[4], C[5]]), 9);
    // The CRC bits of word 0 do not take part.
    assert_eq!(
        crc4(&[WORD0 & 0x0FFF, C[0], C[1], C[2], C[3], C[4], C[5]]),
        9
    );
    assert_ne!(crc4(&[WORD0, C[0] ^ 1, C[1], C[2], C[3], C[4], C[5]]), 9);
}

#[test]
fn first_order_reproduces_the_datasheet_example() {
    // Datasheet: dT = -5962, TEMP = 1981 (19.81 degC), P = 39998 (3999.8 mbar). At 19.81 degC
    // the second-order terms are OFFi = 541, SENSi = 225, Ti = 0, which leave P at 39998.
    let (p, t) = compensate(&Calibration { c: C }, D1, D2);
    assert_eq!((p, t), (39998, 1981));
}

#[test]
fn second_order_above_20_degc() {
    // D2 = 6,900,000: TEMP = 2245, Ti = 0, OFFi = 3751, SENSi = 0 -> P = 40134.
    assert_eq!(
        compensate(&Calibration { c: C }, D1, 6_900_000),
        (40134, 2245)
    );
}

#[test]
fn second_order_below_minus_15_degc() {
    // D2 = 5,000,000: TEMP = -3677, Ti = 1158, OFFi = 81,517,796, SENSi = 39,100,021
    // -> P = 35762, TEMP2 = -4835.
    assert_eq!(
        compensate(&Calibration { c: C }, D1, 5_000_000),
        (35762, -4835)
    );
}

#[test]
fn bring_up_and_one_reading_are_the_datasheet_transactions() {
    let mut ex = prom_reads(WORD0);
    ex.extend(adc(0x4A, D1)); // D1 at OSR 8192
    ex.extend(adc(0x5A, D2)); // D2 at OSR 8192
    let mut i2c = Mock::new(&ex);
    // The waits: the PROM reload after the reset, then each conversion at OSR 8192.
    let mut delay =
        CheckedDelay::new(&[D::delay_us(2_800), D::delay_us(18_080), D::delay_us(18_080)]);
    let mut s = Ms5837::new(i2c.clone(), &mut delay, Osr::Osr8192).unwrap();
    assert_eq!(s.calibration().c, C);
    let r = s.read(&mut delay).unwrap();
    delay.done();
    assert_eq!(r.raw, (39998, 1981));
    assert!((r.pressure_pa - 399_980.0).abs() < 0.5);
    assert!((r.temperature_c - 19.81).abs() < 1e-4);
    i2c.done();
}

#[test]
fn each_oversampling_ratio_sends_its_command() {
    for (osr, d1, d2) in [
        (Osr::Osr256, 0x40, 0x50),
        (Osr::Osr1024, 0x44, 0x54),
        (Osr::Osr4096, 0x48, 0x58),
    ] {
        let mut ex = prom_reads(WORD0);
        ex.extend(adc(d1, D1));
        ex.extend(adc(d2, D2));
        let mut i2c = Mock::new(&ex);
        let mut s = Ms5837::new(i2c.clone(), &mut NoopDelay, osr).unwrap();
        s.read(&mut NoopDelay).unwrap();
        i2c.done();
    }
    assert_eq!(Osr::Osr8192.conversion_time_us(), 18_080);
}

#[test]
fn a_bad_prom_crc_is_refused_with_both_values() {
    let mut i2c = Mock::new(&prom_reads(0x5340));
    let e = Ms5837::new(i2c.clone(), &mut NoopDelay, Osr::Osr8192).unwrap_err();
    assert_eq!(
        e,
        Error::PromCrc {
            stored: 5,
            computed: 9
        }
    );
    i2c.done();
}

#[test]
fn another_product_is_refused() {
    // Product 0x15 (an MS5837-02BA21) with its own correct CRC.
    let w0 = 0x15 << 5;
    let crc = crc4(&[w0, C[0], C[1], C[2], C[3], C[4], C[5]]);
    let mut i2c = Mock::new(&prom_reads((u16::from(crc) << 12) | w0));
    let e = Ms5837::new(i2c.clone(), &mut NoopDelay, Osr::Osr8192).unwrap_err();
    assert_eq!(e, Error::WrongChip { product: 0x15 });
    i2c.done();
}

#[test]
fn a_bus_error_is_an_error_value() {
    let mut i2c = Mock::new(&[T::write(ADDRESS, vec![0x1E]).with_error(ErrorKind::Bus)]);
    let e = Ms5837::new(i2c.clone(), &mut NoopDelay, Osr::Osr8192).unwrap_err();
    assert_eq!(e, Error::Bus(ErrorKind::Bus));
    i2c.done();
}

#[test]
fn an_unfinished_conversion_and_an_absurd_reading_are_refused() {
    let mut ex = prom_reads(WORD0);
    ex.extend(adc(0x4A, 0)); // the ADC reads 0 when no conversion finished
    ex.extend(adc(0x4A, D1));
    ex.extend(adc(0x5A, 5_000_000)); // -48 degC: outside the sensor's range
    let mut i2c = Mock::new(&ex);
    let mut s = Ms5837::new(i2c.clone(), &mut NoopDelay, Osr::Osr8192).unwrap();
    assert_eq!(s.read(&mut NoopDelay).unwrap_err(), Error::NotConverted);
    assert_eq!(s.read(&mut NoopDelay).unwrap_err(), Error::OutOfRange);
    i2c.done();
}

#[test]
fn depth_from_pressure_in_sea_and_fresh_water() {
    let sea = DepthConfig::default();
    // 10 m of sea water: rho g h = 1029 * 9.80665 * 10 Pa.
    let p10 = sea.surface_pressure_pa + 1029.0 * 9.806_65 * 10.0;
    assert!((sea.depth_m(p10) - 10.0).abs() < 1e-4);
    let fresh = DepthConfig {
        density_kg_m3: 997.0,
        surface_pressure_pa: 100_000.0,
        ..DepthConfig::default()
    };
    assert!((fresh.depth_m(100_000.0 + 997.0 * 9.806_65 * 2.5) - 2.5).abs() < 1e-4);
    assert_eq!(fresh.depth_m(100_000.0), 0.0);
}

#[test]
fn conversions_started_and_read_on_later_loop_passes_without_a_wait() {
    // The loop's way: start D1, come back later, read it and start D2, come back, read D2.
    let mut ex = prom_reads(WORD0);
    ex.extend(adc(0x48, D1)); // D1 at OSR 4096
    ex.extend(adc(0x58, D2)); // D2 at OSR 4096
    let mut i2c = Mock::new(&ex);
    // Only the reset's wait: the conversions are not waited for.
    let mut delay = CheckedDelay::new(&[D::delay_us(2_800)]);
    let mut s = Ms5837::new(i2c.clone(), &mut delay, Osr::Osr4096).unwrap();
    delay.done();
    s.start(Conversion::Pressure).unwrap();
    let d1 = s.read_adc().unwrap();
    s.start(Conversion::Temperature).unwrap();
    let d2 = s.read_adc().unwrap();
    assert_eq!((d1, d2), (D1, D2));
    assert_eq!(s.reading(d1, d2).unwrap().raw, (39998, 1981));
    i2c.done();
}
