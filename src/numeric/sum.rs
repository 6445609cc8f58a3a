//! Exact, order-independent summation of `f64` values.
//!
//! Monte Carlo summaries must be identical whatever the thread count, shard split or the
//! order in which partial results arrive. A floating-point running sum is not: its rounding
//! depends on the order. [`ExactSum`] keeps the sum as a wide fixed-point integer (a Kulisch
//! accumulator covering every `f64` exponent), so adding is exact and associative, merging
//! two accumulators is exact, and the result is rounded to `f64` once, at the end.

mod compensated;
pub use compensated::{Dot, LaneSums, Plain, SquareDot, Terms, exact_sum_of};

/// Bits per limb; limbs are `i64` so each has 31 bits of headroom for lazy carries.
const LIMB_BITS: u32 = 32;
/// Limbs to cover bit positions 2^-1074 … 2^1024 plus carry room.
const LIMBS: usize = 70;
/// Additions allowed between carry normalisations (each adds < 2^32 to a limb).
const MAX_PENDING: u32 = 1 << 29;
/// Exponent of the least significant bit of limb 0.
const LSB_EXPONENT: i32 = -1074;

/// An exact accumulator for sums of `f64` values (NaN and ±∞ are tracked and propagate).
#[derive(Clone, PartialEq, Eq)]
pub struct ExactSum {
    limbs: [i64; LIMBS],
    pending: u32,
    nan: bool,
    pos_inf: bool,
    neg_inf: bool,
}

impl Default for ExactSum {
    fn default() -> Self {
        Self::new()
    }
}

impl std::fmt::Debug for ExactSum {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_tuple("ExactSum").field(&self.value()).finish()
    }
}

impl ExactSum {
    /// An empty sum (zero).
    pub const fn new() -> Self {
        ExactSum {
            limbs: [0; LIMBS],
            pending: 0,
            nan: false,
            pos_inf: false,
            neg_inf: false,
        }
    }

    /// Add `x` exactly.
    #[inline]
    pub fn add(&mut self, x: f64) {
        if !x.is_finite() {
            if x.is_nan() {
                self.nan = true;
            } else if x > 0.0 {
                self.pos_inf = true;
            } else {
                self.neg_inf = true;
            }
            return;
        }
        if x == 0.0 {
            return;
        }
        let bits = x.to_bits();
        let exponent_field = ((bits >> 52) & 0x7ff) as u32;
        let fraction = bits & ((1u64 << 52) - 1);
        let (mantissa, position) = if exponent_field == 0 {
            (fraction, 0u32)
        } else {
            (fraction | (1u64 << 52), exponent_field - 1)
        };
        let limb = (position / LIMB_BITS) as usize;
        let shifted = (mantissa as u128) << (position % LIMB_BITS);
        let mask = (1u128 << LIMB_BITS) - 1;
        let parts = [
            (shifted & mask) as i64,
            ((shifted >> LIMB_BITS) & mask) as i64,
            (shifted >> (2 * LIMB_BITS)) as i64,
        ];
        if x > 0.0 {
            for (k, p) in parts.into_iter().enumerate() {
                self.limbs[limb + k] += p;
            }
        } else {
            for (k, p) in parts.into_iter().enumerate() {
                self.limbs[limb + k] -= p;
            }
        }
        self.pending += 1;
        if self.pending >= MAX_PENDING {
            self.normalise();
        }
    }

    /// Add every value of an iterator.
    pub fn add_all(&mut self, values: impl IntoIterator<Item = f64>) {
        for v in values {
            self.add(v);
        }
    }

    /// Add another accumulator exactly (the merge of two partial sums).
    pub fn merge(&mut self, other: &ExactSum) {
        let mut other = other.clone();
        other.normalise();
        self.normalise();
        for (a, b) in self.limbs.iter_mut().zip(other.limbs.iter()) {
            *a += *b;
        }
        self.pending = 1;
        self.nan |= other.nan;
        self.pos_inf |= other.pos_inf;
        self.neg_inf |= other.neg_inf;
    }

    /// Propagate carries so that every limb but the top one lies in [0, 2^32).
    fn normalise(&mut self) {
        for i in 0..LIMBS - 1 {
            let carry = self.limbs[i] >> LIMB_BITS;
            self.limbs[i] -= carry << LIMB_BITS;
            self.limbs[i + 1] += carry;
        }
        self.pending = 0;
    }

    /// The sum as a double-double: its rounded value and the rounded remainder (the
    /// remainder exact to 2⁻¹⁰⁶ relative), for arithmetic that needs more than `f64` keeps.
    pub fn value_dd(&self) -> crate::numeric::dd::Dd {
        let hi = self.value();
        if !hi.is_finite() {
            return crate::numeric::dd::Dd::from(hi);
        }
        let mut rest = self.clone();
        rest.add(-hi);
        crate::numeric::dd::Dd::new(hi, rest.value())
    }

