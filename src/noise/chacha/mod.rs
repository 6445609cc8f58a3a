//! The ChaCha8 keystream as 64-bit words, sixteen blocks at a time.
//!
//! This is the same generator as `rand_chacha::ChaCha8Rng` — same key, stream (nonce) and
//! block-counter layout, same word order — verified word for word against it in the tests
//! below. It exists because the Monte Carlo kernel is bound by random-number generation:
//! computing sixteen blocks per call, one block per 32-bit lane (one 512-bit pass on
//! AVX-512, two 256-bit passes on AVX2, portable code the compiler vectorises otherwise), and
//! writing the words straight into the caller's buffer is markedly faster than
//! `rand_chacha`'s four-block refill plus a byte copy.
//!
//! The block layout (64-bit counter, the stream as the nonce) and the vector passes are in
//! `numeric::simd` ([`chacha_state`](crate::numeric::simd::chacha_state)); the dispatch and
//! the portable pass are here.

/// Blocks computed by one pass of the portable and AVX2 code (one per 32-bit lane).
const LANES: usize = 8;
/// Blocks per call: two 8-lane passes, or one 16-lane AVX-512 pass.
const BLOCKS_PER_CALL: usize = 16;
/// 32-bit words per ChaCha block.
const BLOCK_WORDS: usize = 16;
/// 64-bit output words per call (16 blocks × 16 u32 / 2).
pub const WORDS_PER_CALL: usize = BLOCKS_PER_CALL * BLOCK_WORDS / 2;
/// 64-bit output words per 8-lane pass.
const WORDS_PER_PASS: usize = LANES * BLOCK_WORDS / 2;
/// ChaCha8: four double rounds.
const DOUBLE_ROUNDS: usize = 4;

type Lanes = [u32; LANES];

/// A ChaCha8 keystream positioned at a block boundary, read as little-endian u64 words.
#[derive(Clone)]
pub struct ChaCha8Words {
    key: [u32; 8],
    stream: u64,
    /// Counter of the next block to compute.
    counter: u64,
    buffer: [u64; WORDS_PER_CALL],
    /// Next unread word of `buffer` (`WORDS_PER_CALL` when empty).
    pos: usize,
}

impl std::fmt::Debug for ChaCha8Words {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ChaCha8Words")
            .field("stream", &self.stream)
            .field("counter", &self.counter)
            .finish_non_exhaustive()
    }
}

impl ChaCha8Words {
    /// The keystream of `seed` (the 256-bit key) on stream `stream`, from block 0; the same
    /// words as `ChaCha8Rng::from_seed(seed)` after `set_stream(stream)`.
    pub fn new(seed: [u8; 32], stream: u64) -> Self {
        let key = std::array::from_fn(|i| {
            u32::from_le_bytes(seed[4 * i..4 * i + 4].try_into().expect("4 bytes"))
        });
        ChaCha8Words {
            key,
            stream,
            counter: 0,
            buffer: [0; WORDS_PER_CALL],
            pos: WORDS_PER_CALL,
        }
    }

    /// Start at block `counter` instead of 0 (for tests of the counter's carry).
    #[cfg(test)]
    fn at_block(mut self, counter: u64) -> Self {
        self.counter = counter;
        self.pos = WORDS_PER_CALL;
        self
    }

