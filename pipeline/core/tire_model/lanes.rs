//! A fixed-width pack of `f64` lanes ([`V`]) and polynomial `atan`, `sin`, `cos`, `tan` on it,
//! for the structure-of-arrays batch evaluator (`batch.rs`).
//!
//! In: `f64` values, [`LANES`] at a time. Out: lane-wise arithmetic, comparisons, selects and
//! elementary functions written as straight-line code that the compiler turns into SIMD
//! instructions (no intrinsics, no `unsafe`). Every operation is a plain IEEE multiply, add,
//! divide or square root (never a fused multiply-add), so results are the same bits on every
//! x86-64 level and every lane count.
//!
//! Accuracy (see the tests): `atan` within 1 ulp of the standard library's (the polynomial's own
//! error is 1.6e-18 relative); `sin`, `cos` within 1 ulp for
//! `|x| <= 100` and 2 ulp up to `1e5` (three-part Cody-Waite reduction by pi/2), `tan` within
//! 2 ulp more than those. Arguments beyond
//! `1e5` in magnitude, infinities and NaN are handed to the standard library lane by lane.
//! Coefficients: least-squares fits on Chebyshev nodes in 50-digit arithmetic (mpmath),
//! relative error of the polynomial on its interval: atan 1.6e-18, sin 4.1e-18, cos 6.5e-19.
//!
//! Deliberately not here: `exp` (one call per point; the standard library's is used lane by
//! lane) and anything the tire model does not call.

// Index loops over the fixed lane count are the form the auto-vectoriser handles best (and
// what the kernel's speed was measured with); iterator rewrites are not worth the risk here.
#![allow(clippy::needless_range_loop)]

use std::f64::consts::{FRAC_2_PI, FRAC_PI_2, FRAC_PI_4};
use std::ops::{Add, Div, Mul, Neg, Sub};

/// Number of points evaluated together.
pub const LANES: usize = 32;

/// `LANES` values, one per point.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct V(pub [f64; LANES]);

/// A lane mask (result of a comparison).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct M(pub [bool; LANES]);

macro_rules! lane_binop {
    ($tr:ident, $f:ident, $op:tt) => {
        impl $tr for V {
            type Output = V;
            #[inline(always)]
            fn $f(self, o: V) -> V {
                let mut r = [0.0; LANES];
                for i in 0..LANES {
                    r[i] = self.0[i] $op o.0[i];
                }
                V(r)
            }
        }
        impl $tr<f64> for V {
            type Output = V;
            #[inline(always)]
            fn $f(self, o: f64) -> V {
                let mut r = [0.0; LANES];
                for i in 0..LANES {
                    r[i] = self.0[i] $op o;
                }
                V(r)
            }
        }
        impl $tr<V> for f64 {
            type Output = V;
            #[inline(always)]
            fn $f(self, o: V) -> V {
                let mut r = [0.0; LANES];
                for i in 0..LANES {
                    r[i] = self $op o.0[i];
                }
                V(r)
            }
        }
    };
}

lane_binop!(Add, add, +);
lane_binop!(Sub, sub, -);
lane_binop!(Mul, mul, *);
lane_binop!(Div, div, /);

impl Neg for V {
    type Output = V;
    #[inline(always)]
    fn neg(self) -> V {
        self.map(|x| -x)
    }
}

impl V {
    /// Every lane `x`.
    #[inline(always)]
    pub fn splat(x: f64) -> V {
        V([x; LANES])
    }

    /// Lane-wise `f`.
    #[inline(always)]
    pub fn map(self, f: impl Fn(f64) -> f64) -> V {
        let mut r = [0.0; LANES];
        for i in 0..LANES {
            r[i] = f(self.0[i]);
        }
        V(r)
    }

    /// `x * x`.
    #[inline(always)]
    pub fn sq(self) -> V {
        self * self
    }

    /// Absolute value.
    #[inline(always)]
    pub fn abs(self) -> V {
        self.map(f64::abs)
    }

    /// Square root.
    #[inline(always)]
    pub fn sqrt(self) -> V {
        self.map(f64::sqrt)
    }

    /// Lane-wise `f64::min`.
    #[inline(always)]
    pub fn min(self, limit: f64) -> V {
        self.map(|x| x.min(limit))
    }

