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
mod tables;

pub use chacha::ChaCha8Words;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use tables::{ZIG_F, ZIG_R, ZIG_X};

/// Tag that separates chassis-mc keys from any other use of the same seed.
const KEY_TAG: &[u8; 8] = b"chassmc1";

/// The 256-bit ChaCha key of (seed, condition, channel). `channel` names the noise source
/// within a model (each model numbers its own; see e.g. the vehicle model's channels).
pub fn key(seed: u64, condition: u64, channel: u64) -> [u8; 32] {
    let mut k = [0u8; 32];
    k[0..8].copy_from_slice(&seed.to_le_bytes());
    k[8..16].copy_from_slice(&condition.to_le_bytes());
    k[16..24].copy_from_slice(&channel.to_le_bytes());
    k[24..32].copy_from_slice(KEY_TAG);
    k
}

/// The random stream of one realisation on one channel.
pub fn stream(seed: u64, condition: u64, channel: u64, realisation: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::from_seed(key(seed, condition, channel));
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

    /// The stream of (seed, condition, channel, realisation).
    pub fn for_realisation(seed: u64, condition: u64, channel: u64, realisation: u64) -> Self {
        Self::new(key(seed, condition, channel), realisation)
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
    /// The sequence of (seed, condition, channel, realisation) (see [`key`]).
    pub fn for_realisation(seed: u64, condition: u64, channel: u64, realisation: u64) -> Self {
        NormalSequence {
            stream: NormalStream::for_realisation(seed, condition, channel, realisation),
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
fn under_density(layer: usize, x: f64, y: f64) -> bool {
    squeeze(layer, x, y).unwrap_or_else(|| y < (-0.5 * x * x).exp())
}

/// The squeeze's decision of [`under_density`], or `None` when its bounds leave it open.
#[inline]
fn squeeze(layer: usize, x: f64, y: f64) -> Option<bool> {
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
fn candidate(word: u64) -> (f64, bool) {
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
fn candidates_body(words: &[u64], out: &mut [f64], outside: &mut [u64; BLOCK / 64]) {
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
fn candidates(words: &[u64], out: &mut [f64], outside: &mut [u64; BLOCK / 64]) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU supports AVX-512F, checked just above.
            return unsafe { simd::candidates_avx512(words, out, outside) };
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { simd::candidates(words, out, outside) };
        }
    }
    candidates_body(words, out, outside)
}

#[cfg(target_arch = "x86_64")]
mod simd {
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
    pub(super) fn candidates_avx512(
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
    pub(super) fn candidates(words: &[u64], out: &mut [f64], outside: &mut [u64; BLOCK / 64]) {
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

#[cfg(test)]
mod tests {
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
            candidates_body(&words[..n], &mut x0[..n], &mut b0);
            let (mut x1, mut b1) = ([0.0; BLOCK], [0u64; BLOCK / 64]);
            candidates(&words[..n], &mut x1[..n], &mut b1);
            assert_eq!(x0.map(f64::to_bits), x1.map(f64::to_bits));
            assert_eq!(b0, b1);
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") {
                let (mut x2, mut b2) = ([0.0; BLOCK], [0u64; BLOCK / 64]);
                // SAFETY: AVX2 checked above.
                unsafe { simd::candidates(&words[..n], &mut x2[..n], &mut b2) };
                assert_eq!(x0.map(f64::to_bits), x2.map(f64::to_bits));
                assert_eq!(b0, b2);
            }
        }
    }

    #[test]
    fn a_sequence_is_the_same_whatever_lengths_are_read() {
        let mut whole = NormalSequence::for_realisation(3, 1, 2, 5);
        let mut expected = vec![0.0; 1000];
        whole.fill(&mut expected);
        for lengths in [&[1000][..], &[1, 255, 256, 300, 188], &[97, 97, 97, 709]] {
            let mut s = NormalSequence::for_realisation(3, 1, 2, 5);
            let mut got = Vec::new();
            for &n in lengths {
                let mut part = vec![0.0; n];
                s.fill(&mut part);
                got.extend(part);
            }
            assert_eq!(got, expected, "{lengths:?}");
        }
        // and it is the stream's whole blocks
        let mut stream = NormalStream::for_realisation(3, 1, 2, 5);
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
        let a = key(1, 2, 1);
        assert_ne!(a, key(2, 2, 1));
        assert_ne!(a, key(1, 3, 1));
        assert_ne!(a, key(1, 2, 2));
    }

    #[test]
    fn streams_are_independent_of_how_they_are_created() {
        let mut a = NormalStream::for_realisation(7, 1, 1, 42);
        let mut b = NormalStream::for_realisation(7, 1, 1, 42);
        let mut x = [0.0; 300];
        let mut y = [0.0; 300];
        a.fill(&mut x);
        b.fill(&mut y);
        assert_eq!(x, y);
        let mut c = NormalStream::for_realisation(7, 1, 1, 43);
        c.fill(&mut y);
        assert_ne!(x, y);
    }
}