    /// The next word.
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        if self.pos == WORDS_PER_CALL {
            self.refill();
        }
        let w = self.buffer[self.pos];
        self.pos += 1;
        w
    }

    /// Fill `out` with the next words, computing whole calls straight into it when the
    /// buffer is empty.
    #[inline]
    pub fn fill(&mut self, out: &mut [u64]) {
        let mut i = 0;
        while i < out.len() {
            if self.pos == WORDS_PER_CALL {
                if out.len() - i >= WORDS_PER_CALL {
                    let chunk: &mut [u64; WORDS_PER_CALL] = (&mut out[i..i + WORDS_PER_CALL])
                        .try_into()
                        .expect("chunk length");
                    self.generate(chunk);
                    i += WORDS_PER_CALL;
                    continue;
                }
                self.refill();
            }
            let take = (WORDS_PER_CALL - self.pos).min(out.len() - i);
            out[i..i + take].copy_from_slice(&self.buffer[self.pos..self.pos + take]);
            self.pos += take;
            i += take;
        }
    }

    /// Compute the next sixteen blocks into `out`.
    #[inline]
    fn generate(&mut self, out: &mut [u64; WORDS_PER_CALL]) {
        blocks(&self.key, self.stream, self.counter, out);
        self.counter = self.counter.wrapping_add(BLOCKS_PER_CALL as u64);
    }

    /// The next call's words into the buffer.
    #[inline]
    fn refill(&mut self) {
        blocks(&self.key, self.stream, self.counter, &mut self.buffer);
        self.counter = self.counter.wrapping_add(BLOCKS_PER_CALL as u64);
        self.pos = 0;
    }
}

/// Sixteen blocks with counters `counter .. counter + 16`: explicit AVX-512 or AVX2 code
/// when the CPU has it, else the portable lane-array code (integer arithmetic: identical
/// results on every path).
fn blocks(key: &[u32; 8], stream: u64, counter: u64, out: &mut [u64; WORDS_PER_CALL]) {
    #[cfg(target_arch = "x86_64")]
    {
        use crate::numeric::simd;
        if simd::avx512f() {
            // SAFETY: the CPU supports AVX-512F, checked just above.
            return unsafe { simd::chacha_blocks_16::<DOUBLE_ROUNDS>(key, counter, stream, out) };
        }
        if simd::avx2() {
            for (pass, chunk) in out.chunks_exact_mut(WORDS_PER_PASS).enumerate() {
                let chunk = chunk.try_into().expect("pass length");
                let start = counter.wrapping_add((pass * LANES) as u64);
                // SAFETY: the CPU supports AVX2, checked just above.
                unsafe { simd::chacha_blocks_8::<DOUBLE_ROUNDS>(key, start, stream, chunk) };
            }
            return;
        }
    }
    blocks_portable(key, stream, counter, out)
}

/// The portable path: two eight-lane passes.
fn blocks_portable(key: &[u32; 8], stream: u64, counter: u64, out: &mut [u64; WORDS_PER_CALL]) {
    for (pass, chunk) in out.chunks_exact_mut(WORDS_PER_PASS).enumerate() {
        let chunk = chunk.try_into().expect("pass length");
        blocks_body(
            key,
            stream,
            counter.wrapping_add((pass * LANES) as u64),
            chunk,
        );
    }
}

/// Blocks in order, each as eight little-endian 64-bit words: word j of block `lane` is
/// state words 2j (low half) and 2j + 1 (high half) of that block.
#[inline(always)]
fn interleave<const L: usize>(words: &[[u32; L]; BLOCK_WORDS], out: &mut [u64]) {
    for lane in 0..L {
        for j in 0..BLOCK_WORDS / 2 {
            out[lane * BLOCK_WORDS / 2 + j] =
                u64::from(words[2 * j][lane]) | (u64::from(words[2 * j + 1][lane]) << 32);
        }
    }
}

#[inline(always)]
fn add(a: Lanes, b: Lanes) -> Lanes {
    std::array::from_fn(|i| a[i].wrapping_add(b[i]))
}

#[inline(always)]
fn xor_rotl(a: Lanes, b: Lanes, r: u32) -> Lanes {
    std::array::from_fn(|i| (a[i] ^ b[i]).rotate_left(r))
}

#[inline(always)]
fn quarter_round(x: &mut [Lanes; BLOCK_WORDS], a: usize, b: usize, c: usize, d: usize) {
    x[a] = add(x[a], x[b]);
    x[d] = xor_rotl(x[d], x[a], 16);
    x[c] = add(x[c], x[d]);
    x[b] = xor_rotl(x[b], x[c], 12);
    x[a] = add(x[a], x[b]);
    x[d] = xor_rotl(x[d], x[a], 8);
    x[c] = add(x[c], x[d]);
    x[b] = xor_rotl(x[b], x[c], 7);
}

