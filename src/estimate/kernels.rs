//! The block sums of the kernel's fast path (speed and output noise only): a portable
//! version in four lanes and an AVX2 version that is lane for lane the same, bit for bit.

use crate::noise::BLOCK;

/// Zero draws for a channel that is off.
pub(crate) const ZEROS: [f64; BLOCK] = [0.0; BLOCK];

/// Independent partial sums per accumulator: four lanes break the add-latency chain and let
/// the compiler use vector registers; lanes are combined as (l0 + l1) + (l2 + l3).
const LANES: usize = 4;

/// The noise-free columns of one block of samples.
pub(crate) struct Columns<'a> {
    pub(crate) v: &'a [f64],
    pub(crate) f: &'a [f64],
    pub(crate) c: &'a [f64],
    pub(crate) y: &'a [f64],
}

#[inline(always)]
fn reduce(lanes: [f64; LANES]) -> f64 {
    (lanes[0] + lanes[1]) + (lanes[2] + lanes[3])
}

/// Σw, ΣwF, Σwc, Σw², Σwy over a block, w = (V + σ_v e)². On x86-64 with AVX2 the four
/// lanes are one 256-bit register each; the results are bit-identical to the portable code
/// (the same operations per lane in the same order: no FMA, no reassociation).
pub(crate) fn speed_sums(cols: &Columns<'_>, e: &[f64], sd_v: f64) -> [f64; 5] {
    #[cfg(target_arch = "x86_64")]
    {
        if crate::numeric::simd::avx2() {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { simd::speed_sums::<false>(cols, e, sd_v, &mut []) };
        }
    }
    speed_sums_body::<false>(cols, e, sd_v, &mut [])
}

/// [`speed_sums`] that also writes each sample's w into `w` (as long as the block): the
/// measured rows of the fast path, the values the sums take.
pub(crate) fn speed_sums_writing_w(
    cols: &Columns<'_>,
    e: &[f64],
    sd_v: f64,
    w: &mut [f64],
) -> [f64; 5] {
    assert_eq!(w.len(), cols.v.len(), "the block's w");
    #[cfg(target_arch = "x86_64")]
    {
        if crate::numeric::simd::avx2() {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { simd::speed_sums::<true>(cols, e, sd_v, w) };
        }
    }
    speed_sums_body::<true>(cols, e, sd_v, w)
}

#[cfg(target_arch = "x86_64")]
mod simd {
    //! AVX2 versions of the per-block sums, lane for lane the portable code.

    use std::arch::x86_64::*;

    use super::{Columns, LANES, output_sums_tail, reduce, speed_sums_tail};

