//! Sine and cosine with the same bits on every x86-64 CPU: every |x| ≤ π/4 is evaluated by
//! the same branch-free polynomials, written once over the number types of `numeric::simd`
//! (so the compiler can turn them into SIMD code), and a larger or non-finite argument is
//! handed to `f64::sin_cos`. Grade noise turns each sample's gravity terms by the small
//! angle −δ, δ = σ_θ·e ([`turn`], its own short series, [`sin_cos`] for a larger δ;
//! docs/model.md#noise-channels). The tests hold the polynomials, one value at a time and
//! over slices in AVX2, against the fdlibm coefficients and the system's libm.
//!
//! The polynomials are the fdlibm kernels `__kernel_sin` and `__kernel_cos` as musl has them
//! (src/math/__sin.c and src/math/__cos.c, from FreeBSD's k_sin.c / k_cos.c; Copyright (C)
//! 1993 by Sun Microsystems, Inc., freely distributable with this notice), evaluated with a
//! zero tail (y = 0). Their Remez error on \[0, π/4\] is below 2⁻⁵⁸ and the result is within
//! one ulp of the true value. There are no fused multiply-adds and no reassociation: Rust
//! contracts nothing by itself and AVX2 alone does not bring FMA, so the portable build and
//! the AVX2 build perform the same IEEE operations in the same order and every x86-64 CPU
//! gives the same bits.

use std::f64::consts::FRAC_PI_4;

mod turn;
pub use turn::turn;

/// The fdlibm coefficients, written with the digits musl has (more than an `f64` holds, so
/// clippy's excessive-precision lint is off here); the tests check their bits against the
/// hex words beside them.
#[allow(clippy::excessive_precision)]
mod fdlibm {
    // fdlibm / musl src/math/__sin.c, copied digit for digit (hex words in the comments).
    pub(super) const S1: f64 = -1.666_666_666_666_663_243_48e-1; // 0xBFC55555 55555549
    pub(super) const S2: f64 = 8.333_333_333_322_489_461_24e-3; // 0x3F811111 1110F8A6
    pub(super) const S3: f64 = -1.984_126_982_985_794_931_34e-4; // 0xBF2A01A0 19C161D5
    pub(super) const S4: f64 = 2.755_731_370_707_006_767_89e-6; // 0x3EC71DE3 57B1FE7D
    pub(super) const S5: f64 = -2.505_076_025_340_686_341_95e-8; // 0xBE5AE5E6 8A2B9CEB
    pub(super) const S6: f64 = 1.589_690_995_211_550_102_21e-10; // 0x3DE5D93A 5ACFD57C

    // fdlibm / musl src/math/__cos.c, copied digit for digit (hex words in the comments).
    pub(super) const C1: f64 = 4.166_666_666_666_660_190_37e-2; // 0x3FA55555 5555554C
    pub(super) const C2: f64 = -1.388_888_888_887_410_957_49e-3; // 0xBF56C16C 16C15177
    pub(super) const C3: f64 = 2.480_158_728_947_672_941_78e-5; // 0x3EFA01A0 19CB1590
    pub(super) const C4: f64 = -2.755_731_435_139_066_330_35e-7; // 0xBE927E4F 809C52AD
    pub(super) const C5: f64 = 2.087_572_321_298_174_827_90e-9; // 0x3E21EE9E BDB4B1C4
    pub(super) const C6: f64 = -1.135_964_755_778_819_482_65e-11; // 0xBDA8FAE9 BE8838D4
}
use fdlibm::*;

use super::simd::{Lanes, Real, Scalar};

/// Whether x is evaluated by the polynomials (|x| ≤ π/4, so never NaN or ±∞); every other
/// argument goes to `f64::sin_cos`.
#[inline(always)]
fn in_kernel_range(x: f64) -> bool {
    x.abs() <= FRAC_PI_4
}

/// sin x and cos x for |x| ≤ π/4 by the fdlibm kernels, without a branch: [`kernel_lanes`]
/// of one value.
#[inline(always)]
fn kernel(x: f64) -> (f64, f64) {
    kernel_lanes(Scalar, x)
}

