//! Scalars the model runs on: plain `f64` for evaluation and forward-mode dual numbers
//! ([`Dual`]) for exact derivatives with respect to chosen coefficients.
//!
//! In: nothing. Out: the [`Real`] trait (the arithmetic and elementary functions the PAC2002
//! equations use) and its two implementations. Branches in the model (sign functions, the
//! `E <= 1` clamp, input limits) are taken on [`Real::value`], so a dual number follows exactly
//! the code path its value follows and its derivative is that of the active branch.

use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub};

/// The scalar operations the tire model needs.
pub trait Real:
    Copy
    + std::fmt::Debug
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Add<f64, Output = Self>
    + Sub<f64, Output = Self>
    + Mul<f64, Output = Self>
    + Div<f64, Output = Self>
    + AddAssign
    + MulAssign
{
    /// A constant (zero derivative).
    fn cst(v: f64) -> Self;
    /// The value part.
    fn value(self) -> f64;
    /// Sine.
    fn sin(self) -> Self;
    /// Cosine.
    fn cos(self) -> Self;
    /// Tangent.
    fn tan(self) -> Self;
    /// Arc tangent.
    fn atan(self) -> Self;
    /// Exponential.
    fn exp(self) -> Self;
    /// Square root (derivative undefined at 0; callers keep the argument positive).
    fn sqrt(self) -> Self;
    /// `self` to the power `y` (`pow`; callers keep `self >= 0`, and the derivative with
    /// respect to `y` is taken as 0 at `self == 0`).
    fn powf(self, y: Self) -> Self;

    /// Absolute value (derivative `sgn(x)`, 0 at 0 taken as +).
    #[inline]
    fn abs(self) -> Self {
        if self.value() < 0.0 { -self } else { self }
    }

    /// `x * x`.
    #[inline]
    fn sq(self) -> Self {
        self * self
    }

    /// `min(self, limit)` on the value, used for the `E <= 1` clamp.
    #[inline]
    fn min_cst(self, limit: f64) -> Self {
        if self.value() > limit {
            Self::cst(limit)
        } else {
            self
        }
    }

    /// `cos(atan(x)) = 1 / sqrt(1 + x^2)`, exact identity, one square root instead of two
    /// transcendental calls.
    #[inline]
    fn cos_atan(self) -> Self {
        Self::cst(1.0) / (self.sq() + 1.0).sqrt()
    }

    /// `sin(2 atan(x)) = 2x / (1 + x^2)`, exact identity.
    #[inline]
    fn sin_2atan(self) -> Self {
        self * 2.0 / (self.sq() + 1.0)
    }
}

impl Real for f64 {
    #[inline]
    fn cst(v: f64) -> Self {
        v
    }
    #[inline]
    fn value(self) -> f64 {
        self
    }
    #[inline]
    fn sin(self) -> Self {
        f64::sin(self)
    }
    #[inline]
    fn cos(self) -> Self {
        f64::cos(self)
    }
    #[inline]
    fn tan(self) -> Self {
        f64::tan(self)
    }
    #[inline]
    fn atan(self) -> Self {
        f64::atan(self)
    }
    #[inline]
    fn exp(self) -> Self {
        f64::exp(self)
    }
    #[inline]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline]
    fn powf(self, y: Self) -> Self {
        f64::powf(self, y)
    }
}

/// A forward-mode dual number with `N` partial derivatives: `v + sum d[i] e_i`.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Dual<const N: usize> {
    /// Value.
    pub v: f64,
    /// Partial derivatives with respect to the `N` seeded variables.
    pub d: [f64; N],
}

impl<const N: usize> Dual<N> {
    /// The `i`-th independent variable with value `v` (derivative 1 along `i`).
    pub fn var(v: f64, i: usize) -> Self {
        let mut d = [0.0; N];
        d[i] = 1.0;
        Dual { v, d }
    }

    /// Apply a scalar function with value `fv` and derivative `dfdx` at `self.v` (chain rule).
    #[inline]
    fn chain(self, fv: f64, dfdx: f64) -> Self {
        let mut d = self.d;
        d.iter_mut().for_each(|x| *x *= dfdx);
        Dual { v: fv, d }
    }
}

impl<const N: usize> Add for Dual<N> {
    type Output = Self;
    #[inline]
    fn add(mut self, o: Self) -> Self {
        self.v += o.v;
        for (a, b) in self.d.iter_mut().zip(o.d) {
            *a += b;
        }
        self
    }
}

impl<const N: usize> Sub for Dual<N> {
    type Output = Self;
    #[inline]
    fn sub(mut self, o: Self) -> Self {
        self.v -= o.v;
        for (a, b) in self.d.iter_mut().zip(o.d) {
            *a -= b;
        }
        self
    }
}

