//! `fit` of a log without a grade column: the filters' own intervals and the bootstrap's,
//! on synthetic logs whose truth follows the filters' model (studies/fit_log_no_grade.toml),
//! and what a fit file with the filters must and must not say (docs/model.md#fit).

use std::path::Path;

use super::common::*;
use chassis_mc::fit::{FitSpec, fit, simulate_log};

/// The true mass of studies/fit_log_no_grade.toml \[kg\].
const MASS: f64 = 1800.0;

/// The fit file of studies/fit_no_grade.toml on `log`, with `estimators`, `realisations`
/// bootstrap realisations and bootstrap seed `seed`.
fn fit_text(log: &Path, estimators: &str, realisations: u64, seed: u64) -> String {
    let text = std::fs::read_to_string(study_path("fit_no_grade.toml")).unwrap();
    let text = set_key(&text, "file", &format!("\"{}\"", log.display()));
    let text = set_key(&text, "estimators", estimators);
    let text = set_key(&text, "realisations", &realisations.to_string());
    set_key(&text, "seed", &seed.to_string())
}

/// Realisation `r`'s log of studies/fit_log_no_grade.toml written to `path` without its
/// grade column (a vehicle with no grade sensor).
fn log_without_grade(r: u64, path: &Path) {
    simulate_log(&study("fit_log_no_grade.toml", 1), r, path, true).unwrap();
    let text = std::fs::read_to_string(path).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let grade = header.iter().position(|c| *c == "grade_rad").unwrap();
    let kept: String = text
        .lines()
        .map(|l| {
            let cells: Vec<&str> = l.split(',').collect();
            let row: Vec<&str> = (0..cells.len())
                .filter(|&i| i != grade)
                .map(|i| cells[i])
                .collect();
            row.join(",") + "\n"
        })
        .collect();
    std::fs::write(path, kept).unwrap();
}

/// Over `logs` logs (realisations 0…logs−1), how many times the EKF's own 95 % interval of
/// 1/M, and its bootstrap's (R = 100, seed 9000 + r), holds the truth; and the median ratio
/// of the bootstrap interval's width to the filter's.
fn ekf_coverage(logs: u64) -> (usize, usize, f64) {
    let tmp = tempfile::tempdir().unwrap();
    let (mut own, mut boot) = (0, 0);
    let mut ratios = Vec::new();
    for r in 0..logs {
        let log = tmp.path().join(format!("log{r}.csv"));
        log_without_grade(r, &log);
        let text = fit_text(&log, "[\"ekf\"]", 100, 9000 + r);
        let spec = FitSpec::parse(&text, "no-grade fit", tmp.path()).unwrap();
        let result = fit(&spec, &tmp.path().join(format!("out{r}"))).unwrap();
        let row = result
            .rows
            .iter()
            .find(|x| x.parameter == "inv_mass")
            .unwrap();
        let interval = row.filter.expect("the filter's own interval");
        let truth = 1.0 / MASS;
        own += usize::from(interval.low <= truth && truth <= interval.high);
        boot += usize::from(row.ci_low <= truth && truth <= row.ci_high);
        ratios.push((row.ci_high - row.ci_low) / (interval.high - interval.low));
    }
    ratios.sort_by(f64::total_cmp);
    (own, boot, ratios[ratios.len() / 2])
}

#[test]
fn the_ekfs_own_interval_covers_the_mass_of_logs_without_a_grade_column() {
    // 50 synthetic logs (studies/fit_log_no_grade.toml: the thesis car, 600 s at 10 Hz,
    // σ_v = 0.1 m/s, a random-walk grade and the filters' process noise, M = 1800 kg against
    // the filters' prior 1500 ± 250 kg), the grade column removed, fitted by the EKF. Its own
    // 95 % interval of 1/M must hold the truth in 45–49 of 50 (90–98 %). For a consistent
    // filter X ~ Bin(50, 0.95): P(X ≤ 44) = 0.04, P(X = 50) = 0.08; the prior, a standard
    // deviation from the truth, pulls the estimate by about 0.3 of its SD (posterior over
    // prior variance ≈ 0.08), for ≈ 94.5 % (P(X ≤ 44) = 0.06, P(X = 50) = 0.06). The band
    // 90–98 % is the one asked of this check: a consistent filter lands outside it at about
    // one seed in eight, so a failure after the streams change calls for the 400-log
    // measurement below before anything else. Measured: 46 of 50; over 400 logs
    // 95.3 ± 1.1 % (`ekf_coverage_over_400_logs`).
    let (own, boot, ratio) = ekf_coverage(50);
    eprintln!(
        "EKF's own interval covers {own} of 50, its bootstrap's {boot}; median width ratio \
         bootstrap / own {ratio:.3}"
    );
    assert!((45..=49).contains(&own), "covers {own} of 50");
}

