//! The exactly rounded sum of many terms, fast: a compensated sum in SIMD lanes (each
//! addition's rounding error kept by Knuth's TwoSum and summed apart) with a rigorous bound
//! on what that sum may still miss. Where the bound shows the exact sum rounds to the same
//! `f64` as the compensated one, that is the answer; otherwise (a sum that cancels to within
//! the bound of a rounding boundary, a huge or tiny total, a non-finite term) the terms go
//! through the exact accumulator. An exactly rounded sum is one number whatever computes
//! it, so both routes give the bits [`ExactSum`](super::ExactSum) gives.
//!
//! The bound: TwoSum is error-free, so the computed sum s and the exact errors eᵢ of its
//! n − 1 additions satisfy S = s + Σeᵢ exactly, in any order of the additions; |eᵢ| ≤ u·|sᵢ|
//! ≤ u(1 + γₙ)·Σ|pᵢ| (u = 2⁻⁵³, sᵢ a partial sum), and summing the eᵢ in floating point
//! errs by at most γₙ·Σ|eᵢ|. So |S − (s + c)| ≤ γₙ·n·u·(1 + γₙ)·Σ|pᵢ| with c the computed
//! sum of the errors (Ogita, Rump and Oishi, "Accurate sum and dot product", SIAM J. Sci.
//! Comput. 26, 2005, §4), which 2·(m·u)²·A bounds with m = 2n + 16 (every addition of terms,
//! of lanes and of errors) and A the computed Σ|pᵢ|, for n < 2³⁰.

use super::exact_sum;
#[cfg(target_arch = "x86_64")]
use crate::numeric::simd::Avx2;
use crate::numeric::simd::{Lanes, Lanes4, Quad, Real, Scalar};

/// The terms of a sum, by row: read in lanes of any width.
pub trait Terms {
    /// Number of terms.
    fn len(&self) -> usize;
    /// Whether there are none.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Terms `i .. i + L::WIDTH`.
    fn at<L: Lanes>(&self, l: L, i: usize) -> L::F64;
}

/// Σ aᵢ.
pub struct Plain<'a>(pub &'a [f64]);
/// Σ aᵢ·bᵢ (each product rounded, then summed exactly).
pub struct Dot<'a>(pub &'a [f64], pub &'a [f64]);
/// Σ (aᵢ·aᵢ)·bᵢ (each product rounded in that order, then summed exactly).
pub struct SquareDot<'a>(pub &'a [f64], pub &'a [f64]);

impl Terms for Plain<'_> {
    fn len(&self) -> usize {
        self.0.len()
    }
    #[inline(always)]
    fn at<L: Lanes>(&self, l: L, i: usize) -> L::F64 {
        l.load(self.0, i)
    }
}

impl Terms for Dot<'_> {
    fn len(&self) -> usize {
        assert_eq!(self.0.len(), self.1.len(), "a dot product of equal lengths");
        self.0.len()
    }
    #[inline(always)]
    fn at<L: Lanes>(&self, l: L, i: usize) -> L::F64 {
        l.load(self.0, i) * l.load(self.1, i)
    }
}

impl Terms for SquareDot<'_> {
    fn len(&self) -> usize {
        assert_eq!(self.0.len(), self.1.len(), "a dot product of equal lengths");
        self.0.len()
    }
    #[inline(always)]
    fn at<L: Lanes>(&self, l: L, i: usize) -> L::F64 {
        let a = l.load(self.0, i);
        a * a * l.load(self.1, i)
    }
}

/// The exactly rounded sum of `terms`: bit for bit [`exact_sum`] of the same terms.
pub fn exact_sum_of(terms: &impl Terms) -> f64 {
    let n = terms.len();
    match compensated(terms) {
        Some(sum) => sum,
        None => exact_sum((0..n).map(|i| terms.at(Scalar, i))),
    }
}

/// A sum in flight: the running sum, the sum of its additions' errors, and Σ|p|.
#[derive(Clone, Copy)]
struct Running<R> {
    s: R,
    c: R,
    a: R,
}

impl<R: Real> Running<R> {
    #[inline(always)]
    fn add(&mut self, p: R) {
        let (s, e) = two_sum(self.s, p);
        self.s = s;
        self.c = self.c + e;
        self.a = self.a + p.abs();
    }
}

/// a + b = s + e exactly, s = fl(a + b) (Knuth's TwoSum; round to nearest).
#[inline(always)]
fn two_sum<R: Real>(a: R, b: R) -> (R, R) {
    let s = a + b;
    let bb = s - a;
    let e = (a - (s - bb)) + (b - bb);
    (s, e)
}