    /// Lane-wise `f64::max`.
    #[inline(always)]
    pub fn max(self, limit: f64) -> V {
        self.map(|x| x.max(limit))
    }

    /// Lane-wise `f64::clamp` (NaN stays NaN), without its `lo <= hi` assertion in the loop.
    #[inline(always)]
    pub fn clamp(self, lo: f64, hi: f64) -> V {
        self.map(|x| {
            let x = if x < lo { lo } else { x };
            if x > hi { hi } else { x }
        })
    }

    /// `E <= 1` clamp when `on`, exactly as the scalar evaluator's `min_cst(1.0)`.
    #[inline(always)]
    pub fn clamp_e(self, on: bool) -> V {
        if on {
            self.map(|x| if x > 1.0 { 1.0 } else { x })
        } else {
            self
        }
    }

    /// Sign with `sgn(0) = 0`.
    #[inline(always)]
    pub fn sgn(self) -> V {
        self.map(super::pac2002::sgn)
    }

    /// Sign with `sgn(0) = +1`.
    #[inline(always)]
    pub fn sgn_pos(self) -> V {
        self.map(super::pac2002::sgn_pos)
    }

    /// Lanes equal to `x`.
    #[inline(always)]
    pub fn eq(self, x: f64) -> M {
        self.cmp(|a| a == x)
    }

    /// Lanes below `x`.
    #[inline(always)]
    pub fn lt(self, x: f64) -> M {
        self.cmp(|a| a < x)
    }

    /// Lanes above `x`.
    #[inline(always)]
    pub fn gt(self, x: f64) -> M {
        self.cmp(|a| a > x)
    }

    #[inline(always)]
    fn cmp(self, f: impl Fn(f64) -> bool) -> M {
        let mut r = [false; LANES];
        for i in 0..LANES {
            r[i] = f(self.0[i]);
        }
        M(r)
    }

    /// `cos(atan(x)) = 1 / sqrt(1 + x^2)` (the scalar evaluator's identity, same operations).
    #[inline(always)]
    pub fn cos_atan(self) -> V {
        1.0 / (self.sq() + 1.0).sqrt()
    }

    /// `sin(2 atan(x)) = 2x / (1 + x^2)` (same operations as the scalar evaluator).
    #[inline(always)]
    pub fn sin_2atan(self) -> V {
        self * 2.0 / (self.sq() + 1.0)
    }
}

impl M {
    /// `a` where the mask is set, else `b`.
    #[inline(always)]
    pub fn select(self, a: V, b: V) -> V {
        let mut r = [0.0; LANES];
        for i in 0..LANES {
            r[i] = if self.0[i] { a.0[i] } else { b.0[i] };
        }
        V(r)
    }

    /// Any lane set?
    #[inline(always)]
    pub fn any(self) -> bool {
        self.0.iter().any(|&b| b)
    }
}

/// Horner evaluation `c[0] + s (c[1] + s (c[2] + ...))`. (Estrin's scheme was tried: slower
/// here, the lane count already hides the latency.)
#[inline(always)]
fn horner(s: V, c: &[f64]) -> V {
    let mut r = V::splat(c[c.len() - 1]);
    for &k in c[..c.len() - 1].iter().rev() {
        r = r * s + k;
    }
    r
}

/// `(atan(u) - u) / u^3` as a polynomial in `u^2`, `|u| <= tan(pi/8)`.
const ATAN_P: [f64; 11] = [
    -0.33333333333333187,
    0.1999999999995094,
    -0.1428571427995913,
    0.11111110772667618,
    -0.09090897471908112,
    0.07692055490588258,
    -0.06663053814161533,
    0.058475455697872096,
    -0.050378420221120136,
    0.038029343584793096,
    -0.017870555997701647,
];
const TAN_PI_8: f64 = 0.41421356237309503;
const TAN_3PI_8: f64 = 2.414213562373095;
const PI_4_HI: f64 = FRAC_PI_4;
const PI_4_LO: f64 = 3.061616997868383e-17;
const PI_2_HI: f64 = FRAC_PI_2;
const PI_2_LO: f64 = 6.123233995736766e-17;

