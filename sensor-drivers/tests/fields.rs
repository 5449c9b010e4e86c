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
