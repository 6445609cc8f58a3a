//! A point turned by a small angle: (x, y) → (x cos δ − y sin δ, y cos δ + x sin δ), what
//! grade noise does to every sample's gravity terms (docs/model.md#noise-channels). The
//! noise angle is nearly always tiny (σ_θ of a grade sensor is about 10⁻³ rad), and there
//! the short Taylor series of sin δ and cos δ − 1 are exact to well below an ulp; they take
//! half the operations of the fdlibm kernels ([`super::sin_cos`]) that a larger δ goes to.

use super::sin_cos;
use crate::numeric::simd::{Lanes, Real};

/// The largest |δ| the short series take: beyond it, [`super::sin_cos`] and the rotation by
/// its values. At |δ| = 1/32 the first term each series leaves out is δ⁹/9! < 2.6·10⁻¹⁸ |δ|
/// (sine) and δ⁸/8! < 2.3·10⁻¹⁷ (cos δ − 1), below a quarter of an ulp of the values they
/// enter (δ and 1). A draw of σ_θ = 10⁻³ rad never comes near it; at σ_θ = 10⁻² about one
/// sample in 560 goes beyond it.
pub const SMALL_ANGLE: f64 = 1.0 / 32.0;

// The Taylor coefficients: −1/3!, 1/5!, −1/7! of sin δ = δ + δ·z·(…), z = δ²; −1/2, 1/4!,
// −1/6! of cos δ − 1 = z·(…). (Each rounded to the nearest double; a relative error of
// 10⁻¹⁶ in a term already below 10⁻³ of the value it enters moves nothing.)
const S3: f64 = -1.0 / 6.0;
const S5: f64 = 1.0 / 120.0;
const S7: f64 = -1.0 / 5040.0;
const C2: f64 = -0.5;
const C4: f64 = 1.0 / 24.0;
const C6: f64 = -1.0 / 720.0;

/// The point (x, y) turned by the angle δ, lane by lane: (x cos δ − y sin δ, y cos δ + x sin δ).
///
/// Where |δ| ≤ [`SMALL_ANGLE`]: s = sin δ and m = cos δ − 1 by their series, then
/// x + (x·m − y·s) and y + (y·m + x·s), each a small correction added last to the value it
/// moves (within about one ulp of |(x, y)| of the true values). Elsewhere (and for NaN):
/// [`super::sin_cos`] of δ, then x cos δ − y sin δ and y cos δ + x sin δ. Every lane's result
/// is that of its own values alone, the bits one `f64` gives (`Scalar` lanes).
#[inline(always)]
pub fn turn<L: Lanes>(l: L, x: L::F64, y: L::F64, d: L::F64) -> (L::F64, L::F64) {
    let c = |v: f64| l.splat(v);
    let z = d * d;
    let s = d + d * z * (c(S3) + z * (c(S5) + z * c(S7)));
    let m = z * (c(C2) + z * (c(C4) + z * c(C6)));
    let turned = (x + (x * m - y * s), y + (y * m + x * s));
    match l.not_le_mask(d.abs(), SMALL_ANGLE) {
        0 => turned,
        outside => outside_lanes(l, [x, y, d], turned, outside),
    }
}

/// [`turn`] of one point.
#[cfg(test)]
fn turn_one(x: f64, y: f64, d: f64) -> (f64, f64) {
    turn(crate::numeric::simd::Scalar, x, y, d)
}

/// The rotation by [`super::sin_cos`]'s values, for |δ| beyond the short series.
#[inline]
fn by_sin_cos(x: f64, y: f64, d: f64) -> (f64, f64) {
    let (sin, cos) = sin_cos(d);
    (x * cos - y * sin, y * cos + x * sin)
}

