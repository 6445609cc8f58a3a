//! The number types the engine's vectorised arithmetic is written over, once: [`Real`] (one
//! `f64`, or several in lanes, with the IEEE operations lane by lane) and [`Lanes`], a token
//! that proves its instructions exist and makes, loads and stores its numbers. Vectorised code is a
//! function generic over `L: Lanes`; [`Scalar`] gives the one-sample code, [`Quad`] the
//! portable four lanes, and on x86-64 [`Avx2`](super::Avx2) the same four lanes in one
//! register, with the same bits (no FMA, no reassociation: each lane's operations are the
//! scalar ones in the same order).

use std::ops::{Add, Mul, Sub};

/// A number the arithmetic is written over: `+`, `−`, `×` lane by lane, as IEEE 754 does them.
pub trait Real: Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> {
    /// |x| (the sign bit cleared), lane by lane.
    fn abs(self) -> Self;
    /// The magnitude of `self` with the sign of `sign`, lane by lane.
    fn copysign(self, sign: Self) -> Self;
}

impl Real for f64 {
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        f64::copysign(self, sign)
    }
}

/// A way to compute on [`Real`]s: which number type, how many samples it holds, and how to
/// make, load and store one. Holding a token is the proof that its instructions exist.
pub trait Lanes: Copy {
    /// The number type: `WIDTH` consecutive samples.
    type F64: Real;
    /// Samples per number.
    const WIDTH: usize;
    /// `x` in every lane.
    fn splat(self, x: f64) -> Self::F64;
    /// `s[i .. i + WIDTH]`.
    ///
    /// # Panics
    /// If `s` holds fewer than `i + WIDTH` values.
    fn load(self, s: &[f64], i: usize) -> Self::F64;
    /// `s[i .. i + WIDTH]`, without the bounds check.
    ///
    /// # Safety
    /// `p` points at `i + WIDTH` readable values.
    unsafe fn load_ptr(self, p: *const f64, i: usize) -> Self::F64;
    /// `v` into `s[i .. i + WIDTH]`.
    ///
    /// # Panics
    /// If `s` holds fewer than `i + WIDTH` values.
    fn store(self, v: Self::F64, s: &mut [f64], i: usize);
    /// `v` into `p[i .. i + WIDTH]`, without the bounds check.
    ///
    /// # Safety
    /// `p` points at `i + WIDTH` writable values.
    unsafe fn store_ptr(self, v: Self::F64, p: *mut f64, i: usize);
    /// Bit l set where lane l of `x` is not ≤ `limit` (greater, or NaN).
    fn not_le_mask(self, x: Self::F64, limit: f64) -> u32;
}

/// Tokens of four lanes: the lanes of a number as an array, and the sums taken in them.
pub trait Lanes4: Lanes {
    /// The four lanes of `v`.
    fn lanes(self, v: Self::F64) -> [f64; 4];
    /// The four lanes of each of `v`. A loop: the closure of an array's `map` is not
    /// compiled with the caller's target features, so its intrinsics would be calls.
    #[inline(always)]
    fn lanes_each<const K: usize>(self, v: [Self::F64; K]) -> [[f64; 4]; K] {
        let mut out = [[0.0; 4]; K];
        for (out, v) in out.iter_mut().zip(v) {
            *out = self.lanes(v);
        }
        out
    }
    /// Each of `lanes` loaded (a loop, as [`lanes_each`](Self::lanes_each)).
    #[inline(always)]
    fn load_each<const K: usize>(self, lanes: &[[f64; 4]; K]) -> [Self::F64; K] {
        let mut out = [self.splat(0.0); K];
        for (out, lane) in out.iter_mut().zip(lanes) {
            *out = self.load(lane, 0);
        }
        out
    }
    /// Lane c: (l₀ + l₁) + (l₂ + l₃) of `v[c]`, the reduction of four numbers at once.
    fn reduce4(self, v: [Self::F64; 4]) -> Self::F64;
    /// Each of `v` reduced to (l₀ + l₁) + (l₂ + l₃), four at a time
    /// ([`reduce4`](Self::reduce4)); each sum is reduced apart from the others, so it has
    /// the same bits whatever its neighbours in `v`.
    #[inline(always)]
    fn reduce_each<const K: usize>(self, v: [Self::F64; K]) -> [f64; K] {
        let mut out = [0.0; K];
        let mut k = 0;
        while k < K {
            // Four sums at a time; past the last, any (here the first) stands in.
            let mut four = [v[0]; 4];
            for (j, x) in four.iter_mut().enumerate() {
                if k + j < K {
                    *x = v[k + j];
                }
            }
            let reduced = self.lanes(self.reduce4(four));
            for (j, r) in reduced.into_iter().enumerate() {
                if k + j < K {
                    out[k + j] = r;
                }
            }
            k += 4;
        }
        out
    }
    /// `a & b` bit by bit, lane by lane (a mask's lanes are all ones or all zeros).
    fn and(self, a: Self::F64, b: Self::F64) -> Self::F64;
    /// The mask of a ≤ b (ordered: false where either is NaN), lane by lane.
    fn le(self, a: Self::F64, b: Self::F64) -> Self::F64;
    /// The mask of a ≠ b (unordered: true where either is NaN), lane by lane.
    fn ne(self, a: Self::F64, b: Self::F64) -> Self::F64;
    /// Bit l set where lane l of the mask `m` is set (its sign bit).
    fn movemask(self, m: Self::F64) -> u32;
}

