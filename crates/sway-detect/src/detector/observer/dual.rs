//! Forward-mode dual numbers with `N` derivative directions: the exact Jacobians of the
//! observer's model with respect to the estimated trailer parameters (and the speed), with
//! no finite differences and no allocation (the derivatives are a fixed array).

use std::ops::{Add, Div, Mul, Neg, Sub};

/// The arithmetic the observer's model is written in: `f64` for values, [`Dual`] for values
/// with their derivatives.
pub trait Scalar:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + From<f64>
{
    /// The value without its derivatives (what a branch of a piecewise law is chosen by).
    fn value(self) -> f64;

    /// |x|, with the derivative's sign of x (at x = 0 that of +x: the laws written with it
    /// here are C¹ there, so either side gives the same derivative).
    #[inline]
    fn abs(self) -> Self {
        if self.value() < 0.0 { -self } else { self }
    }
}

impl Scalar for f64 {
    #[inline]
    fn value(self) -> f64 {
        self
    }
}

/// A value and its derivatives in `N` directions: x + Σ ε_i x_i with ε_i ε_j = 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dual<const N: usize> {
    /// the value
    pub re: f64,
    /// the derivatives ∂x/∂z_i
    pub eps: [f64; N],
}

impl<const N: usize> Dual<N> {
    /// The independent variable `i` at `value` (derivative 1 in direction `i`).
    pub fn variable(value: f64, i: usize) -> Self {
        let mut eps = [0.0; N];
        eps[i] = 1.0;
        Dual { re: value, eps }
    }
}

impl<const N: usize> From<f64> for Dual<N> {
    #[inline]
    fn from(re: f64) -> Self {
        Dual { re, eps: [0.0; N] }
    }
}

impl<const N: usize> Scalar for Dual<N> {
    #[inline]
    fn value(self) -> f64 {
        self.re
    }
}

impl<const N: usize> Add for Dual<N> {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        Dual {
            re: self.re + o.re,
            eps: std::array::from_fn(|i| self.eps[i] + o.eps[i]),
        }
    }
}

impl<const N: usize> Sub for Dual<N> {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        Dual {
            re: self.re - o.re,
            eps: std::array::from_fn(|i| self.eps[i] - o.eps[i]),
        }
    }
}

impl<const N: usize> Mul for Dual<N> {
    type Output = Self;
    // the product rule: (x + εx')(y + εy') = xy + ε(x'y + xy')
    #[allow(clippy::suspicious_arithmetic_impl)]
    #[inline]
    fn mul(self, o: Self) -> Self {
        Dual {
            re: self.re * o.re,
            eps: std::array::from_fn(|i| self.eps[i] * o.re + self.re * o.eps[i]),
        }
    }
}

impl<const N: usize> Div for Dual<N> {
    type Output = Self;
    // the quotient rule: (x' − (x/y) y')/y
    #[allow(clippy::suspicious_arithmetic_impl)]
    #[inline]
    fn div(self, o: Self) -> Self {
        let inv = 1.0 / o.re;
        let re = self.re * inv;
        Dual {
            re,
            eps: std::array::from_fn(|i| (self.eps[i] - re * o.eps[i]) * inv),
        }
    }
}

impl<const N: usize> Neg for Dual<N> {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        Dual {
            re: -self.re,
            eps: self.eps.map(|e| -e),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{Dual, Scalar};

    /// f(x, y) = (x y − 3) / (x + y²) and its gradient by hand.
    fn f<S: Scalar>(x: S, y: S) -> S {
        (x * y - S::from(3.0)) / (x + y * y)
    }

    #[test]
    fn derivatives_match_the_hand_computed_gradient() {
        // reference: ∂f/∂x = (y(x + y²) − (xy − 3))/(x + y²)², ∂f/∂y = (x(x + y²) − 2y(xy − 3))/(x + y²)²
        let (x, y) = (1.5, -0.7);
        let d = f(Dual::<2>::variable(x, 0), Dual::<2>::variable(y, 1));
        let den = x + y * y;
        let dx = (y * den - (x * y - 3.0)) / (den * den);
        let dy = (x * den - 2.0 * y * (x * y - 3.0)) / (den * den);
        assert!((d.re - f(x, y)).abs() < 1e-15);
        assert!((d.eps[0] - dx).abs() < 1e-14 && (d.eps[1] - dy).abs() < 1e-14);
        assert_eq!((-d).re, -d.re);
    }
}
