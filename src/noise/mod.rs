//! Noise realisations: per-realisation random streams and the normal generator.
//!
//! Every realisation draws its noise from its own `ChaCha8Rng`, keyed by
//! (study seed, condition index — or the index of the condition's draw group when
//! conditions share draws —, noise channel) with the realisation index as the ChaCha stream
//! (docs/model.md#streams). A realisation's numbers therefore depend on nothing but those
//! four integers: not on the thread count, chunking, shard split or order of execution, and
//! a study extended from R to 2R keeps its first R realisations bit for bit.
//!
//! The keystream is computed by [`ChaCha8Words`], the same generator as `rand_chacha`'s
//! `ChaCha8Rng` (tested word for word) but sixteen blocks per call on AVX-512 or AVX2.
//! Normals come from a 256-layer ziggurat (Marsaglia & Tsang 2000) run in blocks: one
//! 64-bit word per candidate in a vectorised, branch-free pass, then the rare rejections
//! (≈1 %) are resolved in order from the same stream. Every instruction-set path gives the
//! same bits. The mapping from stream to numbers is part of the study's identity and is
//! pinned by a value-stability test.

mod chacha;
mod streams;
mod tables;
mod ziggurat;

pub use chacha::ChaCha8Words;
pub use streams::Stream;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use tables::{ZIG_F, ZIG_R};
use ziggurat::{candidate, candidates, under_density};

/// Tag that separates chassis-mc keys from any other use of the same seed.
const KEY_TAG: &[u8; 8] = b"chassmc1";

/// The 256-bit ChaCha key of (seed, condition, stream) (docs/model.md#streams).
pub fn key(seed: u64, condition: u64, stream: Stream) -> [u8; 32] {
    let mut k = [0u8; 32];
    k[0..8].copy_from_slice(&seed.to_le_bytes());
    k[8..16].copy_from_slice(&condition.to_le_bytes());
    k[16..24].copy_from_slice(&stream.id().to_le_bytes());
    k[24..32].copy_from_slice(KEY_TAG);
    k
}

/// The random stream of one realisation: `rand_chacha`'s, the reference the engine's own
/// keystream is tested against.
pub fn stream(seed: u64, condition: u64, stream: Stream, realisation: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::from_seed(key(seed, condition, stream));
    rng.set_stream(realisation);
    rng
}

/// Number of normals generated per block; part of the stream → numbers mapping.
pub const BLOCK: usize = 256;

/// 2^-53 as an exact constant.
const TWO_POW_M53: f64 = 1.0 / (1u64 << 53) as f64;

/// Standard normal variates from a ChaCha8 stream, produced in blocks of [`BLOCK`].
#[derive(Debug, Clone)]
pub struct NormalStream {
    words: ChaCha8Words,
    /// Raw stream words of the current block, one per candidate.
    block: [u64; BLOCK],
}

impl NormalStream {
    /// Normals from the ChaCha8 keystream of `seed` on `stream` (the words of
    /// `ChaCha8Rng::from_seed(seed)` after `set_stream(stream)`).
    pub fn new(seed: [u8; 32], stream: u64) -> Self {
        NormalStream {
            words: ChaCha8Words::new(seed, stream),
            block: [0; BLOCK],
        }
    }

    /// The stream `stream` of (seed, condition, realisation).
    pub fn for_realisation(seed: u64, condition: u64, stream: Stream, realisation: u64) -> Self {
        Self::new(key(seed, condition, stream), realisation)
    }

    /// Fill `out` (at most [`BLOCK`] values) with independent N(0, 1) variates.
    ///
    /// One 64-bit word per candidate, in stream order; rejected candidates are then resolved
    /// in index order with further words. The values are a fixed function of the stream
    /// *and of the lengths requested*: callers that need reproducibility request the same
    /// lengths in the same order.
    #[inline]
    pub fn fill_block(&mut self, out: &mut [f64]) {
        let n = out.len();
        assert!(n <= BLOCK, "fill_block takes at most {BLOCK} values");
        self.words.fill(&mut self.block[..n]);
        // Branch-free, vectorised pass: every candidate, and a bit for each one outside its
        // layer's core.
        let mut outside = [0u64; BLOCK / 64];
        candidates(&self.block[..n], out, &mut outside);
        // Rare path (≈1 % of candidates), in index order: finish or redraw each reject.
        for (k, mut bits) in outside.into_iter().enumerate() {
            while bits != 0 {
                let j = 64 * k + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                out[j] = self.finish(self.block[j], out[j]);
            }
        }
    }

    /// Fill a slice of any length, block by block.
    pub fn fill(&mut self, out: &mut [f64]) {
        for chunk in out.chunks_mut(BLOCK) {
            self.fill_block(chunk);
        }
    }