/// The compensated sum of `terms` rounded once, when the bound proves it is the exactly
/// rounded sum; `None` when it cannot.
fn compensated(terms: &impl Terms) -> Option<f64> {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = Avx2::detect() {
        // SAFETY: the token proves the CPU has AVX2.
        return unsafe { compensated_avx2(avx2, terms) };
    }
    compensated_lanes(Quad, terms)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn compensated_avx2(avx2: Avx2, terms: &impl Terms) -> Option<f64> {
    compensated_lanes(avx2, terms)
}

#[inline(always)]
fn compensated_lanes<L: Lanes4>(l: L, terms: &impl Terms) -> Option<f64> {
    const WIDTH: usize = 4;
    let n = terms.len();
    // Two sums in flight hide the latency of the additions.
    let mut acc = LaneSums::<L, 2>::new(l);
    let whole = n - n % (2 * WIDTH);
    for i in (0..whole).step_by(2 * WIDTH) {
        acc.add([terms.at(l, i), terms.at(l, i + WIDTH)]);
    }
    let [first, second] = acc.0.map(|lane| lane_total(l, lane));
    let mut total = first;
    merge(&mut total, second);
    for i in whole..n {
        total.add(terms.at(Scalar, i));
    }
    decide(total, n)
}

/// K compensated sums in the lanes of `L`, added to a block of lanes at a time: the
/// running sums of a pass over rows that sums several terms of each row at once
/// (a regression's constant sums). [`LaneSums::finish`] gives each exactly rounded sum the
/// bound decides.
pub struct LaneSums<L: Lanes, const K: usize>([Running<L::F64>; K], [Running<f64>; K]);

impl<L: Lanes4, const K: usize> LaneSums<L, K> {
    /// K empty sums.
    #[inline(always)]
    pub fn new(l: L) -> Self {
        let zero = Running {
            s: l.splat(0.0),
            c: l.splat(0.0),
            a: l.splat(0.0),
        };
        let scalar = Running {
            s: 0.0,
            c: 0.0,
            a: 0.0,
        };
        LaneSums([zero; K], [scalar; K])
    }

    /// The terms of one block of lanes, one per sum.
    #[inline(always)]
    pub fn add(&mut self, terms: [L::F64; K]) {
        for (sum, p) in self.0.iter_mut().zip(terms) {
            sum.add(p);
        }
    }

    /// The terms of one row beyond the blocks, one per sum.
    #[inline(always)]
    pub fn add_row(&mut self, terms: [f64; K]) {
        for (sum, p) in self.1.iter_mut().zip(terms) {
            sum.add(p);
        }
    }

    /// Each sum of `n` terms in all, exactly rounded where the bound decides it (`None`
    /// where it cannot: the caller sums those terms exactly, [`exact_sum_of`]).
    #[inline(always)]
    pub fn finish(self, l: L, n: usize) -> [Option<f64>; K] {
        let mut out = [None; K];
        for ((o, lanes), rows) in out.iter_mut().zip(self.0).zip(self.1) {
            let mut total = lane_total(l, lanes);
            merge(&mut total, rows);
            *o = decide(total, n);
        }
        out
    }
}

/// A sum in lanes as one scalar sum (each addition's error kept).
#[inline(always)]
fn lane_total<L: Lanes4>(l: L, lanes: Running<L::F64>) -> Running<f64> {
    let mut total = Running {
        s: 0.0,
        c: 0.0,
        a: 0.0,
    };
    let [s, c, a] = [lanes.s, lanes.c, lanes.a].map(|v| l.lanes(v));
    for k in 0..4 {
        total.add(s[k]);
        total.c += c[k];
        total.a += a[k];
    }
    total
}

/// `other` added into `total` (its sum by TwoSum, its errors and magnitudes summed).
#[inline(always)]
fn merge(total: &mut Running<f64>, other: Running<f64>) {
    total.add(other.s);
    total.c += other.c;
    total.a += other.a;
}

/// The exactly rounded sum of `n` terms summed into `total`, when the bound proves it.
#[inline(always)]
fn decide(total: Running<f64>, n: usize) -> Option<f64> {
    if n >= 1 << 30 {
        return None;
    }
    let (r, t) = two_sum(total.s, total.c);
    // Additions of terms, of lanes and of errors: under 2n + 16 in all.
    let steps = (2 * n + 16) as f64 * f64::EPSILON / 2.0;
    let bound = 2.0 * steps * steps * total.a;
    // Far from overflow and from the subnormals (NaN, from a NaN or infinite term, is
    // neither).
    let in_range = total.a < 2f64.powi(1000) && r.abs() >= 2f64.powi(-1000);
    if !in_range {
        return None;
    }
    // Half the smaller gap from |r| to its neighbours: the exact sum rounds to r when it is
    // closer to r than that.
    let bits = r.abs().to_bits();
    let up = f64::from_bits(bits + 1) - r.abs();
    let down = r.abs() - f64::from_bits(bits - 1);
    let half_gap = up.min(down) / 2.0;
    (t.abs() + 2.0 * bound < half_gap).then_some(r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn the_fast_sum_is_the_exact_accumulators_bit_for_bit() {
        // Well-conditioned, cancelling, wide-exponent and tiny sums, every length mod 8.
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut fast_paths = 0;
        for case in 0..400 {
            let n = 1 + case * 37 % 5000;
            let a: Vec<f64> = (0..n)
                .map(|i| match case % 4 {
                    0 => rng.random::<f64>(),
                    1 => rng.random::<f64>() - 0.5,
                    2 => (rng.random::<f64>() - 0.5) * 10f64.powi((i % 60) - 30),
                    _ => (i as f64 * 0.01).sin(),
                })
                .collect();
            let b: Vec<f64> = (0..n).map(|_| rng.random::<f64>() * 3.0 - 1.0).collect();
            let exact_plain = exact_sum(a.iter().copied());
            let exact_dot = exact_sum(a.iter().zip(&b).map(|(x, y)| x * y));
            let exact_square = exact_sum(a.iter().zip(&b).map(|(x, y)| x * x * y));
            assert_eq!(exact_sum_of(&Plain(&a)).to_bits(), exact_plain.to_bits());
            assert_eq!(exact_sum_of(&Dot(&a, &b)).to_bits(), exact_dot.to_bits());
            assert_eq!(
                exact_sum_of(&SquareDot(&a, &b)).to_bits(),
                exact_square.to_bits()
            );
            fast_paths += usize::from(compensated(&Dot(&a, &b)).is_some());
        }
        // The fast route is the usual one (else the test would only check the fallback).
        assert!(
            fast_paths > 300,
            "{fast_paths} of 400 sums took the fast route"
        );
    }

    #[test]
    fn several_sums_in_one_pass_are_each_exact_or_handed_over() {
        // Sum 0 of a row's terms is well conditioned; sum 1 ends at a tie (1 + 2⁻⁵³), which
        // the bound cannot decide.
        let n = 4 * 1000 + 3;
        let rows: Vec<[f64; 2]> = (0..n)
            .map(|i| {
                let x = (i as f64 * 0.37).sin() + 2.0;
                let tie = match i {
                    0 => 1.0,
                    1 => 2f64.powi(-53),
                    _ => 0.0,
                };
                [x, tie]
            })
            .collect();
        let mut sums = LaneSums::<Quad, 2>::new(Quad);
        let whole = n - n % 4;
        for i in (0..whole).step_by(4) {
            let lanes = |k: usize| Quad.load(&[0, 1, 2, 3].map(|j| rows[i + j][k]), 0);
            sums.add([lanes(0), lanes(1)]);
        }
        for row in &rows[whole..] {
            sums.add_row(*row);
        }
        let [well, tie] = sums.finish(Quad, n);
        assert_eq!(
            well.map(f64::to_bits),
            Some(exact_sum(rows.iter().map(|r| r[0])).to_bits())
        );
        assert_eq!(tie, None);
    }

    #[test]
    fn sums_at_a_rounding_boundary_and_non_finite_terms_fall_back() {
        // 1 + 2⁻⁵³ is a tie: the compensated sum sees the half ulp exactly and hands over.
        let tie = [1.0, 2f64.powi(-53)];
        assert_eq!(compensated(&Plain(&tie)), None);
        assert_eq!(exact_sum_of(&Plain(&tie)), 1.0);
        let past = [1.0, 2f64.powi(-53), 2f64.powi(-80)];
        assert_eq!(exact_sum_of(&Plain(&past)), 1.0 + f64::EPSILON);
        assert!(exact_sum_of(&Plain(&[1.0, f64::NAN])).is_nan());
        assert_eq!(exact_sum_of(&Plain(&[1.0, f64::INFINITY])), f64::INFINITY);
        assert_eq!(exact_sum_of(&Plain(&[])), 0.0);
        assert_eq!(exact_sum_of(&Plain(&[1e16, 1.0, -1e16])), 1.0);
    }
}
