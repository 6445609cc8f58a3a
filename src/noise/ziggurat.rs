//! The ziggurat's per-candidate steps: the candidate of a 64-bit word (portable, and
//! AVX2/AVX-512 bit for bit alike) and the squeeze that decides most wedge samples without
//! `exp`.

use super::BLOCK;
use super::tables::{ZIG_F, ZIG_X};

/// Relative margin around the squeeze's bounds in [`under_density`]: far above the few
/// units in the last place (≈ 1e-15) by which the tables, the bounds' arithmetic and libm's
/// `exp` can be off, so a decision taken from the bounds is the one `exp` would give.
const SQUEEZE_MARGIN: f64 = 1e-12;

/// Whether `y < exp(−x²/2)` for a candidate `x` in the wedge of `layer` (X\[layer + 1\] ≤
/// |x| ≤ X\[layer\]), calling `exp` only when cheap bounds leave it open.
///
/// Where the density is convex (|x| ≥ 1) it lies above its tangent at X\[layer\] and below
/// the chord between the layer's edges; where it is concave (|x| ≤ 1) the other way round.
/// A `y` below the lower bound (less the margin) is under the density and one above the
/// upper bound (plus the margin) is not; only the thin band between them calls `exp`. The
/// decisions, and so the normals, are exactly those of `y < (−0.5 x²).exp()`. Both
/// comparisons are computed before one (almost always predicted) branch.
#[inline]
pub(super) fn under_density(layer: usize, x: f64, y: f64) -> bool {
    squeeze(layer, x, y).unwrap_or_else(|| y < (-0.5 * x * x).exp())
}

/// The squeeze's decision of [`under_density`], or `None` when its bounds leave it open.
#[inline]
pub(super) fn squeeze(layer: usize, x: f64, y: f64) -> Option<bool> {
    let a = x.abs();
    let (x0, x1) = (ZIG_X[layer], ZIG_X[layer + 1]);
    let (f0, f1) = (ZIG_F[layer], ZIG_F[layer + 1]);
    let chord = f0 + (f1 - f0) * ((x0 - a) / (x0 - x1));
    let tangent = f0 * (1.0 + x0 * (x0 - a));
    // The one layer that straddles the inflection point at |x| = 1 has no squeeze.
    let convex = x1 >= 1.0;
    let concave = x0 <= 1.0;
    let (lower, upper) = if convex {
        (tangent, chord)
    } else {
        (chord, tangent)
    };
    let below = y < lower * (1.0 - SQUEEZE_MARGIN);
    let above = y > upper * (1.0 + SQUEEZE_MARGIN);
    ((convex | concave) & (below | above)).then_some(below)
}

/// The ziggurat candidate of a word: layer from the low 8 bits, a signed uniform
/// u ∈ [−1, 1) from the top 52 bits (built as a double in [1, 2) from its bit pattern, so
/// no integer-to-float conversion is needed), x = u·X\[layer\]; `inside` when |x| lies in
/// the layer's rectangle core.
#[inline(always)]
pub(super) fn candidate(word: u64) -> (f64, bool) {
    let layer = (word & 0xff) as usize;
    let one_to_two = f64::from_bits((word >> 12) | ONE_BITS);
    let u = 2.0 * one_to_two - 3.0;
    let x = u * ZIG_X[layer];
    (x, x.abs() < ZIG_X[layer + 1])
}

/// Bit pattern of 1.0.
const ONE_BITS: u64 = 0x3ff0_0000_0000_0000;

/// The candidate pass, portable version: `out[j]` gets every candidate and bit j of
/// `outside` is set when candidate j fell outside its layer's core.
pub(super) fn candidates_body(words: &[u64], out: &mut [f64], outside: &mut [u64; BLOCK / 64]) {
    for (j, (o, &w)) in out.iter_mut().zip(words).enumerate() {
        let (x, inside) = candidate(w);
        *o = x;
        outside[j / 64] |= u64::from(!inside) << (j % 64);
    }
}

/// The candidate pass; with AVX-512 eight and with AVX2 four candidates per instruction
/// (each layer's table pair read by one 128-bit load), giving bit for bit the values of the
/// portable version: the same exact bit operations, one rounded multiplication and the same
/// comparison per candidate.
pub(super) fn candidates(words: &[u64], out: &mut [f64], outside: &mut [u64; BLOCK / 64]) {
    #[cfg(target_arch = "x86_64")]
    {
        if crate::numeric::simd::avx512f() {
            // SAFETY: the CPU supports AVX-512F, checked just above.
            return unsafe { simd::candidates_avx512(words, out, outside) };
        }
        if crate::numeric::simd::avx2() {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { simd::candidates(words, out, outside) };
        }
    }
    candidates_body(words, out, outside)
}

#[cfg(target_arch = "x86_64")]
pub(super) mod simd {
    use std::arch::x86_64::*;

    use super::{BLOCK, ONE_BITS, ZIG_X, candidate};