    /// Fill `out` with independent U[0, 1) variates (53 bits each, one word per value) from
    /// the same stream.
    pub fn fill_uniform(&mut self, out: &mut [f64]) {
        for u in out.iter_mut() {
            *u = (self.words.next_u64() >> 11) as f64 * TWO_POW_M53;
        }
    }

    /// Resolve a candidate that fell outside its layer's core: accept it in the wedge,
    /// sample the tail, or redraw from fresh words until accepted.
    #[cold]
    fn finish(&mut self, mut word: u64, mut x: f64) -> f64 {
        loop {
            let layer = (word & 0xff) as usize;
            if layer == 0 {
                return self.tail(x < 0.0);
            }
            let y = ZIG_F[layer] + (ZIG_F[layer + 1] - ZIG_F[layer]) * self.open_uniform();
            if under_density(layer, x, y) {
                return x;
            }
            word = self.words.next_u64();
            let (next, inside) = candidate(word);
            if inside {
                return next;
            }
            x = next;
        }
    }

    /// Marsaglia's tail method beyond r.
    fn tail(&mut self, negative: bool) -> f64 {
        loop {
            let xx = -self.open_uniform().ln() / ZIG_R;
            let yy = -self.open_uniform().ln();
            if 2.0 * yy >= xx * xx {
                let z = ZIG_R + xx;
                return if negative { -z } else { z };
            }
        }
    }

    /// A uniform variate on the open interval (0, 1), 53 bits.
    fn open_uniform(&mut self) -> f64 {
        ((self.words.next_u64() >> 11) as f64 + 0.5) * TWO_POW_M53
    }
}

/// Normals of one stream read as a single sequence, whatever lengths are requested: the
/// stream is drawn in whole blocks of [`BLOCK`] (buffered), and a request takes the next
/// values. Readers of different lengths therefore read prefixes of the same sequence —
/// what conditions sharing one draw need (e.g. drive cycles of different lengths).
/// (A plain [`NormalStream`] read in shorter blocks gives other values: its rejections
/// draw from the words after each requested block.)
#[derive(Debug, Clone)]
pub struct NormalSequence {
    stream: NormalStream,
    block: [f64; BLOCK],
    /// Next unread value of `block` (`BLOCK` when empty).
    pos: usize,
}

impl NormalSequence {
    /// The sequence of stream `stream` of (seed, condition, realisation) (see [`key`]).
    pub fn for_realisation(seed: u64, condition: u64, stream: Stream, realisation: u64) -> Self {
        NormalSequence {
            stream: NormalStream::for_realisation(seed, condition, stream, realisation),
            block: [0.0; BLOCK],
            pos: BLOCK,
        }
    }

