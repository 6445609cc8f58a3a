//! Sums over a realisation's measured rows for the estimators that read them: the moments
//! of consecutive segments (`wbcls`) and the running normal equations of `rls`. Both in
//! four lanes like the kernel's block sums, compiled for AVX2 where the CPU has it; the
//! two builds run the same operations in the same order, so they agree bit for bit.

use nalgebra::{Matrix3, Vector3};

use super::moments::{GradeSums, Moments, RowsView};

const LANES: usize = 4;

#[inline(always)]
fn reduce(l: [f64; LANES]) -> f64 {
    (l[0] + l[1]) + (l[2] + l[3])
}

#[inline(always)]
fn mul(a: [f64; LANES], b: [f64; LANES]) -> [f64; LANES] {
    [a[0] * b[0], a[1] * b[1], a[2] * b[2], a[3] * b[3]]
}

/// Least time between two checks of the running `rls` estimate \[s\]: the settle time is
/// resolved to this or to four rows, whichever is longer.
pub const RLS_CHECK_S: f64 = 0.25;

/// The moments of rows `start..end` (N = the row count). With `constant`, the sums of
/// x̃₁ and x̃₃ alone (Σx̃₁², Σx̃₁x̃₃, Σx̃₃², Σx̃₁, Σx̃₃) are taken from it instead of being
/// summed: the caller passes them where those columns are noise-free. With `grade`, the
/// sums of the grade term ([`GradeSums`]) as well (`None` without).
pub fn segment_moments(
    rows: RowsView<'_>,
    start: usize,
    end: usize,
    constant: Option<&Moments>,
    grade: bool,
) -> Moments {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { segment_moments_avx2(rows, start, end, constant, grade) };
        }
    }
    segment_moments_body(rows, start, end, constant, grade)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn segment_moments_avx2(
    rows: RowsView<'_>,
    start: usize,
    end: usize,
    constant: Option<&Moments>,
    grade: bool,
) -> Moments {
    segment_moments_body(rows, start, end, constant, grade)
}

/// The sums that involve w or ỹ: [Σx̃₁ỹ, Σx̃₃ỹ, Σx̃₁w, Σx̃₃w, Σw², Σwỹ, Σw, Σỹ].
#[inline(always)]
fn noisy_sums(f: &[f64], w: &[f64], c: &[f64], y: &[f64]) -> [f64; 8] {
    let n = f.len();
    let whole = n - n % LANES;
    let mut acc = [[0.0; LANES]; 8];
    for i in (0..whole).step_by(LANES) {
        let x1: [f64; LANES] = f[i..i + LANES].try_into().unwrap();
        let w: [f64; LANES] = w[i..i + LANES].try_into().unwrap();
        let x3: [f64; LANES] = c[i..i + LANES].try_into().unwrap();
        let y: [f64; LANES] = y[i..i + LANES].try_into().unwrap();
        let terms = [
            mul(x1, y),
            mul(x3, y),
            mul(x1, w),
            mul(x3, w),
            mul(w, w),
            mul(w, y),
            w,
            y,
        ];
        for (a, t) in acc.iter_mut().zip(terms) {
            for l in 0..LANES {
                a[l] += t[l];
            }
        }
    }
    for i in whole..n {
        let (x1, w, x3, y) = (f[i], w[i], c[i], y[i]);
        let terms = [x1 * y, x3 * y, x1 * w, x3 * w, w * w, w * y, w, y];
        for (a, t) in acc.iter_mut().zip(terms) {
            a[0] += t;
        }
    }
    acc.map(reduce)
}

/// The sums of x̃₁ and x̃₃ alone: [Σx̃₁², Σx̃₁x̃₃, Σx̃₃², Σx̃₁, Σx̃₃].
#[inline(always)]
fn regressor_sums(f: &[f64], c: &[f64]) -> [f64; 5] {
    let n = f.len();
    let whole = n - n % LANES;
    let mut acc = [[0.0; LANES]; 5];
    for i in (0..whole).step_by(LANES) {
        let x1: [f64; LANES] = f[i..i + LANES].try_into().unwrap();
        let x3: [f64; LANES] = c[i..i + LANES].try_into().unwrap();
        let terms = [mul(x1, x1), mul(x1, x3), mul(x3, x3), x1, x3];
        for (a, t) in acc.iter_mut().zip(terms) {
            for l in 0..LANES {
                a[l] += t[l];
            }
        }
    }
    for i in whole..n {
        let (x1, x3) = (f[i], c[i]);
        for (a, t) in acc.iter_mut().zip([x1 * x1, x1 * x3, x3 * x3, x1, x3]) {
            a[0] += t;
        }
    }
    acc.map(reduce)
}

