//! ChaCha's block function in AVX2 and AVX-512 registers (docs in the parent module).

use std::arch::x86_64::*;

use super::chacha_state;

#[inline]
#[target_feature(enable = "avx2")]
fn rotl_8<const L: i32, const R: i32>(x: __m256i) -> __m256i {
    _mm256_or_si256(_mm256_slli_epi32::<L>(x), _mm256_srli_epi32::<R>(x))
}

#[inline]
#[target_feature(enable = "avx2")]
fn quarter_round_8(
    x: &mut [__m256i; 16],
    (a, b, c, d): (usize, usize, usize, usize),
    rot16: __m256i,
    rot8: __m256i,
) {
    x[a] = _mm256_add_epi32(x[a], x[b]);
    x[d] = _mm256_shuffle_epi8(_mm256_xor_si256(x[d], x[a]), rot16);
    x[c] = _mm256_add_epi32(x[c], x[d]);
    x[b] = rotl_8::<12, 20>(_mm256_xor_si256(x[b], x[c]));
    x[a] = _mm256_add_epi32(x[a], x[b]);
    x[d] = _mm256_shuffle_epi8(_mm256_xor_si256(x[d], x[a]), rot8);
    x[c] = _mm256_add_epi32(x[c], x[d]);
    x[b] = rotl_8::<7, 25>(_mm256_xor_si256(x[b], x[c]));
}

/// ChaCha on eight blocks at once, one block per 32-bit lane of a 256-bit register: the
/// blocks of `key` and `nonce` with counters `counter .. counter + 8` ([`chacha_state`]),
/// `ROUNDS2` double rounds, the initial state added, and each block written to `out` in
/// order as eight little-endian 64-bit words (word j of a block is its state words 2j, the
/// low half, and 2j + 1).
///
/// # Safety
/// The CPU supports AVX2 ([`crate::numeric::simd::avx2`]).
#[target_feature(enable = "avx2")]
pub fn chacha_blocks_8<const ROUNDS2: usize>(
    key: &[u32; 8],
    counter: u64,
    nonce: u64,
    out: &mut [u64; 64],
) {
    // Byte shuffles rotating each 32-bit lane left by 16 and by 8.
    let rot16 = _mm256_setr_epi8(
        2, 3, 0, 1, 6, 7, 4, 5, 10, 11, 8, 9, 14, 15, 12, 13, 2, 3, 0, 1, 6, 7, 4, 5, 10, 11, 8, 9,
        14, 15, 12, 13,
    );
    let rot8 = _mm256_setr_epi8(
        3, 0, 1, 2, 7, 4, 5, 6, 11, 8, 9, 10, 15, 12, 13, 14, 3, 0, 1, 2, 7, 4, 5, 6, 11, 8, 9, 10,
        15, 12, 13, 14,
    );
    let state = chacha_state::<8>(key, counter, nonce);
    // SAFETY: each row is an array of 8 u32.
    let init: [__m256i; 16] =
        std::array::from_fn(|k| unsafe { _mm256_loadu_si256(state[k].as_ptr().cast()) });
    let mut x = init;
    for _ in 0..ROUNDS2 {
        quarter_round_8(&mut x, (0, 4, 8, 12), rot16, rot8);
        quarter_round_8(&mut x, (1, 5, 9, 13), rot16, rot8);
        quarter_round_8(&mut x, (2, 6, 10, 14), rot16, rot8);
        quarter_round_8(&mut x, (3, 7, 11, 15), rot16, rot8);
        quarter_round_8(&mut x, (0, 5, 10, 15), rot16, rot8);
        quarter_round_8(&mut x, (1, 6, 11, 12), rot16, rot8);
        quarter_round_8(&mut x, (2, 7, 8, 13), rot16, rot8);
        quarter_round_8(&mut x, (3, 4, 9, 14), rot16, rot8);
    }
    let v: [__m256i; 16] = std::array::from_fn(|k| _mm256_add_epi32(x[k], init[k]));
    // As on AVX-512: unpacking state words 2j and 2j + 1 gives word j of blocks 0 1 4 5
    // (`lo`) and 2 3 6 7 (`hi`); 4 × 4 transposes of words 0–3 and 4–7 of each set give
    // each block's words in order.
    let lo: [__m256i; 8] = std::array::from_fn(|j| _mm256_unpacklo_epi32(v[2 * j], v[2 * j + 1]));
    let hi: [__m256i; 8] = std::array::from_fn(|j| _mm256_unpackhi_epi32(v[2 * j], v[2 * j + 1]));
    for (set, blocks) in [(lo, [0, 1, 4, 5]), (hi, [2, 3, 6, 7])] {
        for half in 0..2 {
            let rows = transpose4([0, 1, 2, 3].map(|j| set[4 * half + j]));
            for (row, block) in rows.into_iter().zip(blocks) {
                // SAFETY: block < 8 and half < 2, so the four words lie within `out`.
                unsafe {
                    _mm256_storeu_si256(out.as_mut_ptr().add(8 * block + 4 * half).cast(), row)
                };
            }
        }
    }
}

/// The 4 × 4 transpose of 64-bit elements: row i of the result holds element i of
/// every input row.
#[inline]
#[target_feature(enable = "avx2")]
fn transpose4(r: [__m256i; 4]) -> [__m256i; 4] {
    let t0 = _mm256_unpacklo_epi64(r[0], r[1]); // r0[0] r1[0] r0[2] r1[2]
    let t1 = _mm256_unpackhi_epi64(r[0], r[1]); // r0[1] r1[1] r0[3] r1[3]
    let t2 = _mm256_unpacklo_epi64(r[2], r[3]);
    let t3 = _mm256_unpackhi_epi64(r[2], r[3]);
    [
        _mm256_permute2x128_si256::<0x20>(t0, t2),
        _mm256_permute2x128_si256::<0x20>(t1, t3),
        _mm256_permute2x128_si256::<0x31>(t0, t2),
        _mm256_permute2x128_si256::<0x31>(t1, t3),
    ]
}

