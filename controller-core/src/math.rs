//! All floating-point maths of the core, in `f32`, in one place.
//!
//! On a Cortex-M4F the FPU does single precision only. `libm`'s `sinf`/`cosf` evaluate their
//! kernels in `f64`, which the M4F runs in software (about 1,250 instructions a call under
//! QEMU), so this module carries its own single-precision sine and cosine: a Cody-Waite
//! reduction by pi/2 in three parts followed by the Cephes minimax polynomials on
//! [-pi/4, pi/4]. Absolute error is below 1e-6 for |x| <= 1e4 rad (checked in the tests
//! against `f64`). `atan2f` comes from `libm`, whose single-precision version is pure `f32`;
//! the square root is a Newton iteration on `1/sqrt` (see [`sqrt`]). Nothing here touches `f64`, so no `__aeabi_d*` helper is linked into the
//! control path.

use core::f32::consts::{FRAC_2_PI, FRAC_PI_4, PI, TAU};

// pi/2 split into three parts so that k * PIO2_1 is exact for |k| < 2^16.
const PIO2_1: f32 = 1.570_312_5;
const PIO2_2: f32 = 4.837_513e-4;
const PIO2_3: f32 = 7.549_79e-8;

#[inline(always)]
fn sin_poly(r: f32, z: f32) -> f32 {
    ((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1) * z * r + r
}

#[inline(always)]
fn cos_poly(z: f32) -> f32 {
    ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2) * z * z - 0.5 * z + 1.0
}

/// Sine and cosine of `x` (radians), computed together with one range reduction.
///
/// Error below 1e-6 for |x| <= 1e4. Non-finite input gives NaN.
#[inline]
pub fn sin_cos(x: f32) -> (f32, f32) {
    let kf = x * FRAC_2_PI;
    // Round to nearest; `as` saturates and maps NaN to 0 (NaN then propagates through r).
    let k = (kf + 0.5f32.copysign(kf)) as i32;
    let kf = k as f32;
    let r = ((x - kf * PIO2_1) - kf * PIO2_2) - kf * PIO2_3;
    let z = r * r;
    let s = sin_poly(r, z);
    let c = cos_poly(z);
    match k & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// [`sin_cos`] for angles that are usually small (pitch, roll, sideslip): for |x| <= pi/4 the
/// range reduction is skipped and the polynomials take `x` itself, otherwise [`sin_cos`].
/// Bit-identical to [`sin_cos`] except near |x| = pi/4, where `sin_cos`'s rounding of
/// `x 2/pi` may pick the next quadrant; both are then within 1 ulp of each other (tested).
#[inline]
pub fn sin_cos_small(x: f32) -> (f32, f32) {
    if x.abs() <= FRAC_PI_4 {
        let z = x * x;
        (sin_poly(x, z), cos_poly(z))
    } else {
        sin_cos(x)
    }
}

/// Sine of `x` (radians). See [`sin_cos`].
#[inline]
pub fn sin(x: f32) -> f32 {
    sin_cos(x).0
}

/// Cosine of `x` (radians). See [`sin_cos`].
#[inline]
pub fn cos(x: f32) -> f32 {
    sin_cos(x).1
}

/// Four-quadrant arctangent of `y / x` (single precision `libm`, pure `f32`).
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    libm::atan2f(y, x)
}

/// Square root in safe `f32` (no `f64`, no `unsafe`, no division).
///
/// `libm::sqrtf` is integer code (about 66 instructions a call on the M4F). Here: a bit-trick
/// first guess of `1/sqrt(x)` (relative error below 3.5e-2), one third-order step on the
/// reciprocal square root (below 1.1e-4), `s = x * y`, and one last Newton correction
/// `s (1 + (1 - s y) / 2)` that leaves about one ulp (relative error below 2e-7, checked in
/// the tests against `f64`). Subnormal inputs are scaled by 2^24 first.
/// `sqrt(+-0) = +-0`, `sqrt(inf) = inf`, negative or NaN give NaN.
#[inline]
pub fn sqrt(x: f32) -> f32 {
    // Positive, normal and finite: the bits lie in [0x0080_0000, 0x7f80_0000).
    if x.to_bits().wrapping_sub(0x0080_0000) < 0x7f00_0000 {
        sqrt_normal(x)
    } else {
        sqrt_special(x)
    }
}

/// Square root of a positive, normal, finite `x` (see [`sqrt`]).
#[inline(always)]
fn sqrt_normal(x: f32) -> f32 {
    let y = f32::from_bits(0x5f37_59df_u32.wrapping_sub(x.to_bits() >> 1));
    // y (1 - e)^(-1/2) to third order, e = 1 - x y^2; (x y) y neither underflows nor overflows.
    let e = 1.0 - (x * y) * y;
    let y = y + y * (e * (0.5 + 0.375 * e));
    let s = x * y;
    s + s * (0.5 * (1.0 - s * y))
}

