//! ChaCha8 on eight blocks at once: one block per 32-bit lane of a 256-bit register.

use std::arch::x86_64::*;

use super::{BLOCK_WORDS, DOUBLE_ROUNDS, LANES, WORDS_PER_PASS, initial_state};

#[inline]
#[target_feature(enable = "avx2")]
fn rotl<const L: i32, const R: i32>(x: __m256i) -> __m256i {
    _mm256_or_si256(_mm256_slli_epi32::<L>(x), _mm256_srli_epi32::<R>(x))
}

#[inline]
#[target_feature(enable = "avx2")]
fn quarter_round(
    x: &mut [__m256i; BLOCK_WORDS],
    (a, b, c, d): (usize, usize, usize, usize),
    rot16: __m256i,
    rot8: __m256i,
) {
    x[a] = _mm256_add_epi32(x[a], x[b]);
    x[d] = _mm256_shuffle_epi8(_mm256_xor_si256(x[d], x[a]), rot16);
    x[c] = _mm256_add_epi32(x[c], x[d]);
    x[b] = rotl::<12, 20>(_mm256_xor_si256(x[b], x[c]));
    x[a] = _mm256_add_epi32(x[a], x[b]);
    x[d] = _mm256_shuffle_epi8(_mm256_xor_si256(x[d], x[a]), rot8);
    x[c] = _mm256_add_epi32(x[c], x[d]);
    x[b] = rotl::<7, 25>(_mm256_xor_si256(x[b], x[c]));
}

#[target_feature(enable = "avx2")]
pub(super) fn blocks(key: &[u32; 8], stream: u64, counter: u64, out: &mut [u64; WORDS_PER_PASS]) {
    // Byte shuffles rotating each 32-bit lane left by 16 and by 8.
    let rot16 = _mm256_setr_epi8(
        2, 3, 0, 1, 6, 7, 4, 5, 10, 11, 8, 9, 14, 15, 12, 13, 2, 3, 0, 1, 6, 7, 4, 5, 10, 11, 8, 9,
        14, 15, 12, 13,
    );
    let rot8 = _mm256_setr_epi8(
        3, 0, 1, 2, 7, 4, 5, 6, 11, 8, 9, 10, 15, 12, 13, 14, 3, 0, 1, 2, 7, 4, 5, 6, 11, 8, 9, 10,
        15, 12, 13, 14,
    );
    let state = initial_state::<LANES>(key, stream, counter);
    // SAFETY: each row is an array of 8 u32.
    let init: [__m256i; BLOCK_WORDS] =
        std::array::from_fn(|k| unsafe { _mm256_loadu_si256(state[k].as_ptr().cast()) });
    let mut x = init;
    for _ in 0..DOUBLE_ROUNDS {
        quarter_round(&mut x, (0, 4, 8, 12), rot16, rot8);
        quarter_round(&mut x, (1, 5, 9, 13), rot16, rot8);
        quarter_round(&mut x, (2, 6, 10, 14), rot16, rot8);
        quarter_round(&mut x, (3, 7, 11, 15), rot16, rot8);
        quarter_round(&mut x, (0, 5, 10, 15), rot16, rot8);
        quarter_round(&mut x, (1, 6, 11, 12), rot16, rot8);
        quarter_round(&mut x, (2, 7, 8, 13), rot16, rot8);
        quarter_round(&mut x, (3, 4, 9, 14), rot16, rot8);
    }
    let v: [__m256i; BLOCK_WORDS] = std::array::from_fn(|k| _mm256_add_epi32(x[k], init[k]));
    // As on AVX-512: unpacking state words 2j and 2j + 1 gives word j of blocks 0 1 4 5
    // (`lo`) and 2 3 6 7 (`hi`); 4 × 4 transposes of words 0–3 and 4–7 of each set give
    // each block's words in order (the same words as `interleave`).
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
