//! The ziggurat's candidate pass on 64-bit lanes: four candidates per AVX2 instruction,
//! eight per AVX-512 instruction. The table and the portable code are in `noise::ziggurat`,
//! which gives the same bits and against which these are tested.
//!
//! The candidate of a word: layer ℓ from the low 8 bits, a signed uniform u ∈ [−1, 1) from
//! the top 52 bits (built as a double in [1, 2) from its bit pattern, so no
//! integer-to-float conversion is needed), x = u·X\[ℓ\]; it is outside its layer's core when
//! not |x| < X\[ℓ + 1\].

use std::arch::x86_64::*;

/// Bit pattern of 1.0.
const ONE_BITS: u64 = 0x3ff0_0000_0000_0000;

/// The pair (X\[ℓ\], X\[ℓ + 1\]) of a word, by one 128-bit load: the layer's width and its
/// core's edge. (A table lookup by scalar loads: on some CPUs, such as AMD Zen 4, a gather
/// instruction costs several times more than these loads.)
///
///
/// # Safety
/// `word` points to a readable u64; the layer index (< 256) keeps the load within the
/// table's 257 entries.
#[inline(always)]
unsafe fn layer_pair(table: &[f64; 257], word: *const u64) -> __m128d {
    // SAFETY: as documented above.
    unsafe { _mm_loadu_pd(table.as_ptr().add((*word & 0xff) as usize)) }
}

/// The candidates of `words` in groups of eight: `out[j]` gets candidate j and bit j of
/// `outside` is set (or-ed in) when it is outside its layer's core. Returns how many were
/// done (the whole groups); the caller does the rest.
///
/// # Panics
/// When `out` is shorter than `words`, or `outside` holds fewer than `words.len()` bits.
///
/// # Safety
/// The CPU supports AVX-512F ([`crate::numeric::simd::avx512f`]).
#[target_feature(enable = "avx512f")]
pub fn ziggurat_candidates_8(
    table: &[f64; 257],
    words: &[u64],
    out: &mut [f64],
    outside: &mut [u64],
) -> usize {
    let n = words.len();
    assert!(out.len() >= n && 64 * outside.len() >= n);
    let whole = n - n % 8;
    let one = _mm512_set1_epi64(ONE_BITS as i64);
    let two = _mm512_set1_pd(2.0);
    let three = _mm512_set1_pd(3.0);
    // The outside bits of 64 candidates are gathered in a register and stored once.
    let mut bits = 0u64;
    let mut j = 0;
    while j < whole {
        // SAFETY: j + 8 <= n for `words` and `out`; `layer_pair` reads within the table.
        unsafe {
            let wp = words.as_ptr().add(j);
            let pair = |k: usize| _mm256_castpd128_pd256(layer_pair(table, wp.add(k)));
            // even candidates' pairs in `a`, odd ones' in `b`: unpacking the low and
            // high halves then gives widths and cores in candidate order
            let a02 = _mm256_insertf128_pd::<1>(pair(0), layer_pair(table, wp.add(2)));
            let a46 = _mm256_insertf128_pd::<1>(pair(4), layer_pair(table, wp.add(6)));
            let b13 = _mm256_insertf128_pd::<1>(pair(1), layer_pair(table, wp.add(3)));
            let b57 = _mm256_insertf128_pd::<1>(pair(5), layer_pair(table, wp.add(7)));
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
            // not (|x| < core)
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
    whole
}

/// As [`ziggurat_candidates_8`], in groups of four.
///
/// # Panics
/// As [`ziggurat_candidates_8`].
///
/// # Safety
/// The CPU supports AVX2 ([`crate::numeric::simd::avx2`]).
#[target_feature(enable = "avx2")]
pub fn ziggurat_candidates_4(
    table: &[f64; 257],
    words: &[u64],
    out: &mut [f64],
    outside: &mut [u64],
) -> usize {
    let n = words.len();
    assert!(out.len() >= n && 64 * outside.len() >= n);
    let whole = n - n % 4;
    let one = _mm256_set1_epi64x(ONE_BITS as i64);
    let two = _mm256_set1_pd(2.0);
    let three = _mm256_set1_pd(3.0);
    let sign = _mm256_set1_pd(-0.0);
    let mut j = 0;
    while j < whole {
        // SAFETY: j + 4 <= n for `words` and `out`; `layer_pair` reads within the table.
        unsafe {
            let wp = words.as_ptr().add(j);
            let pair = |k: usize| _mm256_castpd128_pd256(layer_pair(table, wp.add(k)));
            let a = _mm256_insertf128_pd::<1>(pair(0), layer_pair(table, wp.add(2)));
            let b = _mm256_insertf128_pd::<1>(pair(1), layer_pair(table, wp.add(3)));
            let width = _mm256_unpacklo_pd(a, b);
            let core = _mm256_unpackhi_pd(a, b);
            let w = _mm256_loadu_si256(wp.cast());
            let bits = _mm256_or_si256(_mm256_srli_epi64::<12>(w), one);
            let u = _mm256_sub_pd(_mm256_mul_pd(two, _mm256_castsi256_pd(bits)), three);
            let x = _mm256_mul_pd(u, width);
            _mm256_storeu_pd(out.as_mut_ptr().add(j), x);
            let abs = _mm256_andnot_pd(sign, x);
            // not (|x| < core)
            let rejected = _mm256_cmp_pd::<_CMP_NLT_UQ>(abs, core);
            let mask = _mm256_movemask_pd(rejected) as u64;
            outside[j / 64] |= mask << (j % 64);
        }
        j += 4;
    }
    whole
}
