//! Noise realisations: per-realisation random streams and the normal generator.
//!
//! Every realisation draws its noise from its own `ChaCha8Rng`, keyed by
//! (study seed, condition index, noise channel) with the realisation index as the ChaCha
//! stream (SPEC §5). A realisation's numbers therefore depend on nothing but those four
//! integers: not on the thread count, chunking, shard split or order of execution, and a
//! study extended from R to 2R keeps its first R realisations bit for bit.
//!
//! Normals come from a 256-layer ziggurat (Marsaglia & Tsang 2000) run in blocks: one
//! 64-bit word per candidate in a branch-free pass, then the rare rejections (≈1 %) are
//! redrawn in order from the same stream. The mapping from stream to numbers is part of the
//! study's identity and is pinned by a value-stability test.

mod tables;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use tables::{ZIG_F, ZIG_R, ZIG_X};

/// Independent noise sources of a realisation; each has its own key, so switching one on
/// does not change the draws of another.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u64)]
pub enum Channel {
    /// Speed-measurement noise.
    Velocity = 1,
    /// Additive noise on the regression output.
    Output = 2,
    /// Noise on the measured grade signal.
    Grade = 3,
    /// Noise on the measured propulsion force.
    Force = 4,
    /// Measurement noise of the line-fit example.
    LineFit = 5,
}

/// Noise levels of one condition (standard deviations; 0 = off).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct NoiseLevels {
    /// Speed-measurement noise σ_v [m/s].
    pub velocity_sd: f64,
    /// Additive output noise σ_y [m/s²].
    pub output_sd: f64,
    /// Grade-measurement noise σ_θ [rad].
    pub grade_sd: f64,
    /// Propulsion-force measurement noise σ_F [N].
    pub force_sd: f64,
}

impl NoiseLevels {
    /// True when noise enters a regressor (speed, grade or force), not only the output.
    pub fn in_regressors(&self) -> bool {
        self.velocity_sd > 0.0 || self.grade_sd > 0.0 || self.force_sd > 0.0
    }

    /// True when only the output is noisy.
    pub fn output_only(&self) -> bool {
        self.output_sd > 0.0 && !self.in_regressors()
    }
}

/// Tag that separates chassis-mc keys from any other use of the same seed.
const KEY_TAG: &[u8; 8] = b"chassmc1";

/// The 256-bit ChaCha key of (seed, condition, channel).
pub fn key(seed: u64, condition: u64, channel: Channel) -> [u8; 32] {
    let mut k = [0u8; 32];
    k[0..8].copy_from_slice(&seed.to_le_bytes());
    k[8..16].copy_from_slice(&condition.to_le_bytes());
    k[16..24].copy_from_slice(&(channel as u64).to_le_bytes());
    k[24..32].copy_from_slice(KEY_TAG);
    k
}

/// The random stream of one realisation on one channel.
pub fn stream(seed: u64, condition: u64, channel: Channel, realisation: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::from_seed(key(seed, condition, channel));
    rng.set_stream(realisation);
    rng
}

/// Number of normals generated per block; part of the stream → numbers mapping.
pub const BLOCK: usize = 256;

/// 2^-52 and 2^-53 as exact constants.
const TWO_POW_M52: f64 = 1.0 / (1u64 << 52) as f64;
const TWO_POW_M53: f64 = 1.0 / (1u64 << 53) as f64;

/// Standard normal variates from a ChaCha8 stream, produced in blocks of [`BLOCK`].
#[derive(Debug, Clone)]
pub struct NormalStream {
    rng: ChaCha8Rng,
    words: [u64; BLOCK],
}

impl NormalStream {
    /// Normals from `rng`, starting at its current position.
    pub fn new(rng: ChaCha8Rng) -> Self {
        NormalStream {
            rng,
            words: [0; BLOCK],
        }
    }

    /// The stream of (seed, condition, channel, realisation).
    pub fn for_realisation(seed: u64, condition: u64, channel: Channel, realisation: u64) -> Self {
        Self::new(stream(seed, condition, channel, realisation))
    }

    /// Fill `out` (at most [`BLOCK`] values) with independent N(0, 1) variates.
    ///
    /// The values are a fixed function of the stream *and of the lengths requested*: callers
    /// that need reproducibility request the same lengths in the same order.
    pub fn fill_block(&mut self, out: &mut [f64]) {
        let n = out.len();
        assert!(n <= BLOCK, "fill_block takes at most {BLOCK} values");
        let words = &mut self.words[..n];
        for w in words.iter_mut() {
            *w = self.rng.next_u64();
        }
        // Branch-free pass: every candidate, and whether it fell inside its layer's core.
        let mut rejected = 0usize;
        for (o, &w) in out.iter_mut().zip(words.iter()) {
            let (x, inside) = candidate(w);
            *o = x;
            rejected += usize::from(!inside);
        }
        if rejected == 0 {
            return;
        }
        // Rare path, in index order: finish or redraw each rejected candidate.
        for (j, o) in out.iter_mut().enumerate() {
            let word = self.words[j];
            let (x, inside) = candidate(word);
            if !inside {
                *o = self.finish(word, x);
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
            *u = (self.rng.next_u64() >> 11) as f64 * TWO_POW_M53;
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
            if y < (-0.5 * x * x).exp() {
                return x;
            }
            word = self.rng.next_u64();
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
        ((self.rng.next_u64() >> 11) as f64 + 0.5) * TWO_POW_M53
    }
}

/// The ziggurat candidate of a word: layer from the low 8 bits, a signed uniform in [−1, 1)
/// from the top 53 bits; `inside` when |x| lies in the layer's rectangle core.
#[inline(always)]
fn candidate(word: u64) -> (f64, bool) {
    let layer = (word & 0xff) as usize;
    let u = (word >> 11) as f64 * TWO_POW_M52 - 1.0;
    let x = u * ZIG_X[layer];
    (x, x.abs() < ZIG_X[layer + 1])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_differ_by_seed_condition_and_channel() {
        let a = key(1, 2, Channel::Velocity);
        assert_ne!(a, key(2, 2, Channel::Velocity));
        assert_ne!(a, key(1, 3, Channel::Velocity));
        assert_ne!(a, key(1, 2, Channel::Output));
    }

    #[test]
    fn streams_are_independent_of_how_they_are_created() {
        let mut a = NormalStream::for_realisation(7, 1, Channel::Velocity, 42);
        let mut b = NormalStream::for_realisation(7, 1, Channel::Velocity, 42);
        let mut x = [0.0; 300];
        let mut y = [0.0; 300];
        a.fill(&mut x);
        b.fill(&mut y);
        assert_eq!(x, y);
        let mut c = NormalStream::for_realisation(7, 1, Channel::Velocity, 43);
        c.fill(&mut y);
        assert_ne!(x, y);
    }
}