/// The one-sample token: [`Real`] is `f64`.
#[derive(Debug, Clone, Copy, Default)]
pub struct Scalar;

impl Lanes for Scalar {
    type F64 = f64;
    const WIDTH: usize = 1;
    #[inline(always)]
    fn splat(self, x: f64) -> f64 {
        x
    }
    #[inline(always)]
    fn load(self, s: &[f64], i: usize) -> f64 {
        s[i]
    }
    #[inline(always)]
    unsafe fn load_ptr(self, p: *const f64, i: usize) -> f64 {
        // SAFETY: as the caller promises.
        unsafe { *p.add(i) }
    }
    #[inline(always)]
    fn store(self, v: f64, s: &mut [f64], i: usize) {
        s[i] = v;
    }
    #[inline(always)]
    unsafe fn store_ptr(self, v: f64, p: *mut f64, i: usize) {
        // SAFETY: as the caller promises.
        unsafe { *p.add(i) = v }
    }
    #[inline(always)]
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // NaN is not ≤: the mask holds it
    fn not_le_mask(self, x: f64, limit: f64) -> u32 {
        u32::from(!(x <= limit))
    }
}

/// Four `f64` lanes in an array: the portable code of every four-lane function (the compiler
/// vectorises it as the target allows).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct F64x4Portable(pub [f64; 4]);

impl F64x4Portable {
    #[inline(always)]
    fn map2(self, o: Self, f: impl Fn(f64, f64) -> f64) -> Self {
        let (a, b) = (self.0, o.0);
        F64x4Portable([f(a[0], b[0]), f(a[1], b[1]), f(a[2], b[2]), f(a[3], b[3])])
    }
}

impl Add for F64x4Portable {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        self.map2(o, |a, b| a + b)
    }
}

impl Sub for F64x4Portable {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        self.map2(o, |a, b| a - b)
    }
}

impl Mul for F64x4Portable {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        self.map2(o, |a, b| a * b)
    }
}

impl Real for F64x4Portable {
    #[inline(always)]
    fn abs(self) -> Self {
        F64x4Portable(self.0.map(f64::abs))
    }
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        self.map2(sign, f64::copysign)
    }
}

/// The portable four-lane token.
#[derive(Debug, Clone, Copy, Default)]
pub struct Quad;

impl Lanes for Quad {
    type F64 = F64x4Portable;
    const WIDTH: usize = 4;
    #[inline(always)]
    fn splat(self, x: f64) -> F64x4Portable {
        F64x4Portable([x; 4])
    }
    #[inline(always)]
    fn load(self, s: &[f64], i: usize) -> F64x4Portable {
        F64x4Portable(s[i..i + 4].try_into().expect("four values"))
    }
    #[inline(always)]
    unsafe fn load_ptr(self, p: *const f64, i: usize) -> F64x4Portable {
        // SAFETY: as the caller promises.
        F64x4Portable(unsafe { std::ptr::read_unaligned(p.add(i).cast::<[f64; 4]>()) })
    }
    #[inline(always)]
    fn store(self, v: F64x4Portable, s: &mut [f64], i: usize) {
        s[i..i + 4].copy_from_slice(&v.0);
    }
    #[inline(always)]
    unsafe fn store_ptr(self, v: F64x4Portable, p: *mut f64, i: usize) {
        // SAFETY: as the caller promises.
        unsafe { std::ptr::write_unaligned(p.add(i).cast::<[f64; 4]>(), v.0) }
    }
    #[inline(always)]
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // NaN is not ≤: the mask holds it
    fn not_le_mask(self, x: F64x4Portable, limit: f64) -> u32 {
        (0..4).fold(0, |m, l| m | (u32::from(!(x.0[l] <= limit)) << l))
    }
}

impl Lanes4 for Quad {
    #[inline(always)]
    fn lanes(self, v: F64x4Portable) -> [f64; 4] {
        v.0
    }
    #[inline(always)]
    fn reduce4(self, v: [F64x4Portable; 4]) -> F64x4Portable {
        F64x4Portable(v.map(|v| (v.0[0] + v.0[1]) + (v.0[2] + v.0[3])))
    }
    #[inline(always)]
    fn and(self, a: F64x4Portable, b: F64x4Portable) -> F64x4Portable {
        a.map2(b, |a, b| f64::from_bits(a.to_bits() & b.to_bits()))
    }
    #[inline(always)]
    fn le(self, a: F64x4Portable, b: F64x4Portable) -> F64x4Portable {
        a.map2(b, |a, b| mask(a <= b))
    }
    #[inline(always)]
    fn ne(self, a: F64x4Portable, b: F64x4Portable) -> F64x4Portable {
        a.map2(b, |a, b| mask(a != b))
    }
    #[inline(always)]
    fn movemask(self, m: F64x4Portable) -> u32 {
        (0..4).fold(0, |bits, l| {
            bits | (u32::from(m.0[l].is_sign_negative()) << l)
        })
    }
}

/// A lane of a mask: all ones where `on`, else zero.
#[inline(always)]
fn mask(on: bool) -> f64 {
    f64::from_bits(if on { u64::MAX } else { 0 })
}
