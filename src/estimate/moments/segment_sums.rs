//! Sums over a stretch of a realisation's measured rows, for the estimators' own scans of
//! them: the moments of consecutive segments (`wbcls`'s), written once over the four lanes
//! of `numeric::simd` (portable, or AVX2 where the CPU has it: the same operations in the
//! same order, so the same bits). The scans themselves are their estimators' (`wbcls.rs`,
//! `rls/scan.rs`).

use super::{GradeSums, Moments, RowsView};
#[cfg(target_arch = "x86_64")]
use crate::numeric::simd::Avx2;
use crate::numeric::simd::{Lanes, Lanes4, Quad, Scalar};

const LANES: usize = 4;

/// The moments of rows `start..end` (N = the row count). With `constant`, the sums of
/// x̃₁ and x̃₃ alone (Σx̃₁², Σx̃₁x̃₃, Σx̃₃², Σx̃₁, Σx̃₃) are taken from it instead of being
/// summed: the caller passes them where those columns are noise-free (the segment's of
/// `wbcls::WeightSegments`); where `rows.noise_free_y` says ỹ is noise-free too, so are
/// Σx̃₁ỹ, Σx̃₃ỹ and Σỹ. With `grade`, the
/// sums of the grade term ([`GradeSums`]) as well (`None` without).
pub fn segment_moments(
    rows: RowsView<'_>,
    start: usize,
    end: usize,
    constant: Option<&Moments>,
    grade: bool,
) -> Moments {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = Avx2::detect() {
        // SAFETY: the token proves the CPU has AVX2.
        return unsafe { segment_moments_avx2(avx2, rows, start, end, constant, grade) };
    }
    segment_moments_lanes(Quad, rows, start, end, constant, grade)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn segment_moments_avx2(
    avx2: Avx2,
    rows: RowsView<'_>,
    start: usize,
    end: usize,
    constant: Option<&Moments>,
    grade: bool,
) -> Moments {
    segment_moments_lanes(avx2, rows, start, end, constant, grade)
}

/// A product of columns summed in lanes: columns `.0` and `.1` of the four given, or column
/// `.0` alone when `.1` is [`ALONE`].
type Term = (usize, usize);

/// The second factor of a [`Term`] that is one column alone.
const ALONE: usize = usize::MAX;

/// Term `(x, z)` of `cols` at rows `i .. i + M::WIDTH` in the lanes of `m`: column x alone,
/// or its product with column z. A function, not a closure: a closure's body is not
/// compiled with the caller's target features, so the intrinsics in it would be calls.
#[inline(always)]
fn term<M: Lanes>(m: M, cols: &[&[f64]; 4], (x, z): Term, i: usize) -> M::F64 {
    if z == ALONE {
        m.load(cols[x], i)
    } else {
        m.load(cols[x], i) * m.load(cols[z], i)
    }
}

/// Each term summed over rows `0..n` of `cols`, row i into lane i mod 4 for the groups of
/// four and into lane 0 for the rows after them, in the lanes of `l` (portable, or one AVX2
/// register: the same bits). Always inlined, so that the terms are constants of the loop.
#[inline(always)]
fn lane_sums<L: Lanes4, const K: usize>(
    l: L,
    cols: [&[f64]; 4],
    terms: [Term; K],
    n: usize,
) -> [L::F64; K] {
    let used = |c: usize| terms.iter().any(|&(x, z)| x == c || z == c);
    for (c, col) in cols.iter().enumerate() {
        assert!(!used(c) || col.len() >= n);
    }
    let whole = n - n % LANES;
    let mut acc = [l.splat(0.0); K];
    for i in (0..whole).step_by(LANES) {
        for (a, &t) in acc.iter_mut().zip(&terms) {
            *a = *a + term(l, &cols, t, i);
        }
    }
    for i in whole..n {
        for (a, &t) in acc.iter_mut().zip(&terms) {
            // Into lane 0 alone: −0 is the exact identity of the others (x + (−0) = x for
            // every x, ±0 included).
            *a = *a + l.load(&[term(Scalar, &cols, t, i), -0.0, -0.0, -0.0], 0);
        }
    }
    acc
}

/// Each term summed over all rows of `cols` (`n` rows): [`lane_sums`], then each sum
/// (l₀ + l₁) + (l₂ + l₃), four sums at a time ([`Lanes4::reduce_each`]). The sums below are
/// this with their lists of terms; a term's lanes are summed apart from the others', so a
/// term has the same bits in any list.
#[inline(always)]
fn sums<L: Lanes4, const K: usize>(
    l: L,
    cols: [&[f64]; 4],
    terms: [Term; K],
    n: usize,
) -> [f64; K] {
    l.reduce_each(lane_sums(l, cols, terms, n))
}

/// The sums that involve w or ỹ: [Σx̃₁ỹ, Σx̃₃ỹ, Σx̃₁w, Σx̃₃w, Σw², Σwỹ, Σw, Σỹ].
#[inline(always)]
fn noisy_sums<L: Lanes4>(l: L, f: &[f64], w: &[f64], c: &[f64], y: &[f64]) -> [f64; 8] {
    // Columns 0..4: x̃₁, w, x̃₃, ỹ.
    let terms = [
        (0, 3),
        (2, 3),
        (0, 1),
        (2, 1),
        (1, 1),
        (1, 3),
        (1, ALONE),
        (3, ALONE),
    ];
    sums(l, [f, w, c, y], terms, f.len())
}

/// The sums that involve w: [Σx̃₁w, Σx̃₃w, Σw², Σwỹ, Σw] (those of [`noisy_sums`]).
#[inline(always)]
fn w_sums<L: Lanes4>(l: L, f: &[f64], w: &[f64], c: &[f64], y: &[f64]) -> [f64; 5] {
    // Columns 0..4: x̃₁, w, x̃₃, ỹ.
    let terms = [(0, 1), (2, 1), (1, 1), (1, 3), (1, ALONE)];
    sums(l, [f, w, c, y], terms, f.len())
}

/// The sums of ỹ without w: [Σx̃₁ỹ, Σx̃₃ỹ, Σỹ] of rows `f`, `c`, `y`, the same bits as
/// [`segment_moments`] sums them (the portable build; the AVX2 build agrees bit for bit).
/// For the regression's noise-free sums over each segment (`wbcls::WeightSegments`).
pub(crate) fn output_sums(f: &[f64], c: &[f64], y: &[f64]) -> [f64; 3] {
    // Columns 0..4: x₁, (none), x₃, y.
    sums(Quad, [f, &[], c, y], [(0, 3), (2, 3), (3, ALONE)], f.len())
}

/// The sums of x̃₁ and x̃₃ alone: [Σx̃₁², Σx̃₁x̃₃, Σx̃₃², Σx̃₁, Σx̃₃].
#[inline(always)]
fn regressor_sums<L: Lanes4>(l: L, f: &[f64], c: &[f64]) -> [f64; 5] {
    let terms = [(0, 0), (0, 2), (2, 2), (0, ALONE), (2, ALONE)];
    sums(l, [f, &[], c, &[]], terms, f.len())
}

/// The sums of the grade term s̃: [Σs̃, Σx̃₁s̃, Σx̃₃s̃, Σws̃].
#[inline(always)]
fn grade_sums<L: Lanes4>(l: L, f: &[f64], w: &[f64], c: &[f64], s: &[f64]) -> GradeSums {
    // Columns 0..4: x̃₁, w, x̃₃, s̃.
    let terms = [(3, ALONE), (0, 3), (2, 3), (1, 3)];
    let [s_s, s_1s, s_3s, s_ws] = sums(l, [f, w, c, s], terms, f.len());
    GradeSums {
        s_s,
        s_1s,
        s_3s,
        s_ws,
    }
}

/// `m`, the moments of a segment's rows, with the sums [`segment_moments`] takes from
/// `constant` taken from it: those of x̃₁ and x̃₃ alone, and where `noise_free_y` those of
/// ỹ without w (Σx̃₁ỹ, Σx̃₃ỹ, Σỹ).
#[inline(always)]
pub(crate) fn with_constants(
    m: Moments,
    constant: Option<&Moments>,
    noise_free_y: bool,
) -> Moments {
    let Some(c) = constant else { return m };
    let (s_1y, s_3y, s_y) = match noise_free_y {
        true => (c.s_1y, c.s_3y, c.s_y),
        false => (m.s_1y, m.s_3y, m.s_y),
    };
    Moments {
        s_11: c.s_11,
        s_13: c.s_13,
        s_33: c.s_33,
        s_1: c.s_1,
        s_3: c.s_3,
        s_1y,
        s_3y,
        s_y,
        ..m
    }
}

#[inline(always)]
pub(crate) fn segment_moments_lanes<L: Lanes4>(
    l: L,
    rows: RowsView<'_>,
    start: usize,
    end: usize,
    constant: Option<&Moments>,
    grade: bool,
) -> Moments {
    let (f, w, c, y) = (
        &rows.f[start..end],
        &rows.w[start..end],
        &rows.c[start..end],
        &rows.y[start..end],
    );
    // An `if`, not a closure: a closure is not inlined into the AVX2 functions with it.
    let grade = if grade {
        Some(grade_sums(l, f, w, c, &rows.s[start..end]))
    } else {
        None
    };
    let [s_1y, s_3y, s_1w, s_3w, s_ww, s_wy, s_w, s_y] = match constant {
        // ỹ the regression's: its sums without w are the segment's noise-free ones.
        Some(m) if rows.noise_free_y => {
            let [s_1w, s_3w, s_ww, s_wy, s_w] = w_sums(l, f, w, c, y);
            [m.s_1y, m.s_3y, s_1w, s_3w, s_ww, s_wy, s_w, m.s_y]
        }
        _ => noisy_sums(l, f, w, c, y),
    };
    let [s_11, s_13, s_33, s_1, s_3] = match constant {
        Some(m) => [m.s_11, m.s_13, m.s_33, m.s_1, m.s_3],
        None => regressor_sums(l, f, c),
    };
    Moments {
        s_11,
        s_13,
        s_33,
        s_1y,
        s_3y,
        s_1w,
        s_3w,
        s_ww,
        s_wy,
        s_w,
        s_1,
        s_3,
        s_y,
        n: (end - start) as f64,
        grade,
    }
}
