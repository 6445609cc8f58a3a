//! AVX2's four `f64` lanes: [`Avx2`], the token made only where the CPU has AVX2, and
//! [`F64x4`], its number type, one 256-bit register. Lane for lane the IEEE operations of
//! [`Quad`](super::Quad)'s array, so the same bits.

use std::arch::x86_64::*;
use std::ops::{Add, Mul, Sub};

use super::lanes::{Lanes, Lanes4, Real};

/// The AVX2 token: a value exists only where the CPU has AVX2 and the portable code is not
/// forced ([`Avx2::detect`]).
#[derive(Debug, Clone, Copy)]
pub struct Avx2(());

impl Avx2 {
    /// The token, where AVX2 may run ([`avx2`](super::avx2)).
    #[inline]
    pub fn detect() -> Option<Avx2> {
        super::avx2().then_some(Avx2(()))
    }
}

/// Four `f64` in one AVX2 register. Made only by [`Avx2`]'s methods, so a value proves the
/// CPU has AVX2: that is what makes its operations safe to call.
#[derive(Debug, Clone, Copy)]
#[repr(transparent)]
pub struct F64x4(__m256d);

macro_rules! op {
    ($trait:ident, $method:ident, $intrinsic:ident) => {
        impl $trait for F64x4 {
            type Output = F64x4;
            #[inline(always)]
            fn $method(self, o: F64x4) -> F64x4 {
                // SAFETY: an F64x4 exists only where the CPU has AVX2.
                F64x4(unsafe { $intrinsic(self.0, o.0) })
            }
        }
    };
}

op!(Add, add, _mm256_add_pd);
op!(Sub, sub, _mm256_sub_pd);
op!(Mul, mul, _mm256_mul_pd);

impl Real for F64x4 {
    #[inline(always)]
    fn abs(self) -> F64x4 {
        // SAFETY: an F64x4 exists only where the CPU has AVX2.
        F64x4(unsafe { _mm256_andnot_pd(_mm256_set1_pd(-0.0), self.0) })
    }
    #[inline(always)]
    fn copysign(self, sign: F64x4) -> F64x4 {
        // SAFETY: an F64x4 exists only where the CPU has AVX2.
        unsafe {
            let bit = _mm256_set1_pd(-0.0);
            F64x4(_mm256_or_pd(
                _mm256_andnot_pd(bit, self.0),
                _mm256_and_pd(bit, sign.0),
            ))
        }
    }
}

impl Lanes for Avx2 {
    type F64 = F64x4;
    const WIDTH: usize = 4;
    #[inline(always)]
    fn splat(self, x: f64) -> F64x4 {
        // SAFETY: the token exists only where the CPU has AVX2.
        F64x4(unsafe { _mm256_set1_pd(x) })
    }
    #[inline(always)]
    fn load(self, s: &[f64], i: usize) -> F64x4 {
        // No formatted message: its arguments would be kept for the panic on every call
        // of a hot loop.
        assert!(i + 4 <= s.len(), "four values past the end of the slice");
        // SAFETY: bounds checked just above; the token proves AVX2.
        unsafe { self.load_ptr(s.as_ptr(), i) }
    }
    #[inline(always)]
    unsafe fn load_ptr(self, p: *const f64, i: usize) -> F64x4 {
        // SAFETY: as the caller promises; the token proves AVX2.
        F64x4(unsafe { _mm256_loadu_pd(p.add(i)) })
    }
    #[inline(always)]
    fn store(self, v: F64x4, s: &mut [f64], i: usize) {
        assert!(i + 4 <= s.len(), "four values past the end of the slice");
        // SAFETY: bounds checked just above; the token proves AVX2.
        unsafe { self.store_ptr(v, s.as_mut_ptr(), i) }
    }
    #[inline(always)]
    unsafe fn store_ptr(self, v: F64x4, p: *mut f64, i: usize) {
        // SAFETY: as the caller promises; the token proves AVX2.
        unsafe { _mm256_storeu_pd(p.add(i), v.0) }
    }
    #[inline(always)]
    fn not_le_mask(self, x: F64x4, limit: f64) -> u32 {
        // SAFETY: the token proves AVX2.
        unsafe {
            let not_le = _mm256_cmp_pd::<_CMP_NLE_UQ>(x.0, _mm256_set1_pd(limit));
            _mm256_movemask_pd(not_le) as u32
        }
    }
}

impl Lanes4 for Avx2 {
    #[inline(always)]
    fn lanes(self, v: F64x4) -> [f64; 4] {
        let mut out = [0.0; 4];
        self.store(v, &mut out, 0);
        out
    }
    #[inline(always)]
    fn reduce4(self, [a, b, c, d]: [F64x4; 4]) -> F64x4 {
        // SAFETY: the token proves AVX2.
        unsafe {
            // [a₀+a₁, b₀+b₁, a₂+a₃, b₂+b₃] and the same of c, d; then lane k: the first
            // pair's sum plus the second's.
            let ab = _mm256_hadd_pd(a.0, b.0);
            let cd = _mm256_hadd_pd(c.0, d.0);
            F64x4(_mm256_add_pd(
                _mm256_permute2f128_pd::<0x20>(ab, cd),
                _mm256_permute2f128_pd::<0x31>(ab, cd),
            ))
        }
    }
    #[inline(always)]
    fn and(self, a: F64x4, b: F64x4) -> F64x4 {
        // SAFETY: the token proves AVX2.
        F64x4(unsafe { _mm256_and_pd(a.0, b.0) })
    }
    #[inline(always)]
    fn le(self, a: F64x4, b: F64x4) -> F64x4 {
        // SAFETY: the token proves AVX2.
        F64x4(unsafe { _mm256_cmp_pd::<_CMP_LE_OQ>(a.0, b.0) })
    }
    #[inline(always)]
    fn ne(self, a: F64x4, b: F64x4) -> F64x4 {
        // SAFETY: the token proves AVX2.
        F64x4(unsafe { _mm256_cmp_pd::<_CMP_NEQ_UQ>(a.0, b.0) })
    }
    #[inline(always)]
    fn movemask(self, m: F64x4) -> u32 {
        // SAFETY: the token proves AVX2.
        unsafe { _mm256_movemask_pd(m.0) as u32 }
    }
}
