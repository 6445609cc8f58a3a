use super::*;
use crate::estimate::channels::Channel;
use crate::estimate::moments::segment_sums::segment_moments;
use crate::estimate::moments::test_draws::{block_draws, channel_draws};
use crate::estimate::regression::test_regression as regression;
use crate::estimate::sums::Sum;
use crate::noise::{BLOCK, NormalStream};
#[cfg(target_arch = "x86_64")]
use crate::numeric::simd::Avx2;
use crate::numeric::simd::Quad;

fn moments(reg: &Regression, noise: NoiseLevels, general: bool) -> Moments {
    let mut acc = if general {
        MomentAccumulator::new_general(reg, noise)
    } else {
        MomentAccumulator::new(reg, noise)
    };
    let mut speed = NormalStream::for_realisation(1, 0, Channel::Velocity.stream(), 0);
    let mut output = NormalStream::for_realisation(1, 0, Channel::Output.stream(), 0);
    let (mut e, mut eta) = ([0.0; BLOCK], [0.0; BLOCK]);
    for start in (0..reg.len()).step_by(BLOCK) {
        let len = BLOCK.min(reg.len() - start);
        speed.fill_block(&mut e[..len]);
        output.fill_block(&mut eta[..len]);
        acc.add_block(
            start,
            len,
            BlockNoise::from_fn(|c| match c {
                Channel::Velocity => Some(&e[..len]),
                Channel::Output => Some(&eta[..len]),
                _ => None,
            }),
            None,
        );
    }
    acc.finish()
}

#[test]
fn fast_and_general_paths_build_the_same_moments() {
    let reg = regression();
    let mut noise = NoiseLevels::default();
    noise[Channel::Velocity] = 0.7;
    noise[Channel::Output] = 0.3;
    let a = moments(&reg, noise, false);
    let b = moments(&reg, noise, true);
    // Same products summed in a different grouping: agreement to rounding (1e-12
    // relative is ~10^4 ulps of headroom for 6001 terms).
    for (s, (x, y)) in Sum::ALL.into_iter().zip(a.sums().into_iter().zip(b.sums())) {
        assert!(
            (x - y).abs() <= 1e-12 * x.abs().max(y.abs()),
            "{s:?}: {x} vs {y}"
        );
    }
    assert_eq!(a.n, b.n);
}

#[test]
fn rows_whose_w_the_sums_write_equal_the_rows_pushed_whole() {
    // A `Rows` reused from a realisation with other draws (so w's room holds stale
    // values), filled block by block with w written by the fast path's sums where they
    // write it, against rows pushed with w computed by `push_block`: the same view, bit
    // for bit, for speed and output noise, output noise alone (w not written by the
    // sums), and speed noise under a differentiated acceleration's noise.
    let reg = regression();
    let n = reg.len();
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for (sd_v, sd_y, derivative) in [(0.4, 0.2, false), (0.0, 0.2, false), (0.4, 0.0, true)] {
        let mut noise = NoiseLevels::default();
        noise[Channel::Velocity] = sd_v;
        noise[Channel::Output] = sd_y;
        let d: Vec<f64> = (0..n).map(|i| 1e-3 * (i % 7) as f64).collect();
        let fill = |rows: &mut Rows, r: u64, written: bool| {
            rows.reset(&reg, &noise);
            let draws = channel_draws(n, 9, r);
            let mut acc = MomentAccumulator::new(&reg, noise);
            for start in (0..n).step_by(BLOCK) {
                let len = BLOCK.min(n - start);
                let block = block_draws(&draws, &noise, start, len);
                let d = derivative.then(|| &d[start..start + len]);
                if written && acc.writes_w() {
                    acc.add_block_writing_w(start, len, block, d, rows.w_room(len));
                } else {
                    acc.add_block(start, len, block, d);
                }
                rows.push_block(&reg, &noise, start, len, block, d);
            }
        };
        let (mut written, mut pushed) = (Rows::new(&reg, &noise), Rows::new(&reg, &noise));
        fill(&mut written, 1, true);
        fill(&mut written, 2, true);
        fill(&mut pushed, 2, false);
        let (a, b) = (written.view(&reg), pushed.view(&reg));
        assert_eq!(a.len(), n);
        for (x, y) in [(a.w, b.w), (a.y, b.y), (a.f, b.f), (a.c, b.c)] {
            assert_eq!(
                bits(x),
                bits(y),
                "σ_v {sd_v}, σ_y {sd_y}, derivative {derivative}"
            );
        }
    }
}