impl<const N: usize> Mul for Dual<N> {
    type Output = Self;
    #[inline]
    fn mul(self, o: Self) -> Self {
        let mut d = [0.0; N];
        for ((r, a), b) in d.iter_mut().zip(self.d).zip(o.d) {
            *r = a * o.v + b * self.v;
        }
        Dual { v: self.v * o.v, d }
    }
}

impl<const N: usize> Div for Dual<N> {
    type Output = Self;
    #[inline]
    fn div(self, o: Self) -> Self {
        let inv = 1.0 / o.v;
        let q = self.v * inv;
        let mut d = [0.0; N];
        for ((r, a), b) in d.iter_mut().zip(self.d).zip(o.d) {
            *r = (a - q * b) * inv;
        }
        Dual { v: q, d }
    }
}

impl<const N: usize> Neg for Dual<N> {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        self.chain(-self.v, -1.0)
    }
}

impl<const N: usize> Add<f64> for Dual<N> {
    type Output = Self;
    #[inline]
    fn add(mut self, o: f64) -> Self {
        self.v += o;
        self
    }
}

impl<const N: usize> Sub<f64> for Dual<N> {
    type Output = Self;
    #[inline]
    fn sub(mut self, o: f64) -> Self {
        self.v -= o;
        self
    }
}

impl<const N: usize> Mul<f64> for Dual<N> {
    type Output = Self;
    #[inline]
    fn mul(self, o: f64) -> Self {
        self.chain(self.v * o, o)
    }
}

impl<const N: usize> Div<f64> for Dual<N> {
    type Output = Self;
    #[inline]
    fn div(self, o: f64) -> Self {
        self.chain(self.v / o, 1.0 / o)
    }
}

impl<const N: usize> AddAssign for Dual<N> {
    #[inline]
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}

impl<const N: usize> MulAssign for Dual<N> {
    #[inline]
    fn mul_assign(&mut self, o: Self) {
        *self = *self * o;
    }
}

impl<const N: usize> Real for Dual<N> {
    #[inline]
    fn cst(v: f64) -> Self {
        Dual { v, d: [0.0; N] }
    }
    #[inline]
    fn value(self) -> f64 {
        self.v
    }
    #[inline]
    fn sin(self) -> Self {
        let (s, c) = self.v.sin_cos();
        self.chain(s, c)
    }
    #[inline]
    fn cos(self) -> Self {
        let (s, c) = self.v.sin_cos();
        self.chain(c, -s)
    }
    #[inline]
    fn tan(self) -> Self {
        let t = self.v.tan();
        self.chain(t, 1.0 + t * t)
    }
    #[inline]
    fn atan(self) -> Self {
        self.chain(self.v.atan(), 1.0 / (1.0 + self.v * self.v))
    }
    #[inline]
    fn exp(self) -> Self {
        let e = self.v.exp();
        self.chain(e, e)
    }
    #[inline]
    fn sqrt(self) -> Self {
        let r = self.v.sqrt();
        self.chain(r, 0.5 / r)
    }
    #[inline]
    fn powf(self, y: Self) -> Self {
        let v = self.v.powf(y.v);
        // d(x^y) = y x^(y-1) dx + x^y ln(x) dy
        let dx = if self.v == 0.0 { 0.0 } else { y.v * v / self.v };
        let dy = if self.v > 0.0 { v * self.v.ln() } else { 0.0 };
        let mut d = [0.0; N];
        for ((r, a), b) in d.iter_mut().zip(self.d).zip(y.d) {
            *r = a * dx + b * dy;
        }
        Dual { v, d }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f<T: Real>(x: T, y: T) -> T {
        (x * y).sin() + (x / y).atan() * x.exp() - (y.sq() + 1.0).sqrt() * x.tan()
            + x.cos_atan()
            + y.powf(x)
    }

    #[test]
    fn dual_matches_central_differences() {
        let (x, y) = (0.3, 1.7);
        let r = f(Dual::<2>::var(x, 0), Dual::<2>::var(y, 1));
        let h = 1e-6;
        let dx = (f(x + h, y) - f(x - h, y)) / (2.0 * h);
        let dy = (f(x, y + h) - f(x, y - h)) / (2.0 * h);
        assert!((r.v - f(x, y)).abs() < 1e-15);
        assert!((r.d[0] - dx).abs() < 1e-8, "{} vs {dx}", r.d[0]);
        assert!((r.d[1] - dy).abs() < 1e-8, "{} vs {dy}", r.d[1]);
    }

    #[test]
    fn identities_hold() {
        for x in [-3.0, -0.2, 0.0, 0.7, 40.0] {
            assert!((x.cos_atan() - x.atan().cos()).abs() < 1e-15);
            assert!((x.sin_2atan() - (2.0 * x.atan()).sin()).abs() < 1e-15);
        }
    }
}