/// Arc tangent. Reduction to `|u| <= tan(pi/8)` with one division, then an odd polynomial.
#[inline(always)]
pub fn atan(x: V) -> V {
    let a = x.abs();
    let big = a.gt(TAN_3PI_8);
    let mid = a.gt(TAN_PI_8);
    let num = big.select(V::splat(-1.0), mid.select(a - 1.0, a));
    let den = big.select(a, mid.select(a + 1.0, V::splat(1.0)));
    let hi = big.select(
        V::splat(PI_2_HI),
        mid.select(V::splat(PI_4_HI), V::splat(0.0)),
    );
    let lo = big.select(
        V::splat(PI_2_LO),
        mid.select(V::splat(PI_4_LO), V::splat(0.0)),
    );
    let u = num / den;
    let s = u * u;
    let r = hi + (lo + (u + u * s * horner(s, &ATAN_P)));
    let mut out = [0.0; LANES];
    for i in 0..LANES {
        out[i] = r.0[i].copysign(x.0[i]);
    }
    V(out)
}

/// `(sin(z) - z) / z^3` as a polynomial in `z^2`, `|z| <= pi/4`.
const SIN_P: [f64; 6] = [
    -0.1666666666666663,
    0.008333333333321907,
    -0.00019841269829452244,
    2.755731358095979e-06,
    -2.505074222357712e-08,
    1.5895943103357368e-10,
];
/// `(cos(z) - 1 + z^2/2) / z^4` as a polynomial in `z^2`, `|z| <= pi/4`.
const COS_P: [f64; 6] = [
    0.04166666666666659,
    -0.0013888888888872505,
    2.480158728855358e-05,
    -2.755731410296429e-07,
    2.0875691483269687e-09,
    -1.1358093609276402e-11,
];
const TWO_OVER_PI: f64 = FRAC_2_PI;
/// `pi/2` in three parts; the first two have 33 significant bits so `k * part` is exact for
/// `|k| < 2^20`.
const PIO2_1: f64 = 1.5707963267341256;
const PIO2_2: f64 = 6.077100506303966e-11;
const PIO2_3: f64 = 2.0222662487959506e-21;
/// Largest argument reduced here; beyond it (or for NaN, infinities) the standard library is used.
const REDUCE_MAX: f64 = 1e5;

/// `1.5 * 2^52`: adding it rounds a double of magnitude below `2^51` to an integer, whose low
/// bits then sit in the low bits of the sum's mantissa.
const ROUND_MAGIC: f64 = 6755399441055744.0;

/// `x = k pi/2 + r`, `|r| <= pi/4`: returns `(sin r, cos r, odd k, k mod 4 >= 2)`.
#[inline(always)]
fn reduce_sin_cos(x: V) -> (V, V, M, M) {
    let t = x * TWO_OVER_PI + ROUND_MAGIC;
    let k = t - ROUND_MAGIC;
    let mut odd = [false; LANES];
    let mut neg = [false; LANES];
    for i in 0..LANES {
        let bits = t.0[i].to_bits();
        odd[i] = bits & 1 != 0;
        neg[i] = bits & 2 != 0;
    }
    let r = ((x - k * PIO2_1) - k * PIO2_2) - k * PIO2_3;
    let s = r * r;
    let sin_r = r + r * s * horner(s, &SIN_P);
    // fdlibm's compensation: `w = 1 - s/2` rounds; `(1 - w) - s/2` is that rounding error.
    let half_s = s * 0.5;
    let w = 1.0 - half_s;
    let cos_r = w + (((1.0 - w) - half_s) + s * s * horner(s, &COS_P));
    (sin_r, cos_r, M(odd), M(neg))
}

/// Lanes outside the reduced range (or NaN).
#[inline(always)]
fn needs_libm(x: V) -> bool {
    let mut out = false;
    for i in 0..LANES {
        out |= x.0[i].abs() > REDUCE_MAX || x.0[i].is_nan();
    }
    out
}

/// The standard library's `f`, lane by lane (rare: kept out of line).
#[cold]
#[inline(never)]
fn libm(x: V, f: fn(f64) -> f64) -> V {
    x.map(f)
}

/// Sine.
#[inline(always)]
pub fn sin(x: V) -> V {
    if needs_libm(x) {
        return libm(x, f64::sin);
    }
    let (s, c, odd, neg) = reduce_sin_cos(x);
    let v = odd.select(c, s);
    neg.select(-v, v)
}