/// The sums as the kernel computed them before its general path was vectorised, row by
/// row: each channel's perturbation of one sample (the grade's sin and cos of σ_θ δ by
/// `f64::sin_cos`), then every product added in turn, blocks of [`BLOCK`] summed apart.
fn row_by_row(
    reg: &Regression,
    noise: &NoiseLevels,
    draws: &[Vec<f64>],
    derivative: Option<&[f64]>,
) -> (Moments, Moments) {
    let (mut total, mut absolute) = (Moments::default(), Moments::default());
    for start in (0..reg.len()).step_by(BLOCK) {
        let mut b = Moments::default();
        let mut grade = GradeSums::default();
        for i in start..(start + BLOCK).min(reg.len()) {
            let draw = |c: Channel| noise[c] * draws[c.index()][i];
            let f = reg.f[i] + draw(Channel::Force);
            let v = reg.v[i] + draw(Channel::Velocity);
            let (sd, cd) = draw(Channel::Grade).sin_cos();
            let (sin, cos) = (reg.sin_grade[i], reg.cos_grade[i]);
            let (sin, cos) = (sin * cd + cos * sd, cos * cd - sin * sd);
            let s = reg.g * sin;
            let mut y = reg.accel[i] + s + draw(Channel::Output);
            if let Some(d) = derivative {
                y += d[i];
            }
            let row = [f, v * v, -reg.g * cos, y];
            b.add_row(&row);
            grade.add_row(&row, s);
            absolute.add_row(&row.map(f64::abs));
        }
        b.grade = Some(grade);
        total.add(&b);
    }
    let n = reg.len() as f64;
    (Moments { n, ..total }, absolute)
}

#[test]
fn the_vectorised_general_path_keeps_the_row_by_row_sums_within_rounding() {
    // Every channel on, and a derivative's noise: the general path (the block measured in
    // one pass, the grade's gravity terms turned by the short series of its small angle,
    // the sums in four lanes) and the fast path of a differentiated acceleration against
    // the sums row by row as they were first computed (libm's sin and cos of the small
    // angle, the angle addition of sin θ and cos θ). Either way the turned terms are within
    // about an ulp of the true ones (numeric/trig/turn.rs's tests: the two within 2 ε of
    // each other), which moves a term by a few ε of itself, and the lanes only regroup the
    // additions: each order's rounding error is below
    // (N − 1) u Σ|term| (Higham, Accuracy and Stability of Numerical Algorithms, 2nd ed.,
    // §4.2; u = ε/2), so the two agree within N ε Σ|term| (1.3e-12 Σ|term| for these
    // 6001 rows); the largest relative difference is printed.
    let reg = regression();
    let n = reg.len();
    let draws = channel_draws(n, 3, 7);
    let derivative: Vec<f64> = draws[Channel::Velocity.index()]
        .windows(3)
        .map(|e| 0.4 * (e[2] - e[0]) * 50.0)
        .chain([0.0, 0.0])
        .collect();
    let check = |noise: NoiseLevels, derivative: Option<&[f64]>| {
        let mut acc = MomentAccumulator::new_general(&reg, noise);
        let mut fast = MomentAccumulator::new(&reg, noise);
        for start in (0..n).step_by(BLOCK) {
            let len = BLOCK.min(n - start);
            let block = block_draws(&draws, &noise, start, len);
            let d = derivative.map(|d| &d[start..start + len]);
            acc.add_block(start, len, block, d);
            fast.add_block(start, len, block, d);
        }
        let (want, absolute) = row_by_row(&reg, &noise, &draws, derivative);
        let mut got = vec![("general", acc.finish())];
        if noise.fast_path() {
            got.push(("fast", fast.finish()));
        }
        for (path, m) in got {
            let mut worst = 0.0f64;
            for s in Sum::ALL {
                let (x, y) = (m[s], want[s]);
                assert!(
                    (x - y).abs() <= n as f64 * f64::EPSILON * absolute[s],
                    "{path} {noise:?} {s:?}: {x} vs {y}"
                );
                worst = worst.max((x - y).abs() / y.abs());
            }
            println!("{path}: largest relative difference {worst:.1e}");
        }
    };
    let mut noise = NoiseLevels::default();
    noise[Channel::Velocity] = 0.4;
    noise[Channel::Output] = 0.2;
    check(noise, Some(&derivative));
    noise[Channel::Grade] = 0.01;
    noise[Channel::Force] = 30.0;
    check(noise, None);
    check(noise, Some(&derivative));
    // Grade noise without force noise: Σx̃₁² and Σx̃₁ the regression's.
    noise[Channel::Force] = 0.0;
    check(noise, Some(&derivative));
}

