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

/// The candidate pass, portable version, from candidate `start` on (0, or the tail a
/// vector pass leaves): `out[j]` gets every candidate and bit j of `outside` is set when
/// candidate j fell outside its layer's core.
#[inline]
pub(super) fn candidates_portable(
    start: usize,
    words: &[u64],
    out: &mut [f64],
    outside: &mut [u64; BLOCK / 64],
) {
    let tail = out[start..].iter_mut().zip(&words[start..]);
    for (j, (o, &w)) in (start..).zip(tail) {
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
    let done = {
        use crate::numeric::simd;
        if simd::avx512f() {
            // SAFETY: the CPU supports AVX-512F, checked just above.
            unsafe { simd::ziggurat_candidates_8(&ZIG_X, words, out, outside) }
        } else if simd::avx2() {
            // SAFETY: the CPU supports AVX2, checked just above.
            unsafe { simd::ziggurat_candidates_4(&ZIG_X, words, out, outside) }
        } else {
            0
        }
    };
    #[cfg(not(target_arch = "x86_64"))]
    let done = 0;
    candidates_portable(done, words, out, outside)
}