#[test]
#[ignore = "a measurement (400 logs, about 3 minutes in release): cargo test --release -- --ignored ekf_coverage_over_400"]
fn ekf_coverage_over_400_logs() {
    let (own, boot, ratio) = ekf_coverage(400);
    let se = |k: usize| {
        let p = k as f64 / 400.0;
        (p * (1.0 - p) / 400.0).sqrt()
    };
    eprintln!(
        "over 400 logs the EKF's own interval covers {:.3} ± {:.3}, its bootstrap's {:.3} ± \
         {:.3}; median width ratio bootstrap / own {ratio:.3}",
        own as f64 / 400.0,
        se(own),
        boot as f64 / 400.0,
        se(boot)
    );
    // A consistent filter's 95 % interval: within 3 binomial SEs at p = 0.95
    // (√(0.95 · 0.05 / 400) = 0.011), for the filter's own and, a percentile interval of
    // the same model's worlds, the bootstrap's; the two intervals' widths within 20 %.
    let band = 3.0 * (0.95f64 * 0.05 / 400.0).sqrt();
    for (what, k) in [("own", own), ("bootstrap", boot)] {
        let p = k as f64 / 400.0;
        assert!((p - 0.95).abs() <= band, "{what}: {p}");
    }
    assert!((0.8..=1.2).contains(&ratio), "width ratio {ratio}");
}

#[test]
fn a_filters_fit_reports_the_mass_only_with_its_own_interval_beside_the_bootstraps() {
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("log.csv");
    log_without_grade(0, &log);
    let text = fit_text(&log, "[\"ekf\", \"rls_mf\"]", 40, 1);
    let spec = FitSpec::parse(&text, "no-grade fit", tmp.path()).unwrap();
    let result = fit(&spec, &tmp.path().join("out")).unwrap();
    for est in ["ekf", "rls_mf"] {
        let rows: Vec<_> = result.rows.iter().filter(|r| r.estimator == est).collect();
        let names: Vec<&str> = rows.iter().map(|r| r.parameter).collect();
        assert_eq!(names, ["inv_mass", "mass"], "{est}: Cd and Cr are known");
        let (inv, mass) = (rows[0], rows[1]);
        let (i, m) = (inv.filter.unwrap(), mass.filter.unwrap());
        // M's interval is the image of 1/M's under M = 1/θ₁ (to rounding), its SD the
        // delta method's.
        assert!((m.low * i.high - 1.0).abs() < 1e-12 && (m.high * i.low - 1.0).abs() < 1e-12);
        assert!((m.sd - i.sd / (inv.estimate * inv.estimate)).abs() <= 1e-12 * m.sd);
        assert!(inv.sandwich_se.is_nan(), "no sandwich SE for a filter");
    }
    // The file has the filter's columns; a fit without a filter keeps its own.
    let file = tmp.path().join("out/fit.parquet");
    let sd = f64_col(&read_table(&file), "filter_sd");
    assert!(sd.iter().all(|v| v.is_finite() && *v > 0.0));
    // fit.svg draws the filter's own interval and says so.
    let svg = std::fs::read_to_string(tmp.path().join("out/fit.svg")).unwrap();
    assert!(svg.contains("own 95 % interval"));
    // The bootstrap keeps the worlds that ran: all of the EKF's (its mass near the truth's);
    // rls_mf's heavier fit stalls in a few of its drawn grades.
    for r in &result.rows {
        let all = r.estimator == "ekf";
        assert!(
            r.boot_n <= 40 && r.boot_n >= 20 && (!all || r.boot_n == 40),
            "{r:?}"
        );
    }

    let with_grade = tmp.path().join("with_grade.csv");
    simulate_log(&study("fit_log_no_grade.toml", 1), 0, &with_grade, true).unwrap();
    let ols = ols_text(&text.replace(
        &log.display().to_string(),
        &with_grade.display().to_string(),
    ));
    let spec = FitSpec::parse(&ols, "ols fit", tmp.path()).unwrap();
    fit(&spec, &tmp.path().join("ols")).unwrap();
    let table = read_table(&tmp.path().join("ols/fit.parquet"));
    for name in ["filter_sd", "filter_ci_low", "filter_ci_high", "boot_n"] {
        assert!(table.column_by_name(name).is_none(), "{name}");
    }
}

/// `text` (a filters' fit file) for OLS with the grade measured and the accelerometer.
fn ols_text(text: &str) -> String {
    let text = text
        .replace("[\"ekf\", \"rls_mf\"]", "[\"ols\"]")
        .replace("[\"ekf\"]", "[\"ols\"]")
        .replace("grade = \"none\"\n", "");
    let text: String = text
        .lines()
        .filter(|l| {
            ![
                "prior_mass",
                "prior_mass_sd",
                "grade_sd0",
                "grade_walk",
                "speed_process_sd",
                "drag_coefficient",
                "rolling_resistance",
            ]
            .iter()
            .any(|k| l.starts_with(&format!("{k} ")))
        })
        .map(|l| format!("{l}\n"))
        .collect();
    text.replace(
        "force_n\"",
        "force_n\"\ngrade_column = \"grade_rad\"\ngrade_unit = \"rad\"\nacceleration_column = \"accel_m_s2\"",
    )
}