#[test]
fn the_noise_free_force_sums_agree_with_the_summed_ones_within_1e_12() {
    // Grade and speed noise, no force noise: the realisation takes Σx̃₁² and Σx̃₁ from the
    // regression (exactly rounded sums) where the pass once summed them block by block in
    // four lanes. Against those summed values (each block's rows measured and summed by
    // `segment_moments`, whose bits the pass's are: the dispatched-blocks test above, the
    // blocks added in order): every other sum keeps its bits, and these two agree within
    // 1e-12 relative (the summed ones' rounding error is below (N − 1) u Σ|term|, 6.7e-13 of
    // these positive terms for the 6001 rows: Higham, Accuracy and Stability of Numerical
    // Algorithms, 2nd ed., §4.2).
    let reg = regression();
    let n = reg.len();
    // Positive terms, for which Σ|term| is the sum itself (the bound above).
    assert!(reg.f.iter().all(|&f| f > 0.0), "positive forces");
    let mut noise = NoiseLevels::default();
    noise[Channel::Velocity] = 0.4;
    noise[Channel::Grade] = 0.01;
    let draws = channel_draws(n, 3, 11);
    let mut acc = MomentAccumulator::new(&reg, noise);
    let mut summed = Moments::default();
    let mut block = MeasuredBlock::new();
    for start in (0..n).step_by(BLOCK) {
        let len = BLOCK.min(n - start);
        let draws = block_draws(&draws, &noise, start, len);
        acc.add_block(start, len, draws, None);
        let b = Block {
            reg: &reg,
            levels: &noise,
            start,
            len,
            draws,
            derivative: None,
        };
        block.measure_by_samples(b);
        summed.add(&segment_moments(block.view(&reg), 0, len, None, false));
    }
    let got = acc.finish();
    for s in Sum::ALL {
        let (x, y) = (got[s], summed[s]);
        match s {
            Sum::FF | Sum::F => assert!((x - y).abs() <= 1e-12 * y.abs(), "{s:?}: {x} vs {y}"),
            _ => assert_eq!(x.to_bits(), y.to_bits(), "{s:?}"),
        }
    }
    assert_eq!((got.s_11, got.s_1), (reg.xtx[(0, 0)], reg.sum_f));
    let relative = |x: f64, y: f64| (x - y).abs() / y.abs();
    println!(
        "relative differences: Σx̃₁² {:.1e}, Σx̃₁ {:.1e}",
        relative(got.s_11, summed.s_11),
        relative(got.s_1, summed.s_1)
    );
}

/// The five measured columns of two views bit for bit, and which columns are noise-free.
fn assert_same_rows(want: RowsView<'_>, got: RowsView<'_>, what: &str) {
    let bits = |v: &[f64]| v.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    for (x, y) in [
        (want.f, got.f),
        (want.w, got.w),
        (want.c, got.c),
        (want.y, got.y),
        (want.s, got.s),
    ] {
        assert_eq!(bits(x), bits(y), "{what}");
    }
    assert_eq!(want.noise_free_f_c, got.noise_free_f_c, "{what}");
}

