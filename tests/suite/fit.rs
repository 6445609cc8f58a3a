//! `fit` on synthetic logs of a known vehicle, and `simulate-log`.

use super::common::*;
use chassis_mc::fit::{FitSpec, fit, simulate_log};

const TRUTH: [f64; 3] = [1.0 / 1800.0, 0.35 / 1800.0, 0.0125];

/// Synthetic logs fitted.
const LOGS: usize = 50;

fn fit_file(log: &str, realisations: u64) -> String {
    fit_file_seeded(log, realisations, 1)
}

fn fit_file_seeded(log: &str, realisations: u64, seed: u64) -> String {
    format!(
        "seed = {seed}\nrealisations = {realisations}\n\n[log]\nfile = \"{log}\"\n\
         time_column = \"time_s\"\nspeed_column = \"speed_m_s\"\nspeed_unit = \"m/s\"\n\
         force_column = \"force_n\"\ngrade_column = \"grade_rad\"\ngrade_unit = \"rad\"\n\
         acceleration_column = \"accel_m_s2\"\nmin_speed = 0.5\n\n[vehicle]\n\
         frontal_area = 5.5\nair_density = 1.2\ngravity = 9.81\n\n[noise]\nvelocity_sd = 0.1\n\n\
         [estimation]\nestimators = [\"ols\", \"bcls\"]\n"
    )
}

#[test]
fn bootstrap_intervals_cover_the_truth_and_bias_correction_removes_the_bias() {
    // 50 synthetic logs of the thesis car (studies/fit_log.toml: 10 Hz, 600 s, σ_v = 0.1
    // m/s, an ideal accelerometer), each with its own noise seed and its own bootstrap seed
    // (R = 400). There OLS's Cd/M bias is about 2.7 EmpSE. BCLS's 95 % intervals must cover
    // the truth in at least 44 of 50 logs (88 %) for every parameter — the binomial
    // tolerance: P(X ≤ 43) = 0.04 for X ~ Bin(50, 0.95) — and the bias-corrected OLS
    // estimate's mean error over the logs must lie within 3 of its SEs (the spread over
    // the logs / √50) of zero, where uncorrected OLS's Cd/M misses by ~20. Measured: 44,
    // 47, 44 of 50 (over 200 logs 186, 189, 184: the percentile interval covers 92–95 %).
    let tmp = tempfile::tempdir().unwrap();
    let base = study("fit_log.toml", 1);
    let mut covered = [0usize; 3];
    let mut corrected: [Vec<f64>; 3] = Default::default();
    let mut raw: [Vec<f64>; 3] = Default::default();

    for seed in 0..LOGS as u64 {
        let log = tmp.path().join(format!("log{seed}.csv"));
        let s = base
            .clone()
            .with_overrides(None, Some(1000 + seed))
            .unwrap();
        simulate_log(&s, 0, &log).unwrap();
        let spec = FitSpec::parse(
            &fit_file_seeded(&log.display().to_string(), 400, 7000 + seed),
            "fit test",
            tmp.path(),
        )
        .unwrap();
        let result = fit(&spec, &tmp.path().join(format!("out{seed}"))).unwrap();
        for (p, name) in PARAMS.iter().enumerate() {
            let row = |est: &str| {
                result
                    .rows
                    .iter()
                    .find(|r| r.estimator == est && r.parameter == *name)
                    .unwrap()
            };
            let b = row("bcls");
            covered[p] += usize::from(b.ci_low <= TRUTH[p] && TRUTH[p] <= b.ci_high);
            corrected[p].push(row("ols").bias_corrected - TRUTH[p]);
            raw[p].push(row("ols").estimate - TRUTH[p]);
        }
    }
    let z = |v: &[f64]| {
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        mean / (sd / n.sqrt())
    };
    for p in 0..3 {
        eprintln!(
            "{}: BCLS covers in {} of {LOGS}; bias-corrected OLS z = {:.2}, uncorrected z = {:.2}",
            PARAMS[p],
            covered[p],
            z(&corrected[p]),
            z(&raw[p])
        );
    }
    for p in 0..3 {
        assert!(
            covered[p] >= 44,
            "{}: BCLS covers in {} of {LOGS}",
            PARAMS[p],
            covered[p]
        );
        assert!(
            z(&corrected[p]).abs() <= 3.0,
            "{}: corrected OLS z = {}",
            PARAMS[p],
            z(&corrected[p])
        );
    }
    // The correction had something to correct.
    assert!(
        z(&raw[1]).abs() > 6.0,
        "uncorrected OLS Cd/M z = {}",
        z(&raw[1])
    );
}

#[test]
fn the_shipped_log_is_what_simulate_log_writes() {
    // studies/data/fit_log.csv is generated: regenerating it gives the same bytes.
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("log.csv");
    simulate_log(&study("fit_log.toml", 1), 0, &path).unwrap();
    assert_eq!(
        std::fs::read(&path).unwrap(),
        std::fs::read(root().join("studies/data/fit_log.csv")).unwrap(),
        "regenerate with: chassis-mc simulate-log studies/fit_log.toml --out studies/data/fit_log.csv"
    );
    // And the shipped example fits it.
    let (code, stdout, stderr) = cli(
        &[
            "fit".as_ref(),
            root().join("studies/fit_example.toml").as_os_str(),
            "--out".as_ref(),
            tmp.path().join("out").as_os_str(),
        ],
        tmp.path(),
    );
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("drag_coefficient"), "{stdout}");
    assert!(tmp.path().join("out/fit.parquet").is_file());
}

#[test]
fn a_fit_file_error_names_the_key_and_line() {
    let tmp = tempfile::tempdir().unwrap();
    let err = FitSpec::parse(&fit_file("missing.csv", 200), "bad.toml", tmp.path()).unwrap_err();
    assert_eq!(err.key.as_deref(), Some("log.file"), "{err}");
    let text = fit_file(
        &root()
            .join("studies/data/fit_log.csv")
            .display()
            .to_string(),
        200,
    )
    .replace("min_speed = 0.5", "min_speed = -1");
    let err = FitSpec::parse(&text, "bad.toml", tmp.path()).unwrap_err();
    assert_eq!(err.key.as_deref(), Some("log.min_speed"), "{err}");
    assert_eq!(err.line, Some(13), "{err}");
}
