//! Arithmetic on one number or on `W` numbers at once, for integrating several independent
//! plants in one instruction stream.
//!
//! The 6-DOF derivative is a long chain of dependent operations: one plant's RK4 step
//! mostly waits on its own results. [`Lanes`] holds the same quantity of `W` plants; every
//! operation is the IEEE operation of `f64` on each lane (add, subtract, multiply, divide,
//! negate, absolute value, square root), with no reassociation and no fused multiply-add, so lane `i`
//! of a lane computation is the bits of the scalar computation of plant `i`. The compiler
//! turns the element-wise loops into packed instructions, and the `W` chains fill each
//! other's waits.

use core::ops::{Add, Div, Mul, Neg, Sub};

/// A number type the plant's derivative is written over: `f64`, or [`Lanes`] of them.
pub trait Lane:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// The constant `x` in every lane.
    fn splat(x: f64) -> Self;
    /// `|x|` in every lane.
    fn abs(self) -> Self;
    /// The square root in every lane (IEEE, correctly rounded).
    fn sqrt(self) -> Self;
}

impl Lane for f64 {
    #[inline(always)]
    fn splat(x: f64) -> Self {
        x
    }

    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }

    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
}

/// The same quantity of `W` plants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lanes<const W: usize>(pub [f64; W]);

impl<const W: usize> Lanes<W> {
    #[inline(always)]
    fn zip_with(self, rhs: Self, f: impl Fn(f64, f64) -> f64) -> Self {
        let mut o = self.0;
        for (a, b) in o.iter_mut().zip(rhs.0) {
            *a = f(*a, b);
        }
        Lanes(o)
    }

    #[inline(always)]
    fn map(self, f: impl Fn(f64) -> f64) -> Self {
        Lanes(self.0.map(f))
    }
}

impl<const W: usize> Add for Lanes<W> {
    type Output = Self;
    #[inline(always)]
    fn add(self, rhs: Self) -> Self {
        self.zip_with(rhs, |a, b| a + b)
    }
}

impl<const W: usize> Sub for Lanes<W> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, rhs: Self) -> Self {
        self.zip_with(rhs, |a, b| a - b)
    }
}

impl<const W: usize> Mul for Lanes<W> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, rhs: Self) -> Self {
        self.zip_with(rhs, |a, b| a * b)
    }
}

impl<const W: usize> Div for Lanes<W> {
    type Output = Self;
    #[inline(always)]
    fn div(self, rhs: Self) -> Self {
        self.zip_with(rhs, |a, b| a / b)
    }
}

impl<const W: usize> Neg for Lanes<W> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        self.map(|a| -a)
    }
}

impl<const W: usize> Lane for Lanes<W> {
    #[inline(always)]
    fn splat(x: f64) -> Self {
        Lanes([x; W])
    }

    #[inline(always)]
    fn abs(self) -> Self {
        self.map(f64::abs)
    }

    #[inline(always)]
    fn sqrt(self) -> Self {
        self.map(f64::sqrt)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_lane_is_the_scalar_operation_bit_for_bit() {
        let a = [0.1, -3.7e-12, 0.0, -0.0];
        let b = [3.0, 1.0e300, -0.0, 7.25];
        let (la, lb) = (Lanes(a), Lanes(b));
        type Scalar = fn(f64, f64) -> f64;
        let ops: [(Lanes<4>, Scalar); 7] = [
            (la + lb, |x, y| x + y),
            (la - lb, |x, y| x - y),
            (la * lb, |x, y| x * y),
            (la / lb, |x, y| x / y),
            (-la, |x, _| -x),
            (Lane::abs(lb), |_, y| y.abs()),
            (Lane::sqrt(lb), |_, y| y.sqrt()),
        ];
        for (got, scalar) in ops {
            for ((g, x), y) in got.0.iter().zip(a).zip(b) {
                assert_eq!(g.to_bits(), scalar(x, y).to_bits(), "{x} {y}");
            }
        }
    }
}