/// [`sqrt`] for zero, subnormal, infinite, negative and NaN inputs.
#[cold]
#[inline(never)]
fn sqrt_special(x: f32) -> f32 {
    if x > 0.0 && x < f32::MIN_POSITIVE {
        // Scale by 2^24 (exact), the root back by 2^-12 (exact).
        sqrt_normal(x * 16_777_216.0) * (1.0 / 4096.0)
    } else if x == 0.0 || x == f32::INFINITY {
        // +-0 -> +-0, +inf -> +inf.
        x
    } else {
        // Negative, -inf, NaN.
        f32::NAN
    }
}

/// Arcsine through `atan2(x, sqrt(1 - x^2))`; the argument is clamped to [-1, 1] first.
///
/// (`libm::asinf` takes a square root in `f64` for |x| >= 0.5.)
#[inline]
pub fn asin(x: f32) -> f32 {
    let x = clamp(x, -1.0, 1.0);
    atan2(x, sqrt((1.0 - x) * (1.0 + x)))
}

/// Hyperbolic tangent (single precision `libm`, pure `f32`).
#[inline]
pub fn tanh(x: f32) -> f32 {
    libm::tanhf(x)
}

/// Wrap an angle to (-pi, pi].
#[inline]
pub fn wrap_angle(a: f32) -> f32 {
    if (-PI..=PI).contains(&a) {
        if a == -PI {
            return PI;
        }
        return a;
    }
    let turns = a / TAU;
    let k = (turns + 0.5f32.copysign(turns)) as i32 as f32;
    // Subtract 2*pi*k in two parts for accuracy.
    let mut w = (a - k * 6.283_185_5) + k * 1.748_455_6e-7;
    if w <= -PI {
        w += TAU;
    } else if w > PI {
        w -= TAU;
    }
    w
}

/// `x * |x|`: the signed square used by quadratic drag.
#[inline(always)]
pub fn sq_signed(x: f32) -> f32 {
    x * x.abs()
}

/// Clamp `x` into `[lo, hi]` (for `lo <= hi`); NaN gives `lo`.
///
/// Unlike `f32::clamp` it has no `lo <= hi` assertion, so bounds computed at run time leave
/// no panic path (and no panic-message formatting) in the image.
#[inline(always)]
pub fn clamp(x: f32, lo: f32, hi: f32) -> f32 {
    // Plain comparisons: `f32::max`/`min` become calls of `fmaxf`/`fminf` on the M4F.
    let y = if x > lo { x } else { lo };
    if y < hi {
        y
    } else {
        hi
    }
}