#[inline]
#[target_feature(enable = "avx512f")]
fn quarter_round_16(x: &mut [__m512i; 16], (a, b, c, d): (usize, usize, usize, usize)) {
    x[a] = _mm512_add_epi32(x[a], x[b]);
    x[d] = _mm512_rol_epi32::<16>(_mm512_xor_si512(x[d], x[a]));
    x[c] = _mm512_add_epi32(x[c], x[d]);
    x[b] = _mm512_rol_epi32::<12>(_mm512_xor_si512(x[b], x[c]));
    x[a] = _mm512_add_epi32(x[a], x[b]);
    x[d] = _mm512_rol_epi32::<8>(_mm512_xor_si512(x[d], x[a]));
    x[c] = _mm512_add_epi32(x[c], x[d]);
    x[b] = _mm512_rol_epi32::<7>(_mm512_xor_si512(x[b], x[c]));
}

/// ChaCha on sixteen blocks at once, one block per 32-bit lane of a 512-bit register: as
/// [`chacha_blocks_8`], with counters `counter .. counter + 16`.
///
/// # Safety
/// The CPU supports AVX-512F ([`crate::numeric::simd::avx512f`]).
#[target_feature(enable = "avx512f")]
pub fn chacha_blocks_16<const ROUNDS2: usize>(
    key: &[u32; 8],
    counter: u64,
    nonce: u64,
    out: &mut [u64; 128],
) {
    let state = chacha_state::<16>(key, counter, nonce);
    // SAFETY: each row is an array of 16 u32.
    let init: [__m512i; 16] =
        std::array::from_fn(|k| unsafe { _mm512_loadu_si512(state[k].as_ptr().cast()) });
    let mut x = init;
    for _ in 0..ROUNDS2 {
        quarter_round_16(&mut x, (0, 4, 8, 12));
        quarter_round_16(&mut x, (1, 5, 9, 13));
        quarter_round_16(&mut x, (2, 6, 10, 14));
        quarter_round_16(&mut x, (3, 7, 11, 15));
        quarter_round_16(&mut x, (0, 5, 10, 15));
        quarter_round_16(&mut x, (1, 6, 11, 12));
        quarter_round_16(&mut x, (2, 7, 8, 13));
        quarter_round_16(&mut x, (3, 4, 9, 14));
    }
    let v: [__m512i; 16] = std::array::from_fn(|k| _mm512_add_epi32(x[k], init[k]));
    // Word j of block b is state words 2j (low half) and 2j + 1 (high half) of lane b:
    // unpacking the pairs gives, per j, word j of blocks 0 1 4 5 8 9 12 13 (`lo`) and
    // of blocks 2 3 6 7 10 11 14 15 (`hi`); an 8 × 8 transpose of each set then gives
    // each block's eight words in order, stored straight into `out`.
    let lo: [__m512i; 8] = std::array::from_fn(|j| _mm512_unpacklo_epi32(v[2 * j], v[2 * j + 1]));
    let hi: [__m512i; 8] = std::array::from_fn(|j| _mm512_unpackhi_epi32(v[2 * j], v[2 * j + 1]));
    for (set, blocks) in [
        (lo, [0, 1, 4, 5, 8, 9, 12, 13]),
        (hi, [2, 3, 6, 7, 10, 11, 14, 15]),
    ] {
        let rows = transpose8(set);
        for (row, block) in rows.into_iter().zip(blocks) {
            // SAFETY: block < 16, so words 8·block … 8·block + 7 lie within `out`.
            unsafe { _mm512_storeu_si512(out.as_mut_ptr().add(8 * block).cast(), row) };
        }
    }
}

/// The 8 × 8 transpose of 64-bit elements: row i of the result holds element i of
/// every input row.
#[inline]
#[target_feature(enable = "avx512f")]
fn transpose8(r: [__m512i; 8]) -> [__m512i; 8] {
    // [r_a[0], r_b[0], r_a[2], r_b[2], …] and [r_a[1], r_b[1], r_a[3], r_b[3], …]
    let t: [__m512i; 8] = std::array::from_fn(|k| {
        let (a, b) = (r[k & !1], r[k | 1]);
        if k % 2 == 0 {
            _mm512_unpacklo_epi64(a, b)
        } else {
            _mm512_unpackhi_epi64(a, b)
        }
    });
    // 128-bit lanes (0, 2) or (1, 3) of each of two vectors
    let even = |a, b| _mm512_shuffle_i64x2::<0x88>(a, b);
    let odd = |a, b| _mm512_shuffle_i64x2::<0xdd>(a, b);
    let (s0, s2) = (even(t[0], t[2]), odd(t[0], t[2]));
    let (s4, s6) = (even(t[4], t[6]), odd(t[4], t[6]));
    let (s1, s3) = (even(t[1], t[3]), odd(t[1], t[3]));
    let (s5, s7) = (even(t[5], t[7]), odd(t[5], t[7]));
    [
        even(s0, s4),
        even(s1, s5),
        even(s2, s6),
        even(s3, s7),
        odd(s0, s4),
        odd(s1, s5),
        odd(s2, s6),
        odd(s3, s7),
    ]
}