    /// The next `out.len()` values of the sequence.
    pub fn fill(&mut self, out: &mut [f64]) {
        let mut i = 0;
        while i < out.len() {
            if self.pos == BLOCK {
                if out.len() - i >= BLOCK {
                    self.stream.fill_block(&mut out[i..i + BLOCK]);
                    i += BLOCK;
                    continue;
                }
                self.stream.fill_block(&mut self.block);
                self.pos = 0;
            }
            let take = (BLOCK - self.pos).min(out.len() - i);
            out[i..i + take].copy_from_slice(&self.block[self.pos..self.pos + take]);
            self.pos += take;
            i += take;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::tables::ZIG_X;
    use super::ziggurat::{candidates_portable, squeeze};
    use super::*;

    #[test]
    fn vector_candidate_passes_equal_the_portable_one_bit_for_bit() {
        let mut words = [0u64; BLOCK];
        ChaCha8Words::new([9; 32], 3).fill(&mut words);
        // Word i in layer i, so every layer's table pair is read.
        for (i, w) in words.iter_mut().enumerate() {
            *w = (*w & !0xff) | i as u64;
        }
        // A few words that land exactly on layer and sign edge cases.
        words[0] = 0;
        words[1] = u64::MAX;
        words[2] = 0xff;
        words[3] = 1 << 63;
        for n in [BLOCK, BLOCK - 3, 5] {
            let (mut x0, mut b0) = ([0.0; BLOCK], [0u64; BLOCK / 64]);
            candidates_portable(0, &words[..n], &mut x0[..n], &mut b0);
            let (mut x1, mut b1) = ([0.0; BLOCK], [0u64; BLOCK / 64]);
            candidates(&words[..n], &mut x1[..n], &mut b1);
            assert_eq!(x0.map(f64::to_bits), x1.map(f64::to_bits));
            assert_eq!(b0, b1);
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") {
                let (mut x2, mut b2) = ([0.0; BLOCK], [0u64; BLOCK / 64]);
                // SAFETY: AVX2 checked above.
                let done = unsafe {
                    crate::numeric::simd::ziggurat_candidates_4(
                        &ZIG_X,
                        &words[..n],
                        &mut x2[..n],
                        &mut b2,
                    )
                };
                candidates_portable(done, &words[..n], &mut x2[..n], &mut b2);
                assert_eq!(x0.map(f64::to_bits), x2.map(f64::to_bits));
                assert_eq!(b0, b2);
            }
        }
    }

    #[test]
    fn a_sequence_is_the_same_whatever_lengths_are_read() {
        let mut whole = NormalSequence::for_realisation(3, 1, crate::noise::Stream::Channel(2), 5);
        let mut expected = vec![0.0; 1000];
        whole.fill(&mut expected);
        for lengths in [&[1000][..], &[1, 255, 256, 300, 188], &[97, 97, 97, 709]] {
            let mut s = NormalSequence::for_realisation(3, 1, crate::noise::Stream::Channel(2), 5);
            let mut got = Vec::new();
            for &n in lengths {
                let mut part = vec![0.0; n];
                s.fill(&mut part);
                got.extend(part);
            }
            assert_eq!(got, expected, "{lengths:?}");
        }
        // and it is the stream's whole blocks
        let mut stream = NormalStream::for_realisation(3, 1, crate::noise::Stream::Channel(2), 5);
        let mut blocks = vec![0.0; 4 * BLOCK];
        for b in blocks.chunks_mut(BLOCK) {
            stream.fill_block(b);
        }
        assert_eq!(blocks[..1000], expected[..]);
    }

    #[test]
    fn the_squeeze_decides_as_exp_does() {
        // Every layer with a wedge. Each candidate (the layer's edges among them) is tried
        // with a height spread over the layer and with one within 1e-9 relative of the
        // density (where a wrong bound would show).
        let mut words = ChaCha8Words::new([5; 32], 1);
        let mut unit = || (words.next_u64() >> 11) as f64 * TWO_POW_M53;
        let (mut decided, mut near_decided, mut total) = (0u32, 0u32, 0u32);
        for layer in 1..256 {
            let (x0, x1) = (ZIG_X[layer], ZIG_X[layer + 1]);
            for k in 0..2000 {
                let a = match k {
                    0 | 2 => x0,
                    1 | 3 => x1,
                    _ => x1 + (x0 - x1) * unit(),
                };
                let x = if k % 2 == 0 { a } else { -a };
                let f = (-0.5 * x * x).exp();
                let spread = ZIG_F[layer] + (ZIG_F[layer + 1] - ZIG_F[layer]) * unit();
                let near = f * (1.0 + (unit() - 0.5) * 1e-9);
                for (y, is_near) in [(spread, false), (near, true)] {
                    let want = y < f;
                    assert_eq!(
                        under_density(layer, x, y),
                        want,
                        "layer {layer}, x {x}, y {y}"
                    );
                    let by_bounds = squeeze(layer, x, y);
                    if let Some(d) = by_bounds {
                        assert_eq!(d, want, "squeeze: layer {layer}, x {x}, y {y}");
                    }
                    total += 1;
                    decided += u32::from(by_bounds.is_some());
                    near_decided += u32::from(is_near && by_bounds.is_some());
                }
            }
        }
        // The bounds settle most spread heights (half of all cases) and some near ones.
        assert!(
            decided > total * 4 / 10,
            "bounds decided {decided} of {total}"
        );
        assert!(
            near_decided > 0,
            "no height within 1e-9 of the density was decided"
        );
    }

    #[test]
    fn keys_differ_by_seed_condition_and_channel() {
        let a = key(1, 2, Stream::Channel(1));
        assert_ne!(a, key(2, 2, Stream::Channel(1)));
        assert_ne!(a, key(1, 3, Stream::Channel(1)));
        assert_ne!(a, key(1, 2, Stream::Channel(2)));
    }

    #[test]
    fn streams_are_independent_of_how_they_are_created() {
        let mut a = NormalStream::for_realisation(7, 1, crate::noise::Stream::Channel(1), 42);
        let mut b = NormalStream::for_realisation(7, 1, crate::noise::Stream::Channel(1), 42);
        let mut x = [0.0; 300];
        let mut y = [0.0; 300];
        a.fill(&mut x);
        b.fill(&mut y);
        assert_eq!(x, y);
        let mut c = NormalStream::for_realisation(7, 1, crate::noise::Stream::Channel(1), 43);
        c.fill(&mut y);
        assert_ne!(x, y);
    }
}