/// Cosine.
#[inline(always)]
pub fn cos(x: V) -> V {
    if needs_libm(x) {
        return libm(x, f64::cos);
    }
    let (s, c, odd, neg) = reduce_sin_cos(x);
    // cos(k pi/2 + r) = c, -s, -c, s for k mod 4 = 0, 1, 2, 3.
    let v = odd.select(s, c);
    let flip = M(std::array::from_fn(|i| odd.0[i] != neg.0[i]));
    flip.select(-v, v)
}

/// Tangent (`sin r / cos r`, or `-cos r / sin r` for odd `k`).
#[inline(always)]
pub fn tan(x: V) -> V {
    if needs_libm(x) {
        return libm(x, f64::tan);
    }
    let (s, c, odd, _) = reduce_sin_cos(x);
    odd.select(-c, s) / odd.select(s, c)
}

/// Exponential (the standard library's, lane by lane).
#[inline(always)]
pub fn exp(x: V) -> V {
    x.map(f64::exp)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::random::SplitMix64;

    /// `|a - b|` in units in the last place of the reference `b` (normal range).
    fn ulps(a: f64, b: f64) -> f64 {
        if a == b {
            return 0.0;
        }
        let exponent = ((b.abs().max(f64::MIN_POSITIVE).to_bits() >> 52) as i32) - 1023;
        (a - b).abs() / 2f64.powi(exponent - 52)
    }

    /// Worst error (ulp) of `fast` vs `reference` over `n` random arguments in `[lo, hi]` plus
    /// the given special arguments.
    fn worst(
        fast: fn(V) -> V,
        reference: fn(f64) -> f64,
        lo: f64,
        hi: f64,
        specials: &[f64],
    ) -> f64 {
        let mut rng = SplitMix64::new(99);
        let mut args: Vec<f64> = (0..400_000).map(|_| rng.uniform_in(lo, hi)).collect();
        args.extend_from_slice(specials);
        while !args.len().is_multiple_of(LANES) {
            args.push(0.5);
        }
        let mut w: f64 = 0.0;
        for chunk in args.chunks_exact(LANES) {
            let x = V(chunk.try_into().unwrap());
            let y = fast(x);
            for i in 0..LANES {
                let r = reference(x.0[i]);
                assert!(
                    y.0[i].is_nan() == r.is_nan(),
                    "NaN mismatch at {}: {} vs {r}",
                    x.0[i],
                    y.0[i]
                );
                if r.is_finite() {
                    w = w.max(ulps(y.0[i], r));
                } else if !r.is_nan() {
                    assert_eq!(y.0[i], r);
                }
            }
        }
        w
    }

    const SPECIALS: [f64; 14] = [
        0.0,
        -0.0,
        1e-300,
        -1e-20,
        TAN_PI_8,
        TAN_3PI_8,
        1.0,
        -1.0,
        1e20,
        -1e300,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
        std::f64::consts::FRAC_PI_4,
    ];

    #[test]
    fn atan_within_one_ulp() {
        for (lo, hi) in [(-1.0, 1.0), (-3.0, 3.0), (-1e3, 1e3), (-1e12, 1e12)] {
            let w = worst(atan, f64::atan, lo, hi, &SPECIALS);
            assert!(w <= 1.0, "atan on [{lo}, {hi}]: {w} ulp");
        }
    }

    #[test]
    fn sin_cos_within_one_ulp_tan_within_three() {
        // Up to |x| = 100 the reduction adds nothing measurable; towards 1e5 it adds one ulp.
        for (lo, hi, bound) in [
            (-0.8, 0.8, 1.0),
            (-4.0, 4.0, 1.0),
            (-100.0, 100.0, 1.0),
            (-1e5, 1e5, 2.0),
            (-1e9, 1e9, 2.0),
        ] {
            let ws = worst(sin, f64::sin, lo, hi, &SPECIALS);
            let wc = worst(cos, f64::cos, lo, hi, &SPECIALS);
            let wt = worst(tan, f64::tan, lo, hi, &SPECIALS);
            assert!(
                ws <= bound && wc <= bound && wt <= bound + 2.0,
                "[{lo}, {hi}]: sin {ws} cos {wc} tan {wt} ulp"
            );
        }
    }
}
