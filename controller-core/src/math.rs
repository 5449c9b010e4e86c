//! All floating-point maths of the core, in `f32`, in one place.
//!
//! On a Cortex-M4F the FPU does single precision only. `libm`'s `sinf`/`cosf` evaluate their
//! kernels in `f64`, which the M4F runs in software (about 1,250 instructions a call under
//! QEMU), so this module carries its own single-precision sine and cosine: a Cody-Waite
//! reduction by pi/2 in three parts followed by the Cephes minimax polynomials on
//! [-pi/4, pi/4]. Absolute error is below 1e-6 for |x| <= 1e4 rad (checked in the tests
//! against `f64`). `atan2`, `asin` and `tanh` are own `f32` polynomials (Cephes), cheaper
//! than `libm`'s (see each); the square root is a Newton iteration on `1/sqrt` (see [`sqrt`]). Nothing here touches `f64`, so no `__aeabi_d*` helper is linked into the
//! control path.

use core::f32::consts::{FRAC_2_PI, FRAC_PI_2, FRAC_PI_4, PI, TAU};

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

/// Arctangent of `t` for |t| <= tan(pi/8) (Cephes `atanf` polynomial).
#[inline(always)]
fn atan_poly(t: f32) -> f32 {
    let z = t * t;
    (((8.053_744_5e-2 * z - 1.387_768_6e-1) * z + 1.997_771_1e-1) * z - 3.333_295e-1) * z * t + t
}

/// pi/4 - f32(pi/4).
const PIO4_LO: f32 = -2.185_569e-8;

/// Four-quadrant arctangent of `y / x`, pure `f32`.
///
/// `libm::atan2f` costs about 100 instructions a call on the M4F (special-case tests, then
/// `atanf` with its own reduction); here one division reduces to the first octant,
/// `(a - b) / (a + b)` to [-tan(pi/8), tan(pi/8)], a degree-9 odd polynomial, and the octant
/// and quadrant are put back. Relative error below 2e-7 (tested against `f64`). Zeros,
/// infinities and NaN go to `libm::atan2f` (same special values). Not inlined: a copy at
/// each of the laws' call sites would cost 200 B of flash apiece.
#[inline(never)]
pub fn atan2(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (num, den, swapped) = if ay > ax {
        (ax, ay, true)
    } else {
        (ay, ax, false)
    };
    // `den` (>= +0 or NaN) positive and finite: `num / den` is in [0, 1] (or NaN).
    if den.is_nan() || den <= 0.0 || den.is_infinite() {
        return atan2_special(y, x);
    }
    // atan(num/den) in [0, pi/4]: above tan(pi/8) as pi/4 + atan((n - d)/(n + d)).
    let mid = num > 0.414_213_57 * den;
    let p = atan_poly(if mid {
        (num - den) / (num + den)
    } else {
        num / den
    });
    // First quadrant: off + (lo + -+p), with pi/4 and pi/2 in two parts (their f32 rounding
    // alone is 3e-8 relative); pi/2 - (pi/4 + p) = pi/4 - p.
    let (off, lo) = if mid {
        (FRAC_PI_4, PIO4_LO)
    } else if swapped {
        (FRAC_PI_2, 2.0 * PIO4_LO)
    } else {
        (0.0, 0.0)
    };
    let a = off + (lo + if swapped { -p } else { p });
    let a = if x < 0.0 { PI - a } else { a };
    a.copysign(y)
}

