//! Double-double arithmetic: a value as the unevaluated sum hi + lo of two `f64` with
//! |lo| ≤ ½ ulp(hi), about 106 significant bits. The error-free transformations (Knuth's
//! two-sum, the fused multiply-add product) are exact in IEEE arithmetic, so results are the
//! same on every platform. Used where a result is a small difference of large sums: the
//! residual variance of the control-variate regression (docs/model.md#control-variates).

use std::ops::{Add, Div, Mul, Neg, Sub};

/// A double-double number hi + lo.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Dd {
    hi: f64,
    lo: f64,
}

/// s + e = a + b exactly, s = fl(a + b).
#[inline]
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// s + e = a + b exactly when |a| ≥ |b| (or a = 0).
#[inline]
fn quick_two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    (s, b - (s - a))
}

/// p + e = a · b exactly (fused multiply-add, correctly rounded everywhere).
#[inline]
fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

impl Dd {
    /// hi + lo, renormalised.
    pub fn new(hi: f64, lo: f64) -> Self {
        let (hi, lo) = two_sum(hi, lo);
        Dd { hi, lo }
    }

    /// The nearest `f64`.
    pub fn to_f64(self) -> f64 {
        self.hi + self.lo
    }

    /// True when the value is > 0.
    pub fn is_positive(self) -> bool {
        self.hi > 0.0 || (self.hi == 0.0 && self.lo > 0.0)
    }
}

impl From<f64> for Dd {
    fn from(x: f64) -> Self {
        Dd { hi: x, lo: 0.0 }
    }
}

impl Neg for Dd {
    type Output = Dd;
    fn neg(self) -> Dd {
        Dd {
            hi: -self.hi,
            lo: -self.lo,
        }
    }
}

impl Add for Dd {
    type Output = Dd;
    fn add(self, b: Dd) -> Dd {
        let (s, e) = two_sum(self.hi, b.hi);
        let (t, f) = two_sum(self.lo, b.lo);
        let (s, e) = quick_two_sum(s, e + t);
        let (hi, lo) = quick_two_sum(s, e + f);
        Dd { hi, lo }
    }
}

impl Sub for Dd {
    type Output = Dd;
    fn sub(self, b: Dd) -> Dd {
        self + (-b)
    }
}

impl Mul for Dd {
    type Output = Dd;
    fn mul(self, b: Dd) -> Dd {
        let (p, e) = two_prod(self.hi, b.hi);
        let e = e + (self.hi * b.lo + self.lo * b.hi);
        let (hi, lo) = quick_two_sum(p, e);
        Dd { hi, lo }
    }
}

impl Div for Dd {
    type Output = Dd;
    fn div(self, b: Dd) -> Dd {
        // Long division: three f64 quotient digits.
        let q1 = self.hi / b.hi;
        let r = self - b * Dd::from(q1);
        let q2 = r.hi / b.hi;
        let r = r - b * Dd::from(q2);
        let q3 = r.hi / b.hi;
        let (hi, lo) = quick_two_sum(q1, q2);
        Dd { hi, lo } + Dd::from(q3)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_what_f64_loses() {
        // (1 + 2⁻⁶⁰) − 1 is 0 in f64 and 2⁻⁶⁰ in double-double.
        let tiny = 2f64.powi(-60);
        let x = Dd::from(1.0) + Dd::from(tiny) - Dd::from(1.0);
        assert_eq!(x.to_f64(), tiny);
        // (1 + 2⁻³⁰)² = 1 + 2⁻²⁹ + 2⁻⁶⁰: the last term survives.
        let a = Dd::from(1.0 + 2f64.powi(-30));
        let sq = a * a - Dd::from(1.0 + 2f64.powi(-29));
        assert_eq!(sq.to_f64(), tiny);
        // 1/3 · 3 = 1 to within 2⁻¹⁰⁴.
        let third = Dd::from(1.0) / Dd::from(3.0);
        let back = third * Dd::from(3.0) - Dd::from(1.0);
        assert!(back.to_f64().abs() <= 2f64.powi(-104), "{back:?}");
        // 1/3 has a low part: its f64 value times 3 is not 1 exactly in double-double.
        assert_ne!(third.lo, 0.0);
    }
}