#[inline(always)]
fn blocks_body(key: &[u32; 8], stream: u64, counter: u64, out: &mut [u64; WORDS_PER_PASS]) {
    let init = crate::numeric::simd::chacha_state::<LANES>(key, counter, stream);
    let mut x = init;
    for _ in 0..DOUBLE_ROUNDS {
        quarter_round(&mut x, 0, 4, 8, 12);
        quarter_round(&mut x, 1, 5, 9, 13);
        quarter_round(&mut x, 2, 6, 10, 14);
        quarter_round(&mut x, 3, 7, 11, 15);
        quarter_round(&mut x, 0, 5, 10, 15);
        quarter_round(&mut x, 1, 6, 11, 12);
        quarter_round(&mut x, 2, 7, 8, 13);
        quarter_round(&mut x, 3, 4, 9, 14);
    }
    for k in 0..BLOCK_WORDS {
        x[k] = add(x[k], init[k]);
    }
    interleave(&x, out);
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn seed(i: u8) -> [u8; 32] {
        std::array::from_fn(|k| (k as u8).wrapping_mul(29).wrapping_add(i))
    }

    #[test]
    fn words_equal_rand_chacha_chacha8() {
        for (s, stream) in [(0u8, 0u64), (1, 1), (7, 42), (200, u64::MAX)] {
            let mut reference = ChaCha8Rng::from_seed(seed(s));
            reference.set_stream(stream);
            let mut ours = ChaCha8Words::new(seed(s), stream);
            // Mixed access: single words and bulk fills of awkward lengths.
            let mut got = Vec::new();
            for len in [1usize, 63, 64, 65, 200, 1, 1000, 3] {
                let mut buf = vec![0; len];
                ours.fill(&mut buf);
                got.extend(buf);
                got.push(ours.next_u64());
            }
            let want: Vec<u64> = (0..got.len()).map(|_| reference.next_u64()).collect();
            assert_eq!(got, want, "seed {s}, stream {stream}");
        }
    }

    #[test]
    fn every_instruction_set_path_gives_the_same_blocks() {
        let key = [1, 2, 3, 4, 5, 6, 7, 0xffff_ffff];
        for counter in [0u64, 5, (1 << 32) - 7] {
            let mut portable = [0; WORDS_PER_CALL];
            blocks_portable(&key, 77, counter, &mut portable);
            let mut dispatched = [0; WORDS_PER_CALL];
            blocks(&key, 77, counter, &mut dispatched);
            assert_eq!(portable, dispatched);
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") {
                let mut two = [0; WORDS_PER_CALL];
                for (pass, chunk) in two.chunks_exact_mut(WORDS_PER_PASS).enumerate() {
                    let chunk = chunk.try_into().unwrap();
                    let start = counter + (pass * LANES) as u64;
                    // SAFETY: AVX2 checked above.
                    unsafe {
                        crate::numeric::simd::chacha_blocks_8::<DOUBLE_ROUNDS>(
                            &key, start, 77, chunk,
                        )
                    };
                }
                assert_eq!(portable, two);
            }
        }
    }

    #[test]
    fn the_block_counter_carries_into_its_high_word() {
        let start = (1u64 << 32) - 3; // blocks straddle the 32-bit boundary
        let mut reference = ChaCha8Rng::from_seed(seed(3));
        reference.set_stream(9);
        reference.set_word_pos(u128::from(start) * 16);
        let mut ours = ChaCha8Words::new(seed(3), 9).at_block(start);
        let mut got = vec![0; 200];
        ours.fill(&mut got);
        let want: Vec<u64> = (0..200).map(|_| reference.next_u64()).collect();
        assert_eq!(got, want);
    }
}