/// sin x and cos x for |x| ≤ π/4 by the fdlibm kernels, without a branch, lane by lane in
/// the number type of `l` (one definition for the scalar and the vector code, so the same
/// bits).
///
/// Tiny arguments need no special case: once x² underflows (|x| < 2⁻⁵³⁸ or so) the
/// correction terms are zero and the results are x and 1 exactly; before that they are far
/// below half an ulp of x and of 1. The odd polynomial x + x³·p would turn −0 into +0
/// (−0 + +0 = +0), so the sign of x is put back on the sine, which changes nothing else:
/// on this range sin x has the sign of x.
#[inline(always)]
pub fn kernel_lanes<L: Lanes>(l: L, x: L::F64) -> (L::F64, L::F64) {
    let c = |v: f64| l.splat(v);
    let z = x * x;
    let w = z * z;

    // __sin(x, 0, 0)
    let r = c(S2) + z * (c(S3) + z * c(S4)) + z * w * (c(S5) + z * c(S6));
    let v = z * x;
    let sin = (x + v * (c(S1) + z * r)).copysign(x);

    // __cos(x, 0): 1 − z/2 is split into w + ((1 − w) − z/2), whose second part is the
    // rounding error of w, so the sum keeps the result within one ulp.
    let r = z * (c(C1) + z * (c(C2) + z * c(C3))) + w * w * (c(C4) + z * (c(C5) + z * c(C6)));
    let hz = c(0.5) * z;
    let w = c(1.0) - hz;
    let cos = w + (((c(1.0) - w) - hz) + z * r);
    (sin, cos)
}

/// The mask of the lanes of `x` outside the kernels' range (bit l for lane l: |x| > π/4 or
/// NaN, as `!in_kernel_range`), whose results `f64::sin_cos` gives instead.
#[cfg(test)]
fn outside_kernel_range<L: Lanes>(l: L, x: L::F64) -> u32 {
    l.not_le_mask(x.abs(), FRAC_PI_4)
}

/// sin and cos of every `x[i]` into `sin[i]`, `cos[i]` (slices of equal length): the
/// polynomials over many values at once, as the tests check them (no caller outside them).
///
/// For |x| ≤ π/4 the fdlibm polynomials (see the module doc), within one ulp of the true
/// values and bit-identical on every x86-64 CPU; otherwise (and for NaN, ±∞) exactly what
/// `f64::sin_cos` gives. Compiled for AVX2 where the CPU has it, with the same bits.
///
/// # Panics
/// If the three slices differ in length.
#[cfg(test)]
fn sin_cos_slice(x: &[f64], sin: &mut [f64], cos: &mut [f64]) {
    assert!(
        sin.len() == x.len() && cos.len() == x.len(),
        "sin_cos_slice: slices of lengths {}, {}, {}",
        x.len(),
        sin.len(),
        cos.len()
    );
    #[cfg(target_arch = "x86_64")]
    {
        if crate::numeric::simd::avx2() {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { sin_cos_slice_avx2(x, sin, cos) };
        }
    }
    sin_cos_slice_body(x, sin, cos);
}

