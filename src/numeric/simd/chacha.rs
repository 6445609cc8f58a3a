//! ChaCha's block function on 32-bit lanes: the initial state of consecutive blocks, one
//! per lane ([`chacha_state`], portable, for every path), and the block function on eight
//! blocks per AVX2 pass and sixteen per AVX-512 pass, the number of double rounds a
//! parameter. The keystream and its portable code are in `noise::chacha`, which tests these
//! word for word against it and against `rand_chacha`.
//!
//! Block layout (RFC 7539 numbering, 64-bit counter as in Bernstein's original):
//!
//! ```text
//! "expa" "nd 3" "2-by" "te k"
//! key0   key1   key2   key3
//! key4   key5   key6   key7
//! ctr_lo ctr_hi nonce_lo nonce_hi
//! ```

#[cfg(target_arch = "x86_64")]
mod x86_64;
#[cfg(target_arch = "x86_64")]
pub use x86_64::{chacha_blocks_8, chacha_blocks_16};

/// "expand 32-byte k".
const SIGMA: [u32; 4] = [0x6170_7865, 0x3320_646e, 0x7962_2d32, 0x6b20_6574];

/// The initial state of `L` blocks of `key` and `nonce` with counters `counter .. counter +
/// L`, one row per state word and one column per block (the layout every path computes
/// on).
#[inline(always)]
pub fn chacha_state<const L: usize>(key: &[u32; 8], counter: u64, nonce: u64) -> [[u32; L]; 16] {
    let mut x = [[0u32; L]; 16];
    for (k, &c) in SIGMA.iter().enumerate() {
        x[k] = [c; L];
    }
    for (k, &w) in key.iter().enumerate() {
        x[4 + k] = [w; L];
    }
    x[12] = std::array::from_fn(|i| counter.wrapping_add(i as u64) as u32);
    x[13] = std::array::from_fn(|i| (counter.wrapping_add(i as u64) >> 32) as u32);
    x[14] = [nonce as u32; L];
    x[15] = [(nonce >> 32) as u32; L];
    x
}