    /// The sum rounded to the nearest `f64` (ties to even; subnormal results may be off by
    /// one unit in the last place). Independent of the order of additions and merges.
    pub fn value(&self) -> f64 {
        if self.nan || (self.pos_inf && self.neg_inf) {
            return f64::NAN;
        }
        if self.pos_inf {
            return f64::INFINITY;
        }
        if self.neg_inf {
            return f64::NEG_INFINITY;
        }
        let mut acc = self.clone();
        acc.normalise();
        let negative = acc.limbs[LIMBS - 1] < 0;
        if negative {
            for l in acc.limbs.iter_mut() {
                *l = -*l;
            }
            acc.normalise();
        }
        let Some(top) = acc.limbs.iter().rposition(|&l| l != 0) else {
            return 0.0;
        };
        // Gather up to 96 significant bits from the top three limbs, with a sticky bit for
        // anything below, then let the u128 → f64 conversion round once.
        let low = top.saturating_sub(2);
        let mut head: u128 = 0;
        for i in (low..=top).rev() {
            head = (head << LIMB_BITS) | acc.limbs[i] as u128;
        }
        if acc.limbs[..low].iter().any(|&l| l != 0) {
            head |= 1;
        }
        let magnitude =
            scale_by_power_of_two(head as f64, low as i32 * LIMB_BITS as i32 + LSB_EXPONENT);
        if negative { -magnitude } else { magnitude }
    }
}

/// `x · 2^k` without intermediate overflow or underflow of the power of two.
fn scale_by_power_of_two(mut x: f64, mut k: i32) -> f64 {
    while k > 1000 {
        x *= f64::from_bits(((1000 + 1023) as u64) << 52);
        k -= 1000;
    }
    while k < -1000 {
        x *= f64::from_bits(((-1000 + 1023) as u64) << 52);
        k += 1000;
    }
    x * f64::from_bits(((k + 1023) as u64) << 52)
}

/// The correctly rounded sum of `values` (see [`ExactSum`]).
pub fn exact_sum(values: impl IntoIterator<Item = f64>) -> f64 {
    let mut s = ExactSum::new();
    s.add_all(values);
    s.value()
}

/// The mean of `values` from their exactly rounded sum; NaN when empty.
pub fn exact_mean(values: &[f64]) -> f64 {
    exact_sum(values.iter().copied()) / values.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cancellation_that_breaks_naive_sums_is_exact() {
        // 1e16 + 1 - 1e16 = 1 exactly; a naive left-to-right sum gives 0.
        assert_eq!(exact_sum([1e16, 1.0, -1e16]), 1.0);
        assert_eq!(exact_sum([1e308, 1e308, -1e308]), 1e308);
        assert_eq!(
            exact_sum([f64::MIN_POSITIVE / 4.0, 1.0, -1.0]),
            f64::MIN_POSITIVE / 4.0
        );
        // The doubles nearest 0.1, 0.2 and 0.3 sum to exactly 2^-55 (their decimal
        // expansions: 0.1000000000000000055511151231257827 + 0.2000000000000000111022302462515654
        // - 0.2999999999999999888977697537484345); the naive sum gives 5.55e-17.
        assert_eq!(exact_sum([0.1, 0.2, -0.3]), 2f64.powi(-55));
    }

    #[test]
    fn order_and_merging_do_not_change_the_result() {
        let values: Vec<f64> = (0..10_000)
            .map(|i| ((i as f64) * 0.7).sin() * 10f64.powi((i % 40) - 20))
            .collect();
        let forward = exact_sum(values.iter().copied());
        let backward = exact_sum(values.iter().rev().copied());
        let mut left = ExactSum::new();
        let mut right = ExactSum::new();
        for (i, v) in values.iter().enumerate() {
            if i % 3 == 0 {
                left.add(*v)
            } else {
                right.add(*v)
            }
        }
        right.merge(&left);
        assert_eq!(forward.to_bits(), backward.to_bits());
        assert_eq!(forward.to_bits(), right.value().to_bits());
    }

    #[test]
    fn negative_totals_and_non_finite_values() {
        assert_eq!(exact_sum([-3.5, 1.25]), -2.25);
        assert!(exact_sum([1.0, f64::NAN]).is_nan());
        assert_eq!(exact_sum([1.0, f64::INFINITY]), f64::INFINITY);
        assert!(exact_sum([f64::NEG_INFINITY, f64::INFINITY]).is_nan());
        assert_eq!(exact_sum([]), 0.0);
    }

    #[test]
    fn lazy_carries_are_normalised_without_loss() {
        let mut s = ExactSum::new();
        s.pending = MAX_PENDING - 5; // pretend many additions happened: forces normalise()
        let big = 2f64.powi(900);
        for _ in 0..10 {
            s.add(big);
            s.add(-0.5);
        }
        s.add(-10.0 * big);
        assert_eq!(s.value(), -5.0); // only exact carries can bring back the -0.5s
        s.add(5.0);
        s.add(1e-300);
        assert_eq!(s.value(), 1e-300);
    }
}