#[test]
fn the_dispatched_and_portable_blocks_agree_bit_for_bit() {
    // The block measured one sample at a time (each channel's `measure` on one
    // number), in one pass in the portable lanes, and in one pass as dispatched (AVX2
    // where the CPU has it), and its moments summed in that pass: the same operations,
    // so the same bits. Each channel on or off (the speed's or the air speed's), the grade
    // noise with speed noise alone (the
    // grade-noise study), grade angles beyond the short series' 1/32 rad and the
    // polynomials' π/4 (σ_θ = 0.5: most of each block beyond the first, lanes of either
    // kind side by side, a few beyond the second in every block),
    // with and without a derivative's noise, whole and partial blocks.
    let reg = regression();
    let levels = |v: f64, y: f64, theta: f64, f: f64| {
        let mut noise = NoiseLevels::default();
        noise[Channel::Velocity] = v;
        noise[Channel::Output] = y;
        noise[Channel::Grade] = theta;
        noise[Channel::Force] = f;
        noise
    };
    let draws = channel_draws(BLOCK, 4, 2);
    let d: Vec<f64> = (0..BLOCK).map(|j| 0.01 * j as f64 - 1.0).collect();
    // Every combination of the four channels on or off (the pass is compiled for each),
    // each of them with the air-speed channel in place of the speed's, and the grade-noise
    // study's levels.
    let combinations = (0..32).map(|bits: u32| {
        let on = |bit: u32, sd: f64| if bits >> bit & 1 == 1 { sd } else { 0.0 };
        let mut noise = levels(on(0, 0.4), on(1, 0.2), on(2, 0.01), on(3, 30.0));
        if bits >> 4 & 1 == 1 {
            noise[Channel::AirSpeed] = noise[Channel::Velocity].max(0.3);
            noise[Channel::Velocity] = 0.0;
        }
        noise
    });
    for noise in combinations.chain([levels(1.0, 0.0, 0.001, 0.0), levels(0.4, 0.0, 0.5, 0.0)]) {
        for derivative in [None, Some(&d[..])] {
            for (start, len) in [(0, BLOCK), (1000, 253), (3, 7)] {
                let block_noise =
                    BlockNoise::from_fn(|c| noise.is_on(c).then(|| &draws[c.index()][..len]));
                let d = derivative.map(|d| &d[..len]);
                let mut blocks = [(); 3].map(|_| MeasuredBlock::new());
                let b = Block {
                    reg: &reg,
                    levels: &noise,
                    start,
                    len,
                    draws: block_noise,
                    derivative: d,
                };
                blocks[0].measure_by_samples(b);
                blocks[1].measure_one_pass(Quad, b);
                blocks[2].measure(b);
                let want = blocks[0].view(&reg);
                for got in &blocks[1..] {
                    let what = format!("{noise:?} block {start}+{len}");
                    assert_same_rows(want, got.view(&reg), &what);
                }
                // The block's moments as well: measured and summed in one pass (as
                // dispatched) and in two portable steps, against `segment_moments` of
                // the rows measured channel by channel.
                for (regressors, grade) in [(true, true), (false, true), (true, false)] {
                    let none = Moments::default();
                    let constant = (!regressors).then_some(&none);
                    let mut want = segment_moments(blocks[0].view(&reg), 0, len, constant, grade);
                    if !blocks[0].moved()[0] {
                        // x̃₁ noise-free: its sums alone are left to the realisation.
                        (want.s_11, want.s_1) = (0.0, 0.0);
                    }
                    let mut block = MeasuredBlock::new();
                    let wanted = |rows| Wanted {
                        regressors,
                        grade,
                        rows,
                    };
                    let kept = block.measure_and_sum(b, wanted(true), None);
                    // The rows kept are the measured rows.
                    let what = format!("{noise:?} kept rows {start}+{len}");
                    assert_same_rows(blocks[0].view(&reg), block.view(&reg), &what);
                    // Written where the rows are kept instead: the same rows and sums.
                    let [mut f, mut w, mut c, mut s, mut y] = [(); 5].map(|_| vec![0.0; len]);
                    let out = RowsOut {
                        f: Some(&mut f),
                        w: &mut w,
                        c: Some(&mut c),
                        s: Some(&mut s),
                        y: &mut y,
                        chunks: None,
                        chunk_rows: true,
                    };
                    let elsewhere = block.measure_and_sum(b, wanted(true), Some(out));
                    let [force, grade] = block.moved();
                    let range = start..start + len;
                    let written = RowsView {
                        f: if force { &f } else { &reg.f[range.clone()] },
                        w: &w,
                        c: if grade { &c } else { &reg.c[range.clone()] },
                        y: &y,
                        s: if grade { &s } else { &reg.g_sin[range] },
                        noise_free_f_c: !force && !grade,
                        noise_free_y: false,
                        chunks: RowChunks::NONE,
                    };
                    let what = format!("{noise:?} rows written elsewhere {start}+{len}");
                    assert_same_rows(blocks[0].view(&reg), written, &what);
                    let mut got = vec![
                        kept,
                        elsewhere,
                        block.measure_and_sum(b, wanted(false), None),
                        block.measure_and_sum_in(Quad, b, wanted(true), None),
                        block.measure_and_sum_in(Quad, b, wanted(false), None),
                    ];
                    // The AVX2 build too where the dispatch takes the AVX-512VL one.
                    #[cfg(target_arch = "x86_64")]
                    if let Some(avx2) = Avx2::detect() {
                        for rows in [true, false] {
                            // SAFETY: the token proves the CPU has AVX2.
                            got.push(unsafe {
                                block.measure_and_sum_avx2(avx2, b, wanted(rows), None)
                            });
                        }
                    }
                    let bits = |m: &Moments| {
                        let g = m.grade.map(|g| [g.s_s, g.s_1s, g.s_3s, g.s_ws]);
                        (
                            m.sums().map(f64::to_bits),
                            m.n,
                            g.map(|g| g.map(f64::to_bits)),
                        )
                    };
                    for m in &got {
                        assert_eq!(bits(m), bits(&want), "{noise:?} block {start}+{len}");
                    }
                }
            }
        }
    }
}

