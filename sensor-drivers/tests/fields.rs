//! The fixed-point field reader: the same `f32` as `f32::from_str` for every value the
//! instruments print, and the layouts it refuses.
#![allow(clippy::unwrap_used, clippy::indexing_slicing)]

use sensor_drivers::fields::{fixed_point, Fields};

fn fixed_f32(s: &str, decimals: usize) -> Option<f32> {
    Fields::new(s.as_bytes(), b',')
        .next_fixed_f32(decimals)
        .ok()
}

#[test]
fn fixed_point_values_equal_from_str_bit_for_bit() {
    for decimals in [1_usize, 2, 3] {
        let scale = 10_u64.pow(decimals as u32);
        // Every value up to 99.999 (3 decimals), then a sparse sweep up to past 2^24.
        let dense = (0..100 * scale).step_by(1);
        let sparse = (0..40_000_000_u64).step_by(9_973);
        for units in dense.chain(sparse) {
            for sign in ["", "-"] {
                let s = format!(
                    "{sign}{}.{:0w$}",
                    units / scale,
                    units % scale,
                    w = decimals
                );
                let want: f32 = s.parse().unwrap();
                let got = fixed_f32(&s, decimals).unwrap();
                assert_eq!(got.to_bits(), want.to_bits(), "{s}");
            }
        }
    }
}

#[test]
fn layouts_other_than_c_printf_are_refused() {
    assert_eq!(fixed_point("0.250", 3), Some((250, false)));
    assert_eq!(fixed_point("-12.05", 2), Some((1205, true)));
    for bad in [
        "+0.250", "00.250", "01.250", ".250", "0.25", "0.2500", "0,250", "0.2a0", "--0.250",
        "0.-25", "", "-", "1e-3", "inf", "NaN", " 0.250",
    ] {
        assert_eq!(fixed_point(bad, 3), None, "{bad:?}");
    }
    // 20 digits overflow u64.
    assert_eq!(fixed_point("99999999999999999.999", 3), None);
}

#[test]
fn the_compact_f32_reader_is_the_nearest_in_its_exact_range_and_close_beyond() {
    use sensor_drivers::fields::parse_f32_compact;
    // The forms an A50 prints: the nearest f32, bit for bit.
    for s in [
        "0",
        "0.000",
        "-0.000",
        "1e-07",
        "1.4e-07",
        "1.400e-5",
        "2.5E-3",
        "0.250",
        "-1.235",
        "200.00",
        "1075.51",
        "3.20",
        "12345678",
        "+7",
        "1.",
        ".5",
        "16777215e-10",
        "9e10",
        "0.0001234",
        "1e+3",
    ] {
        let want: f32 = s.parse().unwrap();
        assert_eq!(
            parse_f32_compact(s).map(f32::to_bits),
            Some(want.to_bits()),
            "{s}"
        );
    }
    // 19 digits, exponents to +-19: the nearest too.
    for s in [
        "49056.809",
        "123456789012345678",
        "1234567890123456789e-19",
        "1e19",
        "0.1234567891",
        "16777217",
        "1.0000000596046448",
    ] {
        let want: f32 = s.parse().unwrap();
        assert_eq!(
            parse_f32_compact(s).map(f32::to_bits),
            Some(want.to_bits()),
            "{s}"
        );
    }
    // Beyond (exponents past 19): within 3 units in the last place.
    let mut worst = 0_i64;
    for s in [
        "1.2345678901234567e-20",
        "3.4e38",
        "1e-30",
        "9.999999e-39",
        "6.02214076e23",
        "1.17549435e-38",
    ] {
        let want: f32 = s.parse().unwrap();
        let got = parse_f32_compact(s).unwrap();
        let ulps = (i64::from(got.to_bits() as i32) - i64::from(want.to_bits() as i32)).abs();
        worst = worst.max(ulps);
        assert!(ulps <= 3, "{s}: {got} vs {want} ({ulps} ulps)");
    }
    println!("worst beyond the exact range: {worst} ulps");
    // Refused: what is not a decimal number, a value beyond f32, 20 significant digits.
    for s in [
        "",
        "-",
        ".",
        "e5",
        "1e",
        "1e+",
        "1.2.3",
        "1e5.0",
        "inf",
        "NaN",
        "0x10",
        "1 2",
        "--1",
        "1e39",
        "4e38",
        "12345678901234567890",
        "1e12345",
    ] {
        assert_eq!(parse_f32_compact(s), None, "{s}");
    }
    // Tiny values are zero, as from_str gives them.
    assert_eq!(parse_f32_compact("1e-90"), Some(0.0));
}

#[test]
fn the_compact_f32_reader_equals_from_str_over_a_sweep() {
    use sensor_drivers::fields::parse_f32_compact;
    // 200,000 numbers of 1-19 digits, the point anywhere, exponents -10..=10: the same bits
    // as f32::from_str where the point and the exponent make a power of ten within +-19,
    // within 3 units in the last place beyond.
    let mut x = 0x2545_f491_4f6c_dd1d_u64;
    let mut exact = 0;
    for i in 0..200_000_u32 {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        let digits = 1 + (x % 19) as usize;
        let m = (x >> 8) % 10_u64.pow(digits as u32);
        let text = format!("{m:0digits$}");
        let point = (x >> 40) as usize % (digits + 1);
        let (int, frac) = text.split_at(point);
        let int = if int.is_empty() { "0" } else { int };
        let exp = ((x >> 48) % 21) as i32 - 10;
        let sign = if i % 2 == 0 { "" } else { "-" };
        let s = format!("{sign}{int}.{frac}e{exp}");
        let want: f32 = s.parse().unwrap();
        let got = parse_f32_compact(&s).unwrap();
        let folded = exp - frac.len() as i32;
        if folded.abs() <= 19 {
            exact += 1;
            assert_eq!(got.to_bits(), want.to_bits(), "{s}");
        } else {
            let ulps = (i64::from(got.to_bits() as i32) - i64::from(want.to_bits() as i32)).abs();
            assert!(ulps <= 3, "{s}: {ulps} ulps");
        }
    }
    assert!(exact > 150_000, "{exact}");
}