/// sin x and cos x: the polynomials for |x| ≤ π/4 (within one ulp, the same bits on every
/// x86-64 CPU), `f64::sin_cos` otherwise; the same bits as the slices' form gives.
#[inline]
pub fn sin_cos(x: f64) -> (f64, f64) {
    if in_kernel_range(x) {
        kernel(x)
    } else {
        x.sin_cos()
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
#[target_feature(enable = "avx2")]
fn sin_cos_slice_avx2(x: &[f64], sin: &mut [f64], cos: &mut [f64]) {
    sin_cos_slice_body(x, sin, cos);
}

/// The polynomials for every element (a loop the compiler vectorises, noting on the way
/// whether any element lies outside their range), then, only if one does, a scalar pass
/// that overwrites those elements with `f64::sin_cos`.
#[cfg(test)]
#[inline(always)]
fn sin_cos_slice_body(x: &[f64], sin: &mut [f64], cos: &mut [f64]) {
    let mut outside = false;
    for ((&x, s), c) in x.iter().zip(sin.iter_mut()).zip(cos.iter_mut()) {
        (*s, *c) = kernel(x);
        outside |= !in_kernel_range(x);
    }
    if !outside {
        return;
    }
    for ((&x, s), c) in x.iter().zip(sin.iter_mut()).zip(cos.iter_mut()) {
        if !in_kernel_range(x) {
            (*s, *c) = x.sin_cos();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Distance in ulps of two floats of the same sign (equal values, ±0 included, are 0).
    fn ulps(a: f64, b: f64) -> u64 {
        if a == b {
            return 0;
        }
        assert_eq!(a.is_sign_negative(), b.is_sign_negative(), "{a} vs {b}");
        (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs()
    }

    fn slice(x: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let mut s = vec![f64::NAN; x.len()];
        let mut c = vec![f64::NAN; x.len()];
        sin_cos_slice(x, &mut s, &mut c);
        (s, c)
    }

    /// Worst ulp distance of sin and of cos from `f64::sin_cos` over `x`.
    fn worst_ulps(x: &[f64]) -> (u64, u64) {
        let (s, c) = slice(x);
        let mut worst = (0, 0);
        for i in 0..x.len() {
            let (rs, rc) = x[i].sin_cos();
            worst.0 = worst.0.max(ulps(s[i], rs));
            worst.1 = worst.1.max(ulps(c[i], rc));
        }
        worst
    }

    /// n values from 10^lo to 10^hi evenly in the logarithm, with both signs.
    fn log_sweep(lo: f64, hi: f64, n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| 10f64.powf(lo + (hi - lo) * i as f64 / (n - 1) as f64))
            .flat_map(|x| [x, -x])
            .collect()
    }

    fn specials() -> Vec<f64> {
        let sub = f64::MIN_POSITIVE / 2.0;
        let mut x = vec![
            0.0,
            -0.0,
            f64::from_bits(1),
            sub,
            f64::MIN_POSITIVE.next_down(),
            f64::MIN_POSITIVE,
            FRAC_PI_4,
            FRAC_PI_4.next_down(),
            f64::EPSILON,
            1e-8,
            2f64.powi(-27),
            2f64.powi(-26),
        ];
        x.extend(x.clone().into_iter().map(|v| -v));
        x
    }

    // Tolerance 2 ulp: the fdlibm kernels are within one ulp of the true value (their
    // polynomial error is below 2⁻⁵⁸ relative, the rest is a few roundings bounded by the
    // cos split), and glibc's sin and cos, which `f64::sin_cos` calls, are within one ulp as
    // well; two results each less than one ulp from the same real number are at most one
    // ulp apart, or two where the ulp halves across a power of two.
    const TOL_ULPS: u64 = 2;

    #[test]
    fn within_two_ulps_of_std_on_the_kernel_range() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x7419);
        let n = 1_000_000;
        let uniform: Vec<f64> = (0..n)
            .map(|i| -FRAC_PI_4 + 2.0 * FRAC_PI_4 * i as f64 / (n - 1) as f64)
            .chain((0..n).map(|_| rng.random_range(-FRAC_PI_4..=FRAC_PI_4)))
            .collect();
        // 10^log10(π/4) may round past π/4
        let sweep: Vec<f64> = log_sweep(-300.0, FRAC_PI_4.log10(), 200_000)
            .into_iter()
            .map(|x| x.clamp(-FRAC_PI_4, FRAC_PI_4))
            .collect();
        let specials = specials();
        let mut worst = (0, 0);
        for x in [&uniform, &sweep, &specials] {
            assert!(x.iter().all(|&v| in_kernel_range(v)));
            let w = worst_ulps(x);
            worst = (worst.0.max(w.0), worst.1.max(w.1));
        }
        println!(
            "worst on |x| <= pi/4: sin {} ulp, cos {} ulp",
            worst.0, worst.1
        );
        assert!(worst.0 <= TOL_ULPS && worst.1 <= TOL_ULPS, "{worst:?}");

        // the signed and tiny cases exactly
        let (s, c) = slice(&specials);
        for (i, &x) in specials.iter().enumerate() {
            if x.abs() < 1e-8 {
                assert_eq!(s[i].to_bits(), x.to_bits(), "sin {x:e}");
                assert_eq!(c[i], 1.0, "cos {x:e}");
            }
        }
    }

    #[test]
    fn within_two_ulps_of_std_on_the_grade_noise_range() {
        // δ = σ_θ·e with σ_θ ≤ 0.1 rad and |e| ≤ 8: up to 0.8, a little past π/4
        let mut rng = ChaCha8Rng::seed_from_u64(0x0de1);
        let x: Vec<f64> = (0..500_000)
            .map(|_| {
                let sd = rng.random_range(0.0..=0.1);
                let e = rng.random_range(-8.0..=8.0);
                sd * e
            })
            .collect();
        let worst = worst_ulps(&x);
        println!(
            "worst on sigma*delta: sin {} ulp, cos {} ulp",
            worst.0, worst.1
        );
        assert!(worst.0 <= TOL_ULPS && worst.1 <= TOL_ULPS, "{worst:?}");
    }

    #[test]
    fn beyond_pi_over_4_and_non_finite_is_std() {
        let mut x = vec![
            FRAC_PI_4.next_up(),
            0.8,
            1.0,
            3.0,
            1e6,
            1e22,
            1e300,
            f64::MAX,
            f64::INFINITY,
            f64::NAN,
            -f64::NAN,
        ];
        x.extend(x.clone().into_iter().map(|v| -v));
        x.extend(log_sweep(FRAC_PI_4.next_up().log10(), 300.0, 10_000));
        x.retain(|v| !in_kernel_range(*v));
        let (s, c) = slice(&x);
        for (i, &x) in x.iter().enumerate() {
            let (rs, rc) = x.sin_cos();
            if x.is_nan() || x.is_infinite() {
                assert!(s[i].is_nan() && c[i].is_nan() && rs.is_nan() && rc.is_nan());
            } else {
                assert_eq!(s[i].to_bits(), rs.to_bits(), "sin {x:e}");
                assert_eq!(c[i].to_bits(), rc.to_bits(), "cos {x:e}");
            }
        }
    }

    /// In- and out-of-range values mixed, with the specials.
    fn mixed(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let specials = specials();
        (0..n)
            .map(|i| match i % 17 {
                0 => specials[(i / 17) % specials.len()],
                1 => rng.random_range(-10.0..10.0),
                2 => [f64::NAN, f64::INFINITY, -f64::INFINITY][(i / 17) % 3],
                _ => rng.random_range(-FRAC_PI_4..=FRAC_PI_4),
            })
            .collect()
    }

    #[test]
    fn portable_and_dispatched_builds_agree_bit_for_bit() {
        for (k, n) in [0, 1, 3, 4, 5, 8, 257, 4099].into_iter().enumerate() {
            let x = mixed(n, k as u64);
            let (s, c) = slice(&x);
            let (mut s0, mut c0) = (vec![0.0; n], vec![0.0; n]);
            sin_cos_slice_body(&x, &mut s0, &mut c0);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&s), bits(&s0), "sin, n = {n}");
            assert_eq!(bits(&c), bits(&c0), "cos, n = {n}");
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") {
                let (mut s1, mut c1) = (vec![0.0; n], vec![0.0; n]);
                // SAFETY: the CPU supports AVX2, checked just above.
                unsafe { sin_cos_slice_avx2(&x, &mut s1, &mut c1) };
                assert_eq!(bits(&s1), bits(&s0), "avx2 sin, n = {n}");
                assert_eq!(bits(&c1), bits(&c0), "avx2 cos, n = {n}");
            }
        }
    }

    /// Every four-lane token's kernel is the scalar kernel lane by lane.
    fn four_lanes_are_the_kernel<L: crate::numeric::simd::Lanes4>(l: L) {
        let x = mixed(4 * 1000, 17);
        for group in x.chunks_exact(4) {
            let v = l.load(group, 0);
            let (s, c) = kernel_lanes(l, v);
            let outside = outside_kernel_range(l, v);
            let got = (l.lanes(s), l.lanes(c));
            for (i, &x) in group.iter().enumerate() {
                assert_eq!(outside >> i & 1 == 1, !in_kernel_range(x), "{x:e}");
                if in_kernel_range(x) {
                    let (s, c) = kernel(x);
                    assert_eq!(got.0[i].to_bits(), s.to_bits(), "sin {x:e}");
                    assert_eq!(got.1[i].to_bits(), c.to_bits(), "cos {x:e}");
                }
            }
        }
    }

    #[test]
    fn the_four_lane_kernel_is_the_kernel_bit_for_bit() {
        four_lanes_are_the_kernel(crate::numeric::simd::Quad);
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = crate::numeric::simd::Avx2::detect() {
            four_lanes_are_the_kernel(avx2);
        }
    }

    #[test]
    fn one_value_is_the_slice_value() {
        let x = mixed(5000, 99);
        let (s, c) = slice(&x);
        for (i, &x) in x.iter().enumerate() {
            let (s1, c1) = sin_cos(x);
            assert_eq!(s1.to_bits(), s[i].to_bits(), "sin {x:e}");
            assert_eq!(c1.to_bits(), c[i].to_bits(), "cos {x:e}");
        }
    }

    #[test]
    fn coefficients_have_the_bits_of_fdlibm() {
        // the hex words of musl's src/math/__sin.c and __cos.c
        let words: [(f64, u64); 12] = [
            (S1, 0xBFC55555_55555549),
            (S2, 0x3F811111_1110F8A6),
            (S3, 0xBF2A01A0_19C161D5),
            (S4, 0x3EC71DE3_57B1FE7D),
            (S5, 0xBE5AE5E6_8A2B9CEB),
            (S6, 0x3DE5D93A_5ACFD57C),
            (C1, 0x3FA55555_5555554C),
            (C2, 0xBF56C16C_16C15177),
            (C3, 0x3EFA01A0_19CB1590),
            (C4, 0xBE927E4F_809C52AD),
            (C5, 0x3E21EE9E_BDB4B1C4),
            (C6, 0xBDA8FAE9_BE8838D4),
        ];
        for (i, (c, w)) in words.into_iter().enumerate() {
            assert_eq!(c.to_bits(), w, "coefficient {i}");
        }
    }

    #[test]
    #[should_panic(expected = "sin_cos_slice")]
    fn unequal_lengths_panic() {
        sin_cos_slice(&[0.0; 3], &mut [0.0; 3], &mut [0.0; 2]);
    }
}