    #[inline]
    #[target_feature(enable = "avx2")]
    fn lanes(v: __m256d) -> [f64; LANES] {
        let mut out = [0.0; LANES];
        // SAFETY: writes four f64 into an array of four.
        unsafe { _mm256_storeu_pd(out.as_mut_ptr(), v) };
        out
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn load(x: &[f64], i: usize) -> __m256d {
        assert!(i + LANES <= x.len());
        // SAFETY: bounds checked just above.
        unsafe { _mm256_loadu_pd(x.as_ptr().add(i)) }
    }

    /// With `STORE`, w is written into `w_out` (as long as the block).
    #[target_feature(enable = "avx2")]
    pub(super) fn speed_sums<const STORE: bool>(
        cols: &Columns<'_>,
        e: &[f64],
        sd_v: f64,
        w_out: &mut [f64],
    ) -> [f64; 5] {
        let n = cols.v.len();
        assert!(cols.f.len() == n && cols.c.len() == n && cols.y.len() == n && e.len() >= n);
        assert!(!STORE || w_out.len() == n);
        let whole = n - n % LANES;
        let sd = _mm256_set1_pd(sd_v);
        let mut acc = [_mm256_setzero_pd(); 5];
        let mut i = 0;
        while i < whole {
            let vt = _mm256_add_pd(load(cols.v, i), _mm256_mul_pd(sd, load(e, i)));
            let w = _mm256_mul_pd(vt, vt);
            if STORE {
                // SAFETY: i + 4 <= whole <= n = w_out.len() (checked above).
                unsafe { _mm256_storeu_pd(w_out.as_mut_ptr().add(i), w) };
            }
            acc[0] = _mm256_add_pd(acc[0], w);
            acc[1] = _mm256_add_pd(acc[1], _mm256_mul_pd(w, load(cols.f, i)));
            acc[2] = _mm256_add_pd(acc[2], _mm256_mul_pd(w, load(cols.c, i)));
            acc[3] = _mm256_add_pd(acc[3], _mm256_mul_pd(w, w));
            acc[4] = _mm256_add_pd(acc[4], _mm256_mul_pd(w, load(cols.y, i)));
            i += LANES;
        }
        let mut acc = acc.map(|a| lanes(a));
        speed_sums_tail::<STORE>(cols, e, sd_v, whole, &mut acc, w_out);
        acc.map(reduce)
    }

    #[target_feature(enable = "avx2")]
    pub(super) fn output_sums(cols: &Columns<'_>, e: &[f64], sd_v: f64, eta: &[f64]) -> [f64; 4] {
        let n = cols.v.len();
        assert!(cols.f.len() == n && cols.c.len() == n && e.len() >= n && eta.len() >= n);
        let whole = n - n % LANES;
        let sd = _mm256_set1_pd(sd_v);
        let mut acc = [_mm256_setzero_pd(); 4];
        let mut i = 0;
        while i < whole {
            let vt = _mm256_add_pd(load(cols.v, i), _mm256_mul_pd(sd, load(e, i)));
            let eta_i = load(eta, i);
            acc[0] = _mm256_add_pd(acc[0], eta_i);
            acc[1] = _mm256_add_pd(acc[1], _mm256_mul_pd(load(cols.f, i), eta_i));
            acc[2] = _mm256_add_pd(acc[2], _mm256_mul_pd(load(cols.c, i), eta_i));
            acc[3] = _mm256_add_pd(acc[3], _mm256_mul_pd(_mm256_mul_pd(vt, vt), eta_i));
            i += LANES;
        }
        let mut acc = acc.map(|a| lanes(a));
        output_sums_tail(cols, e, sd_v, eta, whole, &mut acc);
        acc.map(reduce)
    }
}

/// The portable [`speed_sums`]; with `STORE`, w is written into `w_out`.
#[inline(always)]
fn speed_sums_body<const STORE: bool>(
    cols: &Columns<'_>,
    e: &[f64],
    sd_v: f64,
    w_out: &mut [f64],
) -> [f64; 5] {
    let mut acc = [[0.0; LANES]; 5];
    let n = cols.v.len();
    let whole = n - n % LANES;
    let lanes = cols.v[..whole]
        .chunks_exact(LANES)
        .zip(cols.f[..whole].chunks_exact(LANES))
        .zip(cols.c[..whole].chunks_exact(LANES))
        .zip(cols.y[..whole].chunks_exact(LANES))
        .zip(e[..whole].chunks_exact(LANES));
    for (g, ((((v, f), c), y), e)) in lanes.enumerate() {
        for l in 0..LANES {
            let vt = v[l] + sd_v * e[l];
            let w = vt * vt;
            if STORE {
                w_out[g * LANES + l] = w;
            }
            acc[0][l] += w;
            acc[1][l] += w * f[l];
            acc[2][l] += w * c[l];
            acc[3][l] += w * w;
            acc[4][l] += w * y[l];
        }
    }
    speed_sums_tail::<STORE>(cols, e, sd_v, whole, &mut acc, w_out);
    acc.map(reduce)
}

/// The samples after the last whole group of lanes, all into lane 0 (shared by every path
/// so that they agree bit for bit).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // five parallel slices indexed together
fn speed_sums_tail<const STORE: bool>(
    cols: &Columns<'_>,
    e: &[f64],
    sd_v: f64,
    whole: usize,
    acc: &mut [[f64; LANES]; 5],
    w_out: &mut [f64],
) {
    for i in whole..cols.v.len() {
        let vt = cols.v[i] + sd_v * e[i];
        let w = vt * vt;
        if STORE {
            w_out[i] = w;
        }
        acc[0][0] += w;
        acc[1][0] += w * cols.f[i];
        acc[2][0] += w * cols.c[i];
        acc[3][0] += w * w;
        acc[4][0] += w * cols.y[i];
    }
}

/// Ση, ΣFη, Σcη, Σwη over a block, w = (V + σ_v e)²; sample i goes to lane i mod 4. Like
/// [`speed_sums`], the AVX2 path is bit-identical to the portable code.
pub(crate) fn output_sums(cols: &Columns<'_>, e: &[f64], sd_v: f64, eta: &[f64]) -> [f64; 4] {
    #[cfg(target_arch = "x86_64")]
    {
        if crate::numeric::simd::avx2() {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { simd::output_sums(cols, e, sd_v, eta) };
        }
    }
    output_sums_body(cols, e, sd_v, eta)
}

#[inline(always)]
fn output_sums_body(cols: &Columns<'_>, e: &[f64], sd_v: f64, eta: &[f64]) -> [f64; 4] {
    let mut acc = [[0.0; LANES]; 4];
    let n = cols.v.len();
    let whole = n - n % LANES;
    let lanes = cols.v[..whole]
        .chunks_exact(LANES)
        .zip(cols.f[..whole].chunks_exact(LANES))
        .zip(cols.c[..whole].chunks_exact(LANES))
        .zip(e[..whole].chunks_exact(LANES))
        .zip(eta[..whole].chunks_exact(LANES));
    for ((((v, f), c), e), eta) in lanes {
        for l in 0..LANES {
            let vt = v[l] + sd_v * e[l];
            acc[0][l] += eta[l];
            acc[1][l] += f[l] * eta[l];
            acc[2][l] += c[l] * eta[l];
            acc[3][l] += vt * vt * eta[l];
        }
    }
    output_sums_tail(cols, e, sd_v, eta, whole, &mut acc);
    acc.map(reduce)
}

/// The samples after the last whole group of lanes, each into lane i mod 4.
#[inline(always)]
fn output_sums_tail(
    cols: &Columns<'_>,
    e: &[f64],
    sd_v: f64,
    eta: &[f64],
    whole: usize,
    acc: &mut [[f64; LANES]; 4],
) {
    for i in whole..cols.v.len() {
        let l = i % LANES;
        let vt = cols.v[i] + sd_v * e[i];
        acc[0][l] += eta[i];
        acc[1][l] += cols.f[i] * eta[i];
        acc[2][l] += cols.c[i] * eta[i];
        acc[3][l] += vt * vt * eta[i];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::channels::Channel;
    use crate::estimate::regression::test_regression as regression;
    use crate::noise::NormalStream;

    #[test]
    fn vector_block_sums_equal_the_portable_ones_bit_for_bit_and_write_w() {
        let reg = regression();
        let mut e = [0.0; BLOCK];
        NormalStream::for_realisation(5, 0, Channel::Velocity.stream(), 1).fill(&mut e);
        let mut eta = [0.0; BLOCK];
        NormalStream::for_realisation(5, 0, Channel::Output.stream(), 1).fill(&mut eta);
        for (start, len) in [(0, BLOCK), (1000, 253), (3, 7)] {
            let cols = Columns {
                v: &reg.v[start..start + len],
                f: &reg.f[start..start + len],
                c: &reg.c[start..start + len],
                y: &reg.y[start..start + len],
            };
            let portable = speed_sums_body::<false>(&cols, &e[..len], 0.8, &mut []);
            let dispatched = speed_sums(&cols, &e[..len], 0.8);
            assert_eq!(portable.map(f64::to_bits), dispatched.map(f64::to_bits));
            // Writing w changes no sum, and writes the w of each sample, every one of them
            // (the two writers start from values no w can take).
            let (mut w_portable, mut w_dispatched) = (vec![-1.0; len], vec![-2.0; len]);
            let writing = speed_sums_body::<true>(&cols, &e[..len], 0.8, &mut w_portable);
            assert_eq!(writing.map(f64::to_bits), portable.map(f64::to_bits));
            let writing = speed_sums_writing_w(&cols, &e[..len], 0.8, &mut w_dispatched);
            assert_eq!(writing.map(f64::to_bits), portable.map(f64::to_bits));
            for (j, (a, b)) in w_portable.iter().zip(&w_dispatched).enumerate() {
                let vt = cols.v[j] + 0.8 * e[j];
                assert_eq!(
                    (a.to_bits(), b.to_bits()),
                    ((vt * vt).to_bits(), (vt * vt).to_bits())
                );
            }
            let portable = output_sums_body(&cols, &e[..len], 0.8, &eta[..len]);
            let dispatched = output_sums(&cols, &e[..len], 0.8, &eta[..len]);
            assert_eq!(portable.map(f64::to_bits), dispatched.map(f64::to_bits));
        }
    }
}
