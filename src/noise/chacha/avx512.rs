//! ChaCha8 on sixteen blocks at once: one block per 32-bit lane of a 512-bit register.

use std::arch::x86_64::*;

use super::{BLOCK_WORDS, BLOCKS_PER_CALL, DOUBLE_ROUNDS, WORDS_PER_CALL, initial_state};

#[inline]
#[target_feature(enable = "avx512f")]
fn quarter_round(x: &mut [__m512i; BLOCK_WORDS], (a, b, c, d): (usize, usize, usize, usize)) {
    x[a] = _mm512_add_epi32(x[a], x[b]);
    x[d] = _mm512_rol_epi32::<16>(_mm512_xor_si512(x[d], x[a]));
    x[c] = _mm512_add_epi32(x[c], x[d]);
    x[b] = _mm512_rol_epi32::<12>(_mm512_xor_si512(x[b], x[c]));
    x[a] = _mm512_add_epi32(x[a], x[b]);
    x[d] = _mm512_rol_epi32::<8>(_mm512_xor_si512(x[d], x[a]));
    x[c] = _mm512_add_epi32(x[c], x[d]);
    x[b] = _mm512_rol_epi32::<7>(_mm512_xor_si512(x[b], x[c]));
}

#[target_feature(enable = "avx512f")]
pub(super) fn blocks(key: &[u32; 8], stream: u64, counter: u64, out: &mut [u64; WORDS_PER_CALL]) {
    const L: usize = BLOCKS_PER_CALL;
    let state = initial_state::<L>(key, stream, counter);
    // SAFETY: each row is an array of 16 u32.
    let init: [__m512i; BLOCK_WORDS] =
        std::array::from_fn(|k| unsafe { _mm512_loadu_si512(state[k].as_ptr().cast()) });
    let mut x = init;
    for _ in 0..DOUBLE_ROUNDS {
        quarter_round(&mut x, (0, 4, 8, 12));
        quarter_round(&mut x, (1, 5, 9, 13));
        quarter_round(&mut x, (2, 6, 10, 14));
        quarter_round(&mut x, (3, 7, 11, 15));
        quarter_round(&mut x, (0, 5, 10, 15));
        quarter_round(&mut x, (1, 6, 11, 12));
        quarter_round(&mut x, (2, 7, 8, 13));
        quarter_round(&mut x, (3, 4, 9, 14));
    }
    let v: [__m512i; BLOCK_WORDS] = std::array::from_fn(|k| _mm512_add_epi32(x[k], init[k]));
    // Word j of block b is state words 2j (low half) and 2j + 1 (high half) of lane b:
    // unpacking the pairs gives, per j, word j of blocks 0 1 4 5 8 9 12 13 (`lo`) and
    // of blocks 2 3 6 7 10 11 14 15 (`hi`); an 8 × 8 transpose of each set then gives
    // each block's eight words in order, stored straight into `out` (the same words
    // as `interleave`, in registers).
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
