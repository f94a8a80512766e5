//! Double-double ("dd") arithmetic: an unevaluated sum `hi + lo` of two `f64`
//! with `|lo| <= ulp(hi)/2`, giving about 106 bits of significand.
//!
//! Only the handful of operations the refinement and basis conversion need
//! are provided. All of them are error-free transformations built on
//! [`f64::mul_add`] (a correctly rounded fused multiply-add), so the results
//! do not depend on the platform having a hardware FMA.

use std::ops::{Add, Mul, Neg, Sub};

/// A double-double number `hi + lo`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Dd {
    pub hi: f64,
    pub lo: f64,
}

/// `a + b = s + e` exactly (Knuth's TwoSum).
#[inline]
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    let e = (a - (s - bb)) + (b - bb);
    (s, e)
}

/// `a + b = s + e` exactly, valid when `|a| >= |b|` or `a == 0`.
#[inline]
fn fast_two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let e = b - (s - a);
    (s, e)
}

/// `a * b = p + e` exactly (barring overflow/underflow).
#[inline]
fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    let e = a.mul_add(b, -p);
    (p, e)
}

impl Dd {
    pub const ZERO: Dd = Dd { hi: 0.0, lo: 0.0 };
    pub const ONE: Dd = Dd { hi: 1.0, lo: 0.0 };

    /// Exact conversion from `f64`.
    #[inline]
    pub const fn from_f64(x: f64) -> Dd {
        Dd { hi: x, lo: 0.0 }
    }

    /// Exact difference `a - b` of two doubles.
    #[inline]
    pub fn diff(a: f64, b: f64) -> Dd {
        let (hi, lo) = two_sum(a, -b);
        Dd { hi, lo }
    }

    /// Rounds to the nearest `f64` (up to a final rounding of `hi + lo`).
    #[inline]
    pub fn to_f64(self) -> f64 {
        self.hi + self.lo
    }

    /// `self / d` for a double divisor, accurate to a few dd ulps.
    #[inline]
    pub fn div_f64(self, d: f64) -> Dd {
        let q1 = self.hi / d;
        // Remainder self - q1*d, computed exactly for the hi part.
        let (p, pe) = two_prod(q1, d);
        let r = ((self.hi - p) - pe) + self.lo;
        let q2 = r / d;
        let (hi, lo) = fast_two_sum(q1, q2);
        Dd { hi, lo }
    }

    /// `self * b` for a double factor.
    #[inline]
    pub fn mul_f64(self, b: f64) -> Dd {
        let (p, e) = two_prod(self.hi, b);
        let e = self.lo.mul_add(b, e);
        let (hi, lo) = fast_two_sum(p, e);
        Dd { hi, lo }
    }

    /// `self + b` for a double summand.
    #[inline]
    pub fn add_f64(self, b: f64) -> Dd {
        let (s, e) = two_sum(self.hi, b);
        let (hi, lo) = fast_two_sum(s, e + self.lo);
        Dd { hi, lo }
    }
}

impl Add for Dd {
    type Output = Dd;
    /// Accurate ("IEEE-style") dd addition.
    #[inline]
    fn add(self, b: Dd) -> Dd {
        let (s, e) = two_sum(self.hi, b.hi);
        let (t, f) = two_sum(self.lo, b.lo);
        let (s, e) = fast_two_sum(s, e + t);
        let (hi, lo) = fast_two_sum(s, e + f);
        Dd { hi, lo }
    }
}

impl Neg for Dd {
    type Output = Dd;
    #[inline]
    fn neg(self) -> Dd {
        Dd {
            hi: -self.hi,
            lo: -self.lo,
        }
    }
}

impl Sub for Dd {
    type Output = Dd;
    #[inline]
    fn sub(self, b: Dd) -> Dd {
        self + (-b)
    }
}

impl Mul for Dd {
    type Output = Dd;
    #[inline]
    fn mul(self, b: Dd) -> Dd {
        let (p, e) = two_prod(self.hi, b.hi);
        let e = self.hi.mul_add(b.lo, self.lo.mul_add(b.hi, e));
        let (hi, lo) = fast_two_sum(p, e);
        Dd { hi, lo }
    }
}

/// Compensated (dd) accumulator for sums of doubles and dd values.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct DdSum(pub Dd);

impl DdSum {
    #[inline]
    pub fn add(&mut self, v: Dd) {
        self.0 = self.0 + v;
    }
    #[inline]
    pub fn add_f64(&mut self, v: f64) {
        self.0 = self.0.add_f64(v);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tenth_times_ten_is_one_to_dd_precision() {
        let tenth = Dd::ONE.div_f64(10.0);
        let back = tenth.mul_f64(10.0) - Dd::ONE;
        assert!(back.to_f64().abs() < 1e-31, "{back:?}");
        // 0.1 is not a double, so the dd value must carry a nonzero tail.
        assert!(tenth.lo != 0.0);
    }

    #[test]
    fn exact_difference_and_cancellation() {
        let a = 1.0e16;
        let d = Dd::diff(a + 2.0, 1.0); // 1e16 + 1 is not representable
        assert_eq!(d.hi + d.lo, 1.0e16 + 1.0);
        let back = d.add_f64(1.0) - Dd::from_f64(a + 2.0);
        assert_eq!(back.to_f64(), 0.0);
    }

    #[test]
    fn product_keeps_low_bits() {
        let x = Dd::from_f64(1.0 + f64::EPSILON);
        let sq = x * x; // 1 + 2eps + eps^2
        assert_eq!(sq.hi, 1.0 + 2.0 * f64::EPSILON);
        assert_eq!(sq.lo, f64::EPSILON * f64::EPSILON);
    }
}