/// `turned` with the lanes in the mask `outside` replaced by [`by_sin_cos`]. Inlined:
/// returned from a call, the pair would pass through memory on the common path too.
#[inline(always)]
fn outside_lanes<L: Lanes>(
    l: L,
    [x, y, d]: [L::F64; 3],
    turned: (L::F64, L::F64),
    outside: u32,
) -> (L::F64, L::F64) {
    let [mut xs, mut ys, mut ds, mut tx, mut ty] = [[0.0; 8]; 5];
    l.store(x, &mut xs, 0);
    l.store(y, &mut ys, 0);
    l.store(d, &mut ds, 0);
    l.store(turned.0, &mut tx, 0);
    l.store(turned.1, &mut ty, 0);
    for lane in (0..L::WIDTH).filter(|lane| outside >> lane & 1 == 1) {
        (tx[lane], ty[lane]) = by_sin_cos(xs[lane], ys[lane], ds[lane]);
    }
    (l.load(&tx, 0), l.load(&ty, 0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numeric::simd::Quad;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Against the rotation by the fdlibm values (the arithmetic the short series replace),
    /// on the unit circle: both are within about an ulp of the true value (the kernels within
    /// one ulp, each product and sum a rounding more), so they differ by at most two ulps of
    /// 1 (4.4·10⁻¹⁶), the coordinates being at most 1 in size; checked over a million δ up to
    /// the bound, of either sign and down to 10⁻⁴ of it, at angles up to ±0.5 rad.
    #[test]
    fn the_short_series_agree_with_the_rotation_by_the_kernels() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x5e71);
        let mut worst = 0.0f64;
        for _ in 0..1_000_000 {
            let theta: f64 = rng.random_range(-0.5..0.5);
            let scale = 10f64.powf(-rng.random_range(0.0..4.0));
            let d = SMALL_ANGLE * scale * rng.random_range(-1.0..=1.0);
            let (y, x) = theta.sin_cos();
            let (tx, ty) = turn_one(x, y, d);
            let (rx, ry) = by_sin_cos(x, y, d);
            worst = worst.max((tx - rx).abs()).max((ty - ry).abs());
        }
        assert!(worst <= 2.0 * f64::EPSILON, "worst difference {worst:e}");
    }

    /// Beyond the bound, NaN and infinite δ: exactly the rotation by the kernels' values;
    /// and four lanes give each lane the bits one value gives, whichever lanes are beyond
    /// the bound.
    #[test]
    fn lanes_are_the_single_points_and_large_angles_keep_the_kernels() {
        let ds = [
            0.0,
            -0.0,
            1e-300,
            0.003,
            -0.02,
            SMALL_ANGLE,
            -SMALL_ANGLE,
            SMALL_ANGLE.next_up(),
            -0.1,
            0.7,
            3.0,
            f64::NAN,
            f64::INFINITY,
        ];
        // (x, y) = (−g cos θ, g sin θ), as the grade noise turns them.
        let point = |k: usize| {
            let theta: f64 = [0.01, -0.3, 0.0, 1.2][k % 4];
            (-9.81 * theta.cos(), 9.81 * theta.sin())
        };
        for (k, &d) in ds.iter().enumerate() {
            let (x, y) = point(k);
            let turned = turn_one(x, y, d);
            if d.is_nan() || d.abs() > SMALL_ANGLE {
                let r = by_sin_cos(x, y, d);
                assert_eq!(turned.0.to_bits(), r.0.to_bits(), "{d}");
                assert_eq!(turned.1.to_bits(), r.1.to_bits(), "{d}");
            }
        }
        lanes_are_single_points(Quad, &ds, point);
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = crate::numeric::simd::Avx2::detect() {
            lanes_are_single_points(avx2, &ds, point);
        }
    }

    /// Four lanes of `l` give each lane the bits one point gives, for each window of four
    /// angles of `ds`.
    fn lanes_are_single_points<L: crate::numeric::simd::Lanes4>(
        l: L,
        ds: &[f64],
        point: impl Fn(usize) -> (f64, f64),
    ) {
        for window in ds.windows(4) {
            let xs: [f64; 4] = std::array::from_fn(|i| point(i).0);
            let ys: [f64; 4] = std::array::from_fn(|i| point(i).1);
            let (tx, ty) = turn(l, l.load(&xs, 0), l.load(&ys, 0), l.load(window, 0));
            let (x4, y4) = (l.lanes(tx), l.lanes(ty));
            for i in 0..4 {
                let (x1, y1) = turn_one(xs[i], ys[i], window[i]);
                assert_eq!(x4[i].to_bits(), x1.to_bits(), "{window:?} lane {i}");
                assert_eq!(y4[i].to_bits(), y1.to_bits(), "{window:?} lane {i}");
            }
        }
    }
}