    /// The pair (X\[layer\], X\[layer + 1\]) of a word, by one 128-bit load: the layer's
    /// width and its core's edge. (A table lookup by scalar loads: on some CPUs, such as
    /// AMD Zen 4, a gather instruction costs several times more than these loads.)
    ///
    /// # Safety
    /// `word` points to a readable u64; the layer index (< 256) keeps the load within
    /// ZIG_X's 257 entries.
    #[inline(always)]
    unsafe fn layer_pair(word: *const u64) -> __m128d {
        // SAFETY: as documented above.
        unsafe { _mm_loadu_pd(ZIG_X.as_ptr().add((*word & 0xff) as usize)) }
    }

    #[target_feature(enable = "avx512f")]
    pub(in crate::noise) fn candidates_avx512(
        words: &[u64],
        out: &mut [f64],
        outside: &mut [u64; BLOCK / 64],
    ) {
        let n = words.len();
        assert!(out.len() == n && n <= BLOCK);
        let whole = n - n % 8;
        let one = _mm512_set1_epi64(ONE_BITS as i64);
        let two = _mm512_set1_pd(2.0);
        let three = _mm512_set1_pd(3.0);
        // The reject bits of 64 candidates are gathered in a register and stored once.
        let mut bits = 0u64;
        let mut j = 0;
        while j < whole {
            // SAFETY: j + 8 <= n for `words` and `out`; `layer_pair` reads within ZIG_X.
            unsafe {
                let wp = words.as_ptr().add(j);
                let pair = |k: usize| _mm256_castpd128_pd256(layer_pair(wp.add(k)));
                // even candidates' pairs in `a`, odd ones' in `b`: unpacking the low and
                // high halves then gives widths and cores in candidate order
                let a02 = _mm256_insertf128_pd::<1>(pair(0), layer_pair(wp.add(2)));
                let a46 = _mm256_insertf128_pd::<1>(pair(4), layer_pair(wp.add(6)));
                let b13 = _mm256_insertf128_pd::<1>(pair(1), layer_pair(wp.add(3)));
                let b57 = _mm256_insertf128_pd::<1>(pair(5), layer_pair(wp.add(7)));
                let a = _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(a02), a46);
                let b = _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(b13), b57);
                let width = _mm512_unpacklo_pd(a, b);
                let core = _mm512_unpackhi_pd(a, b);
                let w = _mm512_loadu_si512(wp.cast());
                let m = _mm512_or_si512(_mm512_srli_epi64::<12>(w), one);
                let u = _mm512_sub_pd(_mm512_mul_pd(two, _mm512_castsi512_pd(m)), three);
                let x = _mm512_mul_pd(u, width);
                _mm512_storeu_pd(out.as_mut_ptr().add(j), x);
                let abs = _mm512_abs_pd(x);
                // not (|x| < core), as the portable `!inside`
                let mask = _mm512_cmp_pd_mask::<_CMP_NLT_UQ>(abs, core) as u64;
                bits |= mask << (j % 64);
            }
            j += 8;
            if j % 64 == 0 {
                outside[j / 64 - 1] |= bits;
                bits = 0;
            }
        }
        if j % 64 != 0 {
            outside[j / 64] |= bits;
        }
        for j in whole..n {
            let (x, inside) = candidate(words[j]);
            out[j] = x;
            outside[j / 64] |= u64::from(!inside) << (j % 64);
        }
    }

    #[target_feature(enable = "avx2")]
    pub(in crate::noise) fn candidates(
        words: &[u64],
        out: &mut [f64],
        outside: &mut [u64; BLOCK / 64],
    ) {
        let n = words.len();
        assert!(out.len() == n && n <= BLOCK);
        let whole = n - n % 4;
        let one = _mm256_set1_epi64x(ONE_BITS as i64);
        let two = _mm256_set1_pd(2.0);
        let three = _mm256_set1_pd(3.0);
        let sign = _mm256_set1_pd(-0.0);
        let mut j = 0;
        while j < whole {
            // SAFETY: j + 4 <= n for `words` and `out`; `layer_pair` reads within ZIG_X.
            unsafe {
                let wp = words.as_ptr().add(j);
                let pair = |k: usize| _mm256_castpd128_pd256(layer_pair(wp.add(k)));
                let a = _mm256_insertf128_pd::<1>(pair(0), layer_pair(wp.add(2)));
                let b = _mm256_insertf128_pd::<1>(pair(1), layer_pair(wp.add(3)));
                let width = _mm256_unpacklo_pd(a, b);
                let core = _mm256_unpackhi_pd(a, b);
                let w = _mm256_loadu_si256(wp.cast());
                let bits = _mm256_or_si256(_mm256_srli_epi64::<12>(w), one);
                let u = _mm256_sub_pd(_mm256_mul_pd(two, _mm256_castsi256_pd(bits)), three);
                let x = _mm256_mul_pd(u, width);
                _mm256_storeu_pd(out.as_mut_ptr().add(j), x);
                let abs = _mm256_andnot_pd(sign, x);
                // not (|x| < core), as the portable `!inside`
                let rejected = _mm256_cmp_pd::<_CMP_NLT_UQ>(abs, core);
                let mask = _mm256_movemask_pd(rejected) as u64;
                outside[j / 64] |= mask << (j % 64);
            }
            j += 4;
        }
        for j in whole..n {
            let (x, inside) = candidate(words[j]);
            out[j] = x;
            outside[j / 64] |= u64::from(!inside) << (j % 64);
        }
    }
}
