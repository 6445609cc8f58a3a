//! The block sums of the realisation kernel's fast path (speed and output noise only), written once
//! over the four lanes of `numeric::simd` (portable or AVX2, the same bits); the measured
//! speed is the speed channel's own arithmetic (`channels::measured_speed`).

use crate::estimate::channels::measured_speed;
use crate::noise::BLOCK;
#[cfg(target_arch = "x86_64")]
use crate::numeric::simd::Avx2;
use crate::numeric::simd::{Lanes4, Quad, Scalar};

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

/// Σw, ΣwF, Σwc, Σw², Σwy over a block, w = (V + σ_v e)², sample i into lane i mod 4: one
/// definition ([`speed_sums_lanes`]) in the portable lanes or, on x86-64 with AVX2, in one
/// 256-bit register, bit for bit the same.
pub(crate) fn speed_sums(cols: &Columns<'_>, e: &[f64], sd_v: f64) -> [f64; 5] {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = Avx2::detect() {
        // SAFETY: the token proves the CPU has AVX2.
        return unsafe { speed_sums_avx2::<false>(avx2, cols, e, sd_v, &mut []) };
    }
    speed_sums_lanes::<_, false>(Quad, cols, e, sd_v, &mut [])
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
    if let Some(avx2) = Avx2::detect() {
        // SAFETY: the token proves the CPU has AVX2.
        return unsafe { speed_sums_avx2::<true>(avx2, cols, e, sd_v, w) };
    }
    speed_sums_lanes::<_, true>(Quad, cols, e, sd_v, w)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn speed_sums_avx2<const STORE: bool>(
    avx2: Avx2,
    cols: &Columns<'_>,
    e: &[f64],
    sd_v: f64,
    w_out: &mut [f64],
) -> [f64; 5] {
    speed_sums_lanes::<_, STORE>(avx2, cols, e, sd_v, w_out)
}

/// [`speed_sums`] in the lanes of `l`; with `STORE`, w is written into `w_out`.
#[inline(always)]
fn speed_sums_lanes<L: Lanes4, const STORE: bool>(
    l: L,
    cols: &Columns<'_>,
    e: &[f64],
    sd_v: f64,
    w_out: &mut [f64],
) -> [f64; 5] {
    let n = cols.v.len();
    assert!(cols.f.len() == n && cols.c.len() == n && cols.y.len() == n && e.len() >= n);
    assert!(!STORE || w_out.len() == n);
    let whole = n - n % LANES;
    let mut acc = [l.splat(0.0); 5];
    for i in (0..whole).step_by(LANES) {
        let vt = measured_speed(l, l.load(cols.v, i), sd_v, l.load(e, i));
        let w = vt * vt;
        if STORE {
            l.store(w, w_out, i);
        }
        acc[0] = acc[0] + w;
        acc[1] = acc[1] + w * l.load(cols.f, i);
        acc[2] = acc[2] + w * l.load(cols.c, i);
        acc[3] = acc[3] + w * w;
        acc[4] = acc[4] + w * l.load(cols.y, i);
    }
    let mut acc = l.lanes_each(acc);
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
        let vt = measured_speed(Scalar, cols.v[i], sd_v, e[i]);
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
/// [`speed_sums`], one definition ([`output_sums_lanes`]) for the portable and AVX2 code.
pub(crate) fn output_sums(cols: &Columns<'_>, e: &[f64], sd_v: f64, eta: &[f64]) -> [f64; 4] {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = Avx2::detect() {
        // SAFETY: the token proves the CPU has AVX2.
        return unsafe { output_sums_avx2(avx2, cols, e, sd_v, eta) };
    }
    output_sums_lanes(Quad, cols, e, sd_v, eta)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn output_sums_avx2(avx2: Avx2, cols: &Columns<'_>, e: &[f64], sd_v: f64, eta: &[f64]) -> [f64; 4] {
    output_sums_lanes(avx2, cols, e, sd_v, eta)
}

/// [`output_sums`] in the lanes of `l`.
#[inline(always)]
fn output_sums_lanes<L: Lanes4>(
    l: L,
    cols: &Columns<'_>,
    e: &[f64],
    sd_v: f64,
    eta: &[f64],
) -> [f64; 4] {
    let n = cols.v.len();
    assert!(cols.f.len() == n && cols.c.len() == n && e.len() >= n && eta.len() >= n);
    let whole = n - n % LANES;
    let mut acc = [l.splat(0.0); 4];
    for i in (0..whole).step_by(LANES) {
        let vt = measured_speed(l, l.load(cols.v, i), sd_v, l.load(e, i));
        let eta_i = l.load(eta, i);
        acc[0] = acc[0] + eta_i;
        acc[1] = acc[1] + l.load(cols.f, i) * eta_i;
        acc[2] = acc[2] + l.load(cols.c, i) * eta_i;
        acc[3] = acc[3] + vt * vt * eta_i;
    }
    let mut acc = l.lanes_each(acc);
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
        let vt = measured_speed(Scalar, cols.v[i], sd_v, e[i]);
        acc[0][l] += eta[i];
        acc[1][l] += cols.f[i] * eta[i];
        acc[2][l] += cols.c[i] * eta[i];
        acc[3][l] += vt * vt * eta[i];
    }
}

#[cfg(test)]
mod tests;