/// The sums of the grade term s̃: [Σs̃, Σx̃₁s̃, Σx̃₃s̃, Σws̃].
#[inline(always)]
fn grade_sums(f: &[f64], w: &[f64], c: &[f64], s: &[f64]) -> GradeSums {
    let n = f.len();
    let whole = n - n % LANES;
    let mut acc = [[0.0; LANES]; 4];
    for i in (0..whole).step_by(LANES) {
        let x1: [f64; LANES] = f[i..i + LANES].try_into().unwrap();
        let w: [f64; LANES] = w[i..i + LANES].try_into().unwrap();
        let x3: [f64; LANES] = c[i..i + LANES].try_into().unwrap();
        let s: [f64; LANES] = s[i..i + LANES].try_into().unwrap();
        let terms = [s, mul(x1, s), mul(x3, s), mul(w, s)];
        for (a, t) in acc.iter_mut().zip(terms) {
            for l in 0..LANES {
                a[l] += t[l];
            }
        }
    }
    for i in whole..n {
        let (x1, w, x3, s) = (f[i], w[i], c[i], s[i]);
        for (a, t) in acc.iter_mut().zip([s, x1 * s, x3 * s, w * s]) {
            a[0] += t;
        }
    }
    let [s_s, s_1s, s_3s, s_ws] = acc.map(reduce);
    GradeSums {
        s_s,
        s_1s,
        s_3s,
        s_ws,
    }
}

