use super::*;
use crate::estimate::moments::segment_sums::{segment_moments, segment_moments_lanes};

/// Deterministic rows y = xθ + wiggle over `n` samples `dt` apart.
fn rows_every(dt: f64, n: usize) -> (Vec<f64>, [Vec<f64>; 4]) {
    let t: Vec<f64> = (0..n).map(|i| dt * i as f64).collect();
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

/// The time steps of the tests: 0.1 s (every group checked) and 0.01 s (every seventh,
/// as on the thesis cycle, so the checks put aside have unchecked groups between them).
const STEPS: [f64; 2] = [0.1, 0.01];

fn view(cols: &[Vec<f64>; 4]) -> RowsView<'_> {
    RowsView {
        f: &cols[0],
        w: &cols[1],
        c: &cols[2],
        y: &cols[3],
        s: &cols[3],
        noise_free_f_c: false,
        noise_free_y: false,
        chunks: RowChunks::NONE,
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
    let cases = STEPS
        .into_iter()
        .flat_map(|dt| [3usize, 401, 1203, 1204].map(|n| (dt, n)));
    for (dt, n) in cases {
        let (t, cols) = rows_every(dt, n);
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
                assert_eq!(got, want, "dt {dt} n {n} λ {lambda} band {band}");
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
                        "dt {dt} n {n} λ {lambda}: {x} vs {y}"
                    );
                }
            }
        }
    }
}

/// The scan of all rows in one portable pass, with the sum `FORGET` says, summing the
/// terms `FREE` leaves to be summed (the others' states from the plan of the rows' own
/// x₁, x₃, y).
fn portable<const FORGET: bool, const FREE: u8>(
    cols: &[Vec<f64>; 4],
    t: &[f64],
    lambda: f64,
) -> RlsResult {
    let n = t.len();
    let own = Some([&cols[0][..], &cols[2][..], &cols[3][..]]);
    let plan = Arc::new(RlsPlan::new(t, own, lambda));
    let mut scan = RlsScan::new(3.3, Arc::clone(&plan), 5e-4, 1e-5, n);
    scan.run
        .advance_body::<_, FORGET, FREE>(Quad, &plan, view(cols), n);
    scan.finish()
}

#[test]
fn the_dispatched_and_portable_builds_agree_bit_for_bit() {
    for dt in STEPS {
        dispatched_and_portable_agree(dt);
    }
}

fn dispatched_and_portable_agree(dt: f64) {
    let (t, cols) = rows_every(dt, 1203);
    for lambda in [1.0, 0.995] {
        let want = rls_scan(view(&cols), &t, 3.3, lambda, 5e-4, 1e-5);
        assert_eq!(want, portable::<true, FREE_NONE>(&cols, &t, lambda));
        // The planned terms' states taken from the plan: the same bits.
        assert_eq!(want, portable::<true, FREE_F_C>(&cols, &t, lambda));
        assert_eq!(want, portable::<true, FREE_F_C_Y>(&cols, &t, lambda));
    }
    // λ = 1: the specialised sum is the general one with factors of exactly 1.
    let want = portable::<true, FREE_NONE>(&cols, &t, 1.0);
    assert_eq!(want, portable::<false, FREE_NONE>(&cols, &t, 1.0));
    assert_eq!(want, portable::<false, FREE_F_C>(&cols, &t, 1.0));
    assert_eq!(want, portable::<false, FREE_F_C_Y>(&cols, &t, 1.0));
    // The segment sums (`wbcls`'s) of the same rows, dispatched and portable.
    for (a, b) in [(0, 1203), (5, 18), (100, 103)] {
        for grade in [false, true] {
            assert_eq!(
                segment_moments(view(&cols), a, b, None, grade),
                segment_moments_lanes(Quad, view(&cols), a, b, None, grade)
            );
        }
    }
}

#[test]
fn a_scan_taken_in_pieces_is_the_scan_in_one_pass_bit_for_bit() {
    // The kernel advances the scan block by block (multiples of four rows) while it
    // measures them; the settle row needs a band that is met part of the way. The scan
    // of rows whose x̃₁, x̃₃ (and ỹ) are the regression's takes the states of the terms
    // of those columns from the regression's plan: the same bits as summing them, with
    // ỹ the regression's and with ỹ moved (output noise).
    let cases = STEPS
        .into_iter()
        .flat_map(|dt| [3usize, 401, 1203, 1204].map(|n| (dt, n)));
    for (dt, n) in cases {
        let (t, cols) = rows_every(dt, n);
        let mut moved = cols.clone();
        for (i, y) in moved[3].iter_mut().enumerate() {
            *y += 1e-3 * ((i * 31 % 17) as f64 - 8.0);
        }
        for lambda in [1.0, 0.995] {
            let own = [&cols[0][..], &cols[2][..], &cols[3][..]];
            let plan = Arc::new(RlsPlan::new(&t, Some(own), lambda));
            let unplanned = Arc::new(RlsPlan::new(&t, None, lambda));
            fn free(cols: &[Vec<f64>; 4], y_free: bool) -> RowsView<'_> {
                RowsView {
                    noise_free_f_c: true,
                    noise_free_y: y_free,
                    ..view(cols)
                }
            }
            let cases = [
                (&unplanned, view(&cols), view(&cols)),
                (&plan, free(&cols, true), view(&cols)),
                (&plan, free(&moved, false), view(&moved)),
            ];
            for (plan, rows, plain) in cases {
                let whole = rls_scan(plain, &t, 3.3, lambda, 5e-4, 5e-5);
                for piece in [4, 256, 1000] {
                    let mut scan = RlsScan::new(3.3, Arc::clone(plan), 5e-4, 5e-5, n);
                    let mut end = 0;
                    while end < n {
                        end = (end + piece).min(n);
                        scan.advance(rows, end);
                    }
                    let what = format!(
                        "dt {dt} n {n} λ {lambda} pieces of {piece}, free {} {}",
                        rows.noise_free_f_c, rows.noise_free_y
                    );
                    assert_eq!(scan.finish(), whole, "{what}");
                }
            }
        }
    }
}