/// The larger of `a` and `b` by one comparison (`b` when `a` is NaN).
#[inline(always)]
pub fn max(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// The smaller of `a` and `b` by one comparison (`b` when `a` is NaN).
#[inline(always)]
pub fn min(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// Clamp `x` into `[lo, hi]` and keep a NaN (as `f32::clamp`, without its `lo <= hi`
/// assertion): for iterations whose caller tests the result for NaN.
#[inline(always)]
pub fn clamp_keep_nan(x: f32, lo: f32, hi: f32) -> f32 {
    if x < lo {
        lo
    } else if x > hi {
        hi
    } else {
        x
    }
}

/// Clamp `x` into `[lo, hi]`, mapping NaN to the point of the range nearest zero: a NaN must
/// never reach a thruster.
#[inline]
pub fn clamp_nan_safe(x: f32, lo: f32, hi: f32) -> f32 {
    if x.is_nan() {
        clamp(0.0, lo, hi)
    } else {
        clamp(x, lo, hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sin_cos_small_matches_sin_cos() {
        // Densely over [-2, 2] rad: the fast path (|x| <= pi/4) and the fallback. Bit for bit
        // except within 1e-6 rad of pi/4, where the two may differ by 1 ulp.
        let n = 400_000;
        let ulp = |a: f32, b: f32| (a.to_bits() as i64 - b.to_bits() as i64).abs();
        for i in 0..=n {
            let x = -2.0 + 4.0 * i as f32 / n as f32;
            let (a, b) = (sin_cos_small(x), sin_cos(x));
            let edge = (x.abs() - FRAC_PI_4).abs() < 1e-6;
            let tol = if edge { 1 } else { 0 };
            assert!(
                ulp(a.0, b.0) <= tol && ulp(a.1, b.1) <= tol,
                "{x}: {a:?} {b:?}"
            );
        }
        for x in [FRAC_PI_4, -FRAC_PI_4] {
            let (a, b) = (sin_cos_small(x), sin_cos(x));
            assert!(ulp(a.0, b.0) <= 1 && ulp(a.1, b.1) <= 1, "{x}");
        }
        assert!(sin_cos_small(f32::NAN).0.is_nan());
    }

    #[test]
    fn sin_cos_accuracy_over_wide_range() {
        let mut worst = 0.0f64;
        let n = 400_000;
        for i in 0..=n {
            let x = -1.0e4f32 + 2.0e4 * (i as f32) / (n as f32);
            let (s, c) = sin_cos(x);
            let xd = x as f64;
            worst = worst.max((s as f64 - xd.sin()).abs());
            worst = worst.max((c as f64 - xd.cos()).abs());
        }
        assert!(worst < 1.0e-6, "worst abs error {worst:e}");
    }

    #[test]
    fn sin_cos_accuracy_near_zero_dense() {
        let mut worst = 0.0f64;
        for i in -200_000..=200_000 {
            let x = i as f32 * 5.0e-5; // [-10, 10] rad
            let (s, c) = sin_cos(x);
            worst = worst.max((s as f64 - (x as f64).sin()).abs());
            worst = worst.max((c as f64 - (x as f64).cos()).abs());
        }
        assert!(worst < 2.0e-7, "worst abs error {worst:e}");
    }

    #[test]
    fn non_finite_gives_nan() {
        assert!(sin(f32::NAN).is_nan());
        assert!(cos(f32::INFINITY).is_nan());
    }

    #[test]
    fn wrap_angle_range_and_identity() {
        for i in -10_000..10_000 {
            let a = i as f32 * 3.7e-3 * 7.0;
            let w = wrap_angle(a);
            assert!(w > -PI && w <= PI, "{a} -> {w}");
            let d = (a as f64 - w as f64) / core::f64::consts::TAU;
            assert!((d - d.round()).abs() < 1e-5, "{a} -> {w}");
        }
        assert_eq!(wrap_angle(-PI), PI);
    }

    #[test]
    fn clamp_behaves() {
        assert_eq!(clamp(5.0, -1.0, 2.0), 2.0);
        assert_eq!(clamp(-5.0, -1.0, 2.0), -1.0);
        assert_eq!(clamp(0.5, -1.0, 2.0), 0.5);
        assert_eq!(clamp(f32::NAN, -1.0, 2.0), -1.0);
        assert_eq!(clamp_nan_safe(f32::NAN, -1.0, 2.0), 0.0);
        assert_eq!(clamp_nan_safe(f32::NAN, 1.0, 2.0), 1.0);
        assert!(clamp_keep_nan(f32::NAN, -1.0, 2.0).is_nan());
        for x in [-3.0f32, -1.0, 0.5, 2.0, 7.0] {
            assert_eq!(clamp_keep_nan(x, -1.0, 2.0), x.clamp(-1.0, 2.0));
        }
    }

    fn sqrt_rel_err(x: f32) -> f64 {
        let e = (x as f64).sqrt();
        ((sqrt(x) as f64) - e).abs() / e
    }

    #[test]
    fn sqrt_accuracy_over_all_binades() {
        let mut worst = 0.0f64;
        // Every binade from the smallest subnormal to f32::MAX, 4,099 mantissas in each.
        let mut bits = 1u32;
        while bits < f32::INFINITY.to_bits() {
            let x = f32::from_bits(bits);
            worst = worst.max(sqrt_rel_err(x));
            bits += 2047;
        }
        // Dense over [1/4, 4) (two binades of the exponent parity).
        for i in 0..2_000_000u32 {
            let x = 0.25 + 3.75 * (i as f32) / 2.0e6;
            worst = worst.max(sqrt_rel_err(x));
        }
        for x in [
            f32::MIN_POSITIVE,
            f32::MAX,
            1.0,
            2.0,
            4.0,
            1.0e-45,
            0.999_999_94,
        ] {
            worst = worst.max(sqrt_rel_err(x));
        }
        assert!(worst <= 2.0e-7, "worst rel error {worst:e}");
    }

    #[test]
    fn sqrt_special_values() {
        assert_eq!(sqrt(0.0).to_bits(), 0.0f32.to_bits());
        assert_eq!(sqrt(-0.0).to_bits(), (-0.0f32).to_bits());
        assert_eq!(sqrt(f32::INFINITY), f32::INFINITY);
        assert!(sqrt(-1.0).is_nan());
        assert!(sqrt(-f32::MIN_POSITIVE).is_nan());
        assert!(sqrt(f32::NEG_INFINITY).is_nan());
        assert!(sqrt(f32::NAN).is_nan());
        assert_eq!(sqrt(4.0), 2.0);
        assert_eq!(sqrt(1.0), 1.0);
        assert_eq!(sqrt(0.25), 0.5);
        assert!(sqrt(f32::MAX).is_finite());
    }

    #[test]
    fn min_max_behave() {
        assert_eq!(max(1.0, 2.0), 2.0);
        assert_eq!(max(3.0, 2.0), 3.0);
        assert_eq!(min(1.0, 2.0), 1.0);
        assert_eq!(min(3.0, 2.0), 2.0);
        assert_eq!(max(f32::NAN, 2.0), 2.0);
        assert_eq!(min(f32::NAN, 2.0), 2.0);
    }

    #[test]
    fn asin_matches_f64() {
        for i in -1000..=1000 {
            let x = i as f32 / 1000.0;
            assert!((asin(x) as f64 - (x as f64).asin()).abs() < 1e-6);
        }
        assert!((asin(2.0) - core::f32::consts::FRAC_PI_2).abs() < 1e-6);
    }
}