#[test]
fn a_fit_file_says_what_the_filters_need_and_nothing_they_do_not_read() {
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("log.csv");
    log_without_grade(0, &log);
    let base = fit_text(&log, "[\"ekf\"]", 20, 1);
    let refused = |text: String, key: &str, words: &str| {
        let e = FitSpec::parse(&text, "f.toml", tmp.path()).unwrap_err();
        assert_eq!(e.key.as_deref(), Some(key), "{e}");
        assert!(e.reason.contains(words), "{e}");
    };
    refused(
        base.replace("rolling_resistance = 0.0125", ""),
        "vehicle.rolling_resistance",
        "required key is missing",
    );
    refused(
        base.replace("prior_mass = 1500.0", ""),
        "estimation.prior_mass",
        "required key is missing",
    );
    refused(
        base.replace("force_n\"", "force_n\"\nmin_speed = 0.5"),
        "log.min_speed",
        "consecutive samples",
    );
    refused(
        base.replace(
            "force_n\"",
            "force_n\"\ngrade_column = \"g\"\ngrade_unit = \"rad\"",
        ),
        "log.grade_column",
        "reads no grade",
    );
    refused(
        base.replace("grade = \"none\"\n", ""),
        "log.grade_column",
        "required key is missing",
    );
    refused(
        base.replace(
            "prior_mass = 1500.0",
            "prior_mass = 1500.0\nknown_mass = true",
        )
        .replace(
            "drag_coefficient = 0.35",
            "mass = 1800.0\ndrag_coefficient = 0.35",
        ),
        "estimation.known_mass",
        "estimates the mass",
    );
    refused(
        format!("{base}\n[systematic]\nwind_speed = 2.0\n"),
        "systematic",
        "not built for the filters",
    );
    refused(
        base.replace("force_n\"", "force_n\"\ngrade_unit = \"rad\""),
        "log.grade_unit",
        "without log.grade_column",
    );
    refused(
        base.replace("drag_coefficient = 0.35", ""),
        "vehicle.drag_coefficient",
        "required key is missing",
    );
    refused(
        base.replace("velocity_sd = 0.1", ""),
        "noise.velocity_sd",
        "must be positive",
    );
    refused(
        base.replace("velocity_sd = 0.1", "velocity_sd = 0.1\ngrade_sd = 0.05"),
        "noise.grade_sd",
        "reads no grade",
    );
    // Without a filter, Cd and Cr are what the fit finds.
    let ols = ols_text(&base).replace("frontal_area", "drag_coefficient = 0.35\nfrontal_area");
    refused(ols, "vehicle.drag_coefficient", "known only to the filters");
    // rls_mf's window is a number of samples: its log's times must be even.
    let uneven = tmp.path().join("uneven.csv");
    let text = std::fs::read_to_string(&log).unwrap();
    let shifted: String = text
        .lines()
        .enumerate()
        .map(|(i, l)| match i {
            2 => l.replacen("0.1,", "0.13,", 1) + "\n",
            _ => format!("{l}\n"),
        })
        .collect();
    std::fs::write(&uneven, shifted).unwrap();
    let rls = fit_text(&uneven, "[\"rls_mf\"]", 20, 1);
    refused(rls, "log.file", "not evenly spaced");
}

#[test]
fn simulate_log_writes_a_realisations_own_path_and_refuses_what_a_log_cannot_carry() {
    let tmp = tempfile::tempdir().unwrap();
    // Two realisations' logs of a truth that follows the filters' model differ in their
    // grade (each its own walk), and the same realisation's twice are the same bytes.
    let [a, b, a2] = ["a.csv", "b.csv", "a2.csv"].map(|n| tmp.path().join(n));
    let s = study("fit_log_no_grade.toml", 1);
    simulate_log(&s, 0, &a, true).unwrap();
    simulate_log(&s, 1, &b, true).unwrap();
    simulate_log(&s, 0, &a2, true).unwrap();
    let (ta, tb) = (std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    assert_eq!(ta, std::fs::read(&a2).unwrap());
    let grade = |text: &[u8]| -> Vec<String> {
        String::from_utf8_lossy(text)
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(3).unwrap().to_string())
            .collect()
    };
    assert_ne!(grade(&ta), grade(&tb));
    // A drawn mass has no place in a log, nor a measured air speed.
    let text = study_text("fit_log_no_grade.toml");
    let drawn = text.replace("[truth]\n", "[truth]\nmass_from_prior = true\n");
    let s = chassis_mc::study::Study::from_toml(&drawn, study_path("x.toml").to_str().unwrap())
        .unwrap();
    let e = simulate_log(&s, 0, &tmp.path().join("c.csv"), true).unwrap_err();
    assert!(e.to_string().contains("mass"), "{e}");
    assert!(!tmp.path().join("c.csv").exists());
}
