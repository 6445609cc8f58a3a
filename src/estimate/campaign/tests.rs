use super::*;

/// Textbook two-sided 95 % quantiles of Student's t at 3 … 15 degrees of freedom (three
/// decimals; e.g. NIST/SEMATECH e-Handbook, table 1.3.6.7.2): the EU criterion's t at
/// n = 4 … 16 runs.
const PRINTED_T: [f64; 13] = [
    3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160, 2.145, 2.131,
];

#[test]
fn the_eu_t_is_students_at_n_minus_one() {
    use statrs::distribution::{ContinuousCDF, StudentsT};
    for n in 4..=40usize {
        let t = student_t_975(n - 1);
        let dist = StudentsT::new(0.0, 1.0, (n - 1) as f64).unwrap();
        // The quantile's defining property, to the CDF's own accuracy.
        assert!(
            (dist.cdf(t) - 0.975).abs() < 1e-9,
            "n = {n}: cdf(t) = {}",
            dist.cdf(t)
        );
        if let Some(&printed) = PRINTED_T.get(n - 4) {
            // The printed table's rounding: half a unit of its third decimal.
            assert!(
                (t - printed).abs() <= 5e-4 + 1e-12,
                "n = {n}: {t} against {printed}"
            );
        }
    }
}

/// Samples of a run decelerating at a constant `a` from `v0`, every `dt`.
fn run_samples(v0: f64, a: f64, dt: f64, n: usize, run: u32) -> (Vec<f64>, Vec<u32>, Vec<f64>) {
    let t: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
    let v = t.iter().map(|t| v0 - a * t).collect();
    (t, vec![run; n], v)
}

#[test]
fn a_uniform_deceleration_takes_two_half_widths_over_a() {
    // v = 30 − 0.5 t: through 20 ± 2 m/s in 8 s whatever the sampling (linear
    // interpolation is exact on a straight line).
    let (t, run, v) = run_samples(30.0, 0.5, 0.3, 200, 0);
    let interval = SpeedInterval {
        speed_m_s: 20.0,
        half_width_m_s: 2.0,
    };
    let times = CoastTimes::measure(&t, &run, |k| v[k], 1, &[interval]);
    assert!((times.times[0] - 8.0).abs() < 1e-12, "{:?}", times.times);
}

#[test]
fn a_run_that_starts_inside_the_interval_or_ends_above_it_has_no_time() {
    let (t, run, v) = run_samples(21.0, 0.5, 0.1, 100, 0);
    let interval = SpeedInterval {
        speed_m_s: 20.0,
        half_width_m_s: 2.0,
    };
    // Starts below 22 m/s.
    assert!(CoastTimes::measure(&t, &run, |k| v[k], 1, &[interval]).times[0].is_nan());
    // Ends at 30 − 0.5 · 9.9 ≈ 25 m/s, above 18.
    let (t, run, v) = run_samples(30.0, 0.5, 0.1, 100, 0);
    assert!(CoastTimes::measure(&t, &run, |k| v[k], 1, &[interval]).times[0].is_nan());
}

#[test]
fn the_eu_criterion_computes_t_s_over_root_n_mean() {
    // Four runs through one interval in 10, 10.2, 9.8 and 10 s: mean 10, s = √(0.08/3).
    let times = CoastTimes {
        times: vec![10.0, 10.2, 9.8, 10.0],
        intervals: 1,
        runs: 4,
    };
    let s = (0.08f64 / 3.0).sqrt();
    let expected = student_t_975(3) * s / (2.0 * 10.0);
    let criterion = EuPrecision {
        max_precision: 0.02,
        min_runs: 4,
    };
    let verdict = criterion.judge(4, &times);
    assert!((verdict.precision - expected).abs() < 1e-15);
    assert_eq!(verdict.passes, expected <= 0.02);
    // A tighter limit fails it; too few runs fail it whatever the spread.
    let strict = EuPrecision {
        max_precision: 0.5 * expected,
        min_runs: 4,
    };
    assert!(!strict.judge(4, &times).passes);
    let more_runs = EuPrecision {
        max_precision: 0.02,
        min_runs: 6,
    };
    assert!(!more_runs.judge(4, &times).passes);
    // A missing time fails.
    let missing = CoastTimes {
        times: vec![10.0, f64::NAN, 9.8, 10.0],
        ..times
    };
    assert!(!criterion.judge(4, &missing).passes);
}

#[test]
fn the_run_count_criterion_counts() {
    let c = RunCount { min_runs: 16 };
    assert!(!c.judge(14, &CoastTimes::default()).passes);
    assert!(c.judge(16, &CoastTimes::default()).passes);
    assert!(c.judge(18, &CoastTimes::default()).passes);
}

#[test]
fn runs_are_told_apart_and_only_the_first_ones_read() {
    // Two runs of one sample series each; only run 0 read when runs = 1.
    let (mut t, mut run, mut v) = run_samples(30.0, 0.5, 0.1, 400, 0);
    let (t1, r1, v1) = run_samples(30.0, 0.25, 0.1, 400, 1);
    t.extend(t1.iter().map(|t| t + 100.0));
    run.extend(r1);
    v.extend(v1);
    let interval = SpeedInterval {
        speed_m_s: 25.0,
        half_width_m_s: 1.0,
    };
    let both = CoastTimes::measure(&t, &run, |k| v[k], 2, &[interval]);
    assert!((both.times[0] - 4.0).abs() < 1e-9 && (both.times[1] - 8.0).abs() < 1e-9);
    let first = CoastTimes::measure(&t, &run, |k| v[k], 1, &[interval]);
    assert_eq!(first.times.len(), 1);
}