#[inline(always)]
fn segment_moments_body(
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
    let grade = grade.then(|| grade_sums(f, w, c, &rows.s[start..end]));
    let [s_1y, s_3y, s_1w, s_3w, s_ww, s_wy, s_w, s_y] = noisy_sums(f, w, c, y);
    let [s_11, s_13, s_33, s_1, s_3] = match constant {
        Some(m) => [m.s_11, m.s_13, m.s_33, m.s_1, m.s_3],
        None => regressor_sums(f, c),
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

/// The exponentially weighted normal equations A = Σ λ^(N−1−i) x̃_i x̃_iᵀ, b likewise, of
/// all rows (k = ½ρA for column 2, `t` the row times), and the first checked row from which
/// on θ̂₁ of the rows so far stays within `target ± band` at every check (`None`: outside
/// or undefined at the last). Checks fall on the last row of a group of four at least
/// [`RLS_CHECK_S`] after the previous check, the last row of the last group, and every
/// row after it.
pub fn rls_scan(
    rows: RowsView<'_>,
    t: &[f64],
    k: f64,
    lambda: f64,
    target: f64,
    band: f64,
) -> ((Matrix3<f64>, Vector3<f64>), Option<usize>) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { rls_scan_avx2(rows, t, k, lambda, target, band) };
        }
    }
    if lambda == 1.0 {
        rls_scan_body::<false>(rows, t, k, lambda, target, band)
    } else {
        rls_scan_body::<true>(rows, t, k, lambda, target, band)
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn rls_scan_avx2(
    rows: RowsView<'_>,
    t: &[f64],
    k: f64,
    lambda: f64,
    target: f64,
    band: f64,
) -> ((Matrix3<f64>, Vector3<f64>), Option<usize>) {
    if lambda == 1.0 {
        rls_scan_body::<false>(rows, t, k, lambda, target, band)
    } else {
        rls_scan_body::<true>(rows, t, k, lambda, target, band)
    }
}

/// The nine running sums [p, q, e, s, u, v, b₁, b₂, b₃] of A = [[p, q, e], [q, s, u],
/// [e, u, v]] and b, from one row.
#[inline(always)]
fn products(x1: f64, x2: f64, x3: f64, y: f64) -> [f64; 9] {
    [
        x1 * x1,
        x1 * x2,
        x1 * x3,
        x2 * x2,
        x2 * x3,
        x3 * x3,
        x1 * y,
        x2 * y,
        x3 * y,
    ]
}

/// Whether θ̂₁ = (A⁻¹b)₁ lies within `target ± band`, by the first column's cofactors
/// (|num − target·det| ≤ band·|det|, no division); false when A is singular.
#[inline(always)]
fn settled(a: &[f64; 9], target: f64, band: f64) -> bool {
    let [p, q, e, s, u, v, b1, b2, b3] = *a;
    let c11 = s * v - u * u;
    let det = p * c11 - q * (q * v - u * e) + e * (q * u - s * e);
    let num = b1 * c11 - q * (b2 * v - u * b3) + e * (b2 * u - s * b3);
    det != 0.0 && (num - target * det).abs() <= band * det.abs()
}

#[inline(always)]
fn rls_scan_body<const FORGET: bool>(
    rows: RowsView<'_>,
    t: &[f64],
    k: f64,
    lambda: f64,
    target: f64,
    band: f64,
) -> ((Matrix3<f64>, Vector3<f64>), Option<usize>) {
    let n = rows.len();
    let whole = n - n % LANES;
    // Lane j holds the rows ≡ j (mod 4), each weighted so that the sum of the lanes after
    // a group of four rows is the state after its last row: a new row of lane j enters
    // with λ^(3−j), and every group ages all lanes by λ⁴.
    let entry = [lambda.powi(3), lambda.powi(2), lambda, 1.0];
    let age = lambda.powi(4);
    let mut lanes = [[0.0; LANES]; 9];
    let mut state = [0.0; 9];
    // The first checked row of the current run of checks inside the band.
    let mut settle = None;
    let mut check = |state: &[f64; 9], row: usize| {
        if !settled(state, target, band) {
            settle = None;
        } else if settle.is_none() {
            settle = Some(row);
        }
    };
    let mut last_check = f64::NEG_INFINITY;
    let (f, w, c, y) = (rows.f, rows.w, rows.c, rows.y);
    for start in (0..whole).step_by(LANES) {
        let x1: [f64; LANES] = f[start..start + LANES].try_into().unwrap();
        let w: [f64; LANES] = w[start..start + LANES].try_into().unwrap();
        let x2 = w.map(|w| -k * w);
        let x3: [f64; LANES] = c[start..start + LANES].try_into().unwrap();
        let y: [f64; LANES] = y[start..start + LANES].try_into().unwrap();
        let terms = [
            mul(x1, x1),
            mul(x1, x2),
            mul(x1, x3),
            mul(x2, x2),
            mul(x2, x3),
            mul(x3, x3),
            mul(x1, y),
            mul(x2, y),
            mul(x3, y),
        ];
        for (lane, t) in lanes.iter_mut().zip(terms) {
            for l in 0..LANES {
                // λ = 1: the factors are exactly 1, so this is the same sum.
                lane[l] = if FORGET {
                    age * lane[l] + entry[l] * t[l]
                } else {
                    lane[l] + t[l]
                };
            }
        }
        let last = start + LANES - 1;
        if t[last] - last_check >= RLS_CHECK_S || last + 1 == whole {
            last_check = t[last];
            state = lanes.map(reduce);
            check(&state, last);
        }
    }
    for i in whole..n {
        let x = products(f[i], -k * w[i], c[i], y[i]);
        for (s, x) in state.iter_mut().zip(x) {
            *s = lambda * *s + x;
        }
        check(&state, i);
    }
    let [p, q, e, s, u, v, b1, b2, b3] = state;
    (
        (
            Matrix3::new(p, q, e, q, s, u, e, u, v),
            Vector3::new(b1, b2, b3),
        ),
        settle,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic rows y = xθ + wiggle over `n` samples 0.1 s apart.
    fn rows(n: usize) -> (Vec<f64>, [Vec<f64>; 4]) {
        let t: Vec<f64> = (0..n).map(|i| 0.1 * i as f64).collect();
        let f: Vec<f64> = t.iter().map(|t| 2000.0 + 200.0 * (0.3 * t).sin()).collect();
        let w: Vec<f64> = t
            .iter()
            .map(|t| (15.0 + 5.0 * (0.11 * t).cos()).powi(2))
            .collect();
        let c: Vec<f64> = t
            .iter()
            .map(|t| -9.81 * (0.05 * (0.07 * t).sin()).cos())
            .collect();
        let theta = [1.0 / 1800.0, 0.35 / 1800.0, 0.0125];
        let k = 3.3;
        let y: Vec<f64> = (0..n)
            .map(|i| {
                let wiggle = 0.05 * ((i * 7919 % 101) as f64 / 50.0 - 1.0);
                theta[0] * f[i] - theta[1] * k * w[i] + theta[2] * c[i] + wiggle
            })
            .collect();
        (t, [f, w, c, y])
    }

    fn view(cols: &[Vec<f64>; 4]) -> RowsView<'_> {
        RowsView {
            f: &cols[0],
            w: &cols[1],
            c: &cols[2],
            y: &cols[3],
            s: &cols[3],
            noise_free_f_c: false,
        }
    }

    /// The checks of `rls_scan` by their definition, on the state of the plain recursion
    /// A_t = λA_{t−1} + x_t x_tᵀ after every row.
    fn naive(
        t: &[f64],
        cols: &[Vec<f64>; 4],
        lambda: f64,
        target: f64,
        band: f64,
    ) -> ([f64; 9], Option<usize>) {
        let n = t.len();
        let whole = n - n % LANES;
        let mut state = [0.0; 9];
        let mut settle = None;
        let mut last_check = f64::NEG_INFINITY;
        for i in 0..n {
            let x = products(cols[0][i], -3.3 * cols[1][i], cols[2][i], cols[3][i]);
            for (s, x) in state.iter_mut().zip(x) {
                *s = lambda * *s + x;
            }
            let checked = if i < whole {
                (i + 1) % LANES == 0 && (t[i] - last_check >= RLS_CHECK_S || i + 1 == whole)
            } else {
                true
            };
            if checked {
                if i < whole {
                    last_check = t[i];
                }
                if !settled(&state, target, band) {
                    settle = None;
                } else if settle.is_none() {
                    settle = Some(i);
                }
            }
        }
        (state, settle)
    }

    #[test]
    fn the_lane_sums_are_the_plain_recursion_and_check_where_it_says() {
        // λ = 1 and λ < 1, with N a multiple of four, not one, and below four; bands of
        // 0.01–1 % around the final 1/M estimate, so the settle row falls at different
        // places (or nowhere). The lanes sum the same products in another order: agreement
        // to 1e-12 relative (rounding of ~1e3 terms).
        for n in [3usize, 401, 1203, 1204] {
            let (t, cols) = rows(n);
            for lambda in [1.0, 0.995] {
                let ((a, b), _) = rls_scan(view(&cols), &t, 3.3, lambda, 0.0, 0.0);
                let final_theta = crate::numeric::linalg::solve_spd(&a, &b).map_or(0.0, |v| v[0]);
                for band in [1e-4, 1e-3, 1e-2] {
                    let (_, got) = rls_scan(
                        view(&cols),
                        &t,
                        3.3,
                        lambda,
                        final_theta,
                        band * final_theta,
                    );
                    let (state, want) = naive(&t, &cols, lambda, final_theta, band * final_theta);
                    assert_eq!(got, want, "n {n} λ {lambda} band {band}");
                    let lanes = [
                        a[(0, 0)],
                        a[(0, 1)],
                        a[(0, 2)],
                        a[(1, 1)],
                        a[(1, 2)],
                        a[(2, 2)],
                        b[0],
                        b[1],
                        b[2],
                    ];
                    for (x, y) in lanes.iter().zip(state) {
                        assert!(
                            (x - y).abs() <= 1e-12 * y.abs().max(1e-300),
                            "n {n} λ {lambda}: {x} vs {y}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn the_dispatched_and_portable_builds_agree_bit_for_bit() {
        let (t, cols) = rows(1203);
        for lambda in [1.0, 0.995] {
            assert_eq!(
                rls_scan(view(&cols), &t, 3.3, lambda, 5e-4, 1e-5),
                rls_scan_body::<true>(view(&cols), &t, 3.3, lambda, 5e-4, 1e-5)
            );
        }
        // λ = 1: the specialised sum is the general one with factors of exactly 1.
        assert_eq!(
            rls_scan_body::<false>(view(&cols), &t, 3.3, 1.0, 5e-4, 1e-5),
            rls_scan_body::<true>(view(&cols), &t, 3.3, 1.0, 5e-4, 1e-5)
        );
        for (a, b) in [(0, 1203), (5, 18), (100, 103)] {
            for grade in [false, true] {
                assert_eq!(
                    segment_moments(view(&cols), a, b, None, grade),
                    segment_moments_body(view(&cols), a, b, None, grade)
                );
            }
        }
    }
}