#[test]
fn leaving_out_the_grade_sums_keeps_the_other_sums_bit_for_bit() {
    // Grade noise with speed and force noise, whole blocks and a partial last one.
    let reg = regression();
    let n = reg.len();
    let mut noise = NoiseLevels::default();
    noise[Channel::Velocity] = 0.4;
    noise[Channel::Grade] = 0.01;
    noise[Channel::Force] = 30.0;
    let draws = channel_draws(n, 5, 1);
    let [with, without] = [true, false].map(|needed| {
        let mut acc = MomentAccumulator::new(&reg, noise).grade_sums(needed);
        for start in (0..n).step_by(BLOCK) {
            let len = BLOCK.min(n - start);
            let block = block_draws(&draws, &noise, start, len);
            acc.add_block(start, len, block, None);
        }
        acc.finish()
    });
    assert!(with.grade.is_some() && without.grade.is_none());
    assert_eq!(
        with.sums().map(f64::to_bits),
        without.sums().map(f64::to_bits)
    );
    assert_eq!(with.n, without.n);
}

#[test]
fn without_noise_the_moments_are_the_noise_free_normal_equations() {
    let reg = regression();
    let m = MomentAccumulator::new(&reg, NoiseLevels::default());
    let mut acc = m;
    for start in (0..reg.len()).step_by(BLOCK) {
        let len = BLOCK.min(reg.len() - start);
        let none = BlockNoise::default();
        acc.add_block(start, len, none, None);
    }
    let (a, b) = acc.finish().ols_system(reg.k);
    for i in 0..3 {
        assert!((b[i] - reg.xty[i]).abs() <= 1e-12 * reg.xty[i].abs());
        for j in 0..3 {
            assert!((a[(i, j)] - reg.xtx[(i, j)]).abs() <= 1e-12 * reg.xtx[(i, j)].abs());
        }
    }
    // BCLS with σ_v = 0 is OLS.
    assert_eq!(
        acc.finish()
            .bcls_system(reg.k, reg.g, &NoiseLevels::default()),
        (a, b)
    );
}