/// [`atan2`] when `x` and `y` are both zero, or one is infinite or NaN.
#[cold]
#[inline(never)]
fn atan2_special(y: f32, x: f32) -> f32 {
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

/// Arcsine; the argument is clamped to [-1, 1] first (NaN gives -pi/2).
///
/// For |x| <= 0.5 (the laws' arguments nearly always) the Cephes `asinf` polynomial, odd of
/// degree 11: no root, no division. Above, `atan2(|x|, sqrt(1 - x^2))` (`libm::asinf` would
/// take a square root in `f64`; Cephes' `pi/2 - 2 asin(sqrt((1 - |x|)/2))` loses 3e-7 to the
/// cancellation near 0.5). Relative error below 2e-7 (tested against `f64`).
#[inline]
pub fn asin(x: f32) -> f32 {
    // False for NaN: the clamp is needed only in `asin_big`.
    if x.abs() <= 0.5 {
        asin_poly(x)
    } else {
        asin_big(x)
    }
}

/// The odd `asin` polynomial for |x| <= 0.5, evaluated on `x` itself: round-to-nearest is
/// symmetric, so this is bit for bit the value on |x| with the sign of `x` put back (also
/// for -0), without the `copysign`.
#[inline(always)]
fn asin_poly(x: f32) -> f32 {
    let z = x * x;
    ((((4.216_32e-2 * z + 2.418_131e-2) * z + 4.547_002_6e-2) * z + 7.495_300_3e-2) * z
        + 1.666_675_2e-1)
        * z
        * x
        + x
}

/// [`asin`] for |x| > 0.5 or NaN.
#[inline(never)]
fn asin_big(x: f32) -> f32 {
    let x = clamp(x, -1.0, 1.0);
    let a = x.abs();
    atan2(a, sqrt((1.0 - a) * (1.0 + a))).copysign(x)
}

/// Hyperbolic tangent (Cephes `tanhf`), pure `f32`.
///
/// `libm::tanhf` goes through `expm1f` (about 130 instructions a call on the M4F). Here: an
/// odd polynomial for |x| <= 0.625, else `1 - 2 / (e^{2|x|} + 1)` with an own `exp`, and
/// +-1 from |x| >= 10 (where `tanh` rounds to 1). Relative error below 3e-7 (tested against
/// `f64`). NaN gives NaN.
#[inline]
pub fn tanh(x: f32) -> f32 {
    let a = x.abs();
    if a <= 0.625 {
        let z = x * x;
        ((((-5.704_988_7e-3 * z + 2.063_909e-2) * z - 5.373_971_6e-2) * z + 1.333_144_2e-1) * z
            - 3.333_328e-1)
            * z
            * x
            + x
    } else if a < 10.0 {
        let e = exp_mid(a + a);
        (1.0 - 2.0 / (e + 1.0)).copysign(x)
    } else if a >= 10.0 {
        1.0f32.copysign(x)
    } else {
        // NaN.
        x
    }
}

/// `e^x` for 0 <= x <= 20 (Cephes `expf`): `x = n ln2 + r`, |r| <= ln2/2, a degree-7
/// polynomial for `e^r`, and `2^n` put into the exponent bits (`n <= 29`, no overflow).
#[inline(always)]
fn exp_mid(x: f32) -> f32 {
    // x >= 0: `as` truncation is the floor.
    let n = (core::f32::consts::LOG2_E * x + 0.5) as i32;
    let nf = n as f32;
    // ln2 in two parts; `nf * 0.693_359_4` is exact for n < 2^11.
    let r = (x - nf * 0.693_359_4) + nf * 2.121_944_4e-4;
    let z = r * r;
    let p = (((((1.987_569_2e-4 * r + 1.398_199_9e-3) * r + 8.333_452e-3) * r + 4.166_579_6e-2)
        * r
        + 1.666_666_5e-1)
        * r
        + 5.0e-1)
        * z
        + r
        + 1.0;
    p * f32::from_bits((n.wrapping_add(127) as u32) << 23)
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
    fn asin_poly_on_x_matches_copysign_form() {
        // The polynomial on |x| with the sign put back (the form `asin_poly` replaced).
        let old = |x: f32| {
            let a = x.abs();
            let z = a * a;
            let r = ((((4.216_32e-2 * z + 2.418_131e-2) * z + 4.547_002_6e-2) * z
                + 7.495_300_3e-2)
                * z
                + 1.666_675_2e-1)
                * z
                * a
                + a;
            r.copysign(x)
        };
        let mut xs: Vec<f32> = (-300_000..=300_000).map(|i| i as f32 * 4e-6).collect();
        xs.extend([
            0.0, -0.0, 0.5, -0.5, 1e-30, -1e-30, 1e-45, -1e-45, 0.75, -0.99, 1.0, -1.0, 2.0, -7.0,
        ]);
        for x in xs {
            if x.abs() <= 0.5 {
                assert_eq!(asin(x).to_bits(), old(x).to_bits(), "{x}");
            }
        }
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

    fn rel(a: f32, e: f64) -> f64 {
        if e == 0.0 {
            (a as f64).abs()
        } else {
            ((a as f64) - e).abs() / e.abs()
        }
    }

    #[test]
    fn atan2_accuracy_and_special_values() {
        let mut worst = 0.0f64;
        // All directions densely, at several magnitudes.
        let n = 1_000_000;
        for i in 0..n {
            let t = -3.2 + 6.4 * (i as f64) / (n as f64);
            for m in [1.0e-30f64, 1.0e-3, 1.0, 7.5e4, 1.0e30] {
                let (y, x) = ((m * t.sin()) as f32, (m * t.cos()) as f32);
                let e = (y as f64).atan2(x as f64);
                worst = worst.max(rel(atan2(y, x), e));
            }
        }
        // Ratios y/x spread over many binades, all four quadrants.
        let mut bits = 0x0080_0000u32;
        while bits < 0x7f00_0000 {
            let r = f32::from_bits(bits);
            for (y, x) in [(r, 1.0f32), (1.0, r), (-r, 1.0), (r, -1.0), (-1.0, -r)] {
                let e = (y as f64).atan2(x as f64);
                worst = worst.max(rel(atan2(y, x), e));
            }
            bits += 4093;
        }
        assert!(worst <= 2.0e-7, "worst rel error {worst:e}");
        // Special values as libm.
        let sp = [
            0.0f32,
            -0.0,
            1.0,
            -1.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        for y in sp {
            for x in sp {
                let (a, b) = (atan2(y, x), libm::atan2f(y, x));
                assert!(
                    a.to_bits() == b.to_bits() || (a - b).abs() <= 1e-7,
                    "{y} {x}: {a} {b}"
                );
            }
        }
    }

    #[test]
    fn tanh_accuracy() {
        let mut worst = 0.0f64;
        for i in -2_000_000..=2_000_000 {
            let x = i as f32 * 1.0e-5; // [-20, 20]
            worst = worst.max(rel(tanh(x), (x as f64).tanh()));
        }
        for x in [
            1.0e-30f32,
            1.0e-8,
            1.0e-3,
            0.625,
            9.99,
            10.0,
            1.0e3,
            f32::MAX,
        ] {
            worst = worst.max(rel(tanh(x), (x as f64).tanh()));
            worst = worst.max(rel(tanh(-x), (-x as f64).tanh()));
        }
        assert!(worst <= 3.0e-7, "worst rel error {worst:e}");
        assert_eq!(tanh(f32::INFINITY), 1.0);
        assert_eq!(tanh(f32::NEG_INFINITY), -1.0);
        assert_eq!(tanh(-0.0), 0.0);
        assert!(tanh(f32::NAN).is_nan());
    }

    #[test]
    fn asin_accuracy() {
        let (mut worst_abs, mut worst_rel) = (0.0f64, 0.0f64);
        for i in -2_000_000..=2_000_000 {
            let x = i as f32 * 5.0e-7; // [-1, 1]
            let e = (x as f64).asin();
            worst_abs = worst_abs.max(((asin(x) as f64) - e).abs());
            worst_rel = worst_rel.max(rel(asin(x), e));
        }
        assert!(worst_abs <= 2.0e-7, "worst abs error {worst_abs:e}");
        assert!(worst_rel <= 2.0e-7, "worst rel error {worst_rel:e}");
        assert_eq!(asin(1.0), FRAC_PI_2);
        assert_eq!(asin(-1.0), -FRAC_PI_2);
        assert_eq!(asin(-0.0).to_bits(), (-0.0f32).to_bits());
    }

    #[test]
    fn asin_matches_f64() {
        for i in -1000..=1000 {
            let x = i as f32 / 1000.0;
            assert!((asin(x) as f64 - (x as f64).asin()).abs() < 1e-6);
        }
        assert!((asin(2.0) - core::f32::consts::FRAC_PI_2).abs() < 1e-6);
        assert_eq!(asin(f32::NAN), -core::f32::consts::FRAC_PI_2);
    }
}
