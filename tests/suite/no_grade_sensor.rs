//! No grade sensor: the filters of mass and grade (`ekf`, `rls_mf`), the bound along each
//! realisation's true path, and a truth that follows the filters' model
//! (docs/model.md#no-grade-sensor, docs/model.md#filter-truth).

use std::path::Path;

use chassis_mc::montecarlo::Silent;
use chassis_mc::run::{RunOptions, run_study, summarize};
use chassis_mc::study::Study;

use super::common::*;

/// The thesis vehicle and torque from 10 m/s for `duration` s at 0.01 s, speed noise
/// 0.1 m/s, `ekf` and `rls_mf` without the grade; the truth follows the filters' model
/// (a random-walk grade, 1/M from the prior, the filters' process noise).
pub(super) fn filter_model_study(duration: f64, realisations: u64) -> (String, Study) {
    let text = study_text("thesis.toml");
    let text = set_key(&text, "duration", &format!("{duration}"));
    let text = set_key(&text, "initial_speed", "10.0");
    let text = set_key(&text, "scales", "[1.0]");
    let text = set_key(&text, "velocity_sd", "[0.1]");
    let text = set_key(
        &text,
        "profile",
        "\"random_walk\"\ngrade_walk = 1e-7\ngrade_sd0 = 0.01",
    );
    let text: String = text
        .lines()
        .filter(|l| !l.starts_with("height") && !l.starts_with("period"))
        .map(|l| format!("{l}\n"))
        .collect();
    let text = set_key(
        &text,
        "estimators",
        "[\"ekf\", \"rls_mf\"]\ngrade = \"none\"\nprior_mass = 1500.0\nprior_mass_sd = 250.0\n\
         grade_sd0 = 0.01\ngrade_walk = 1e-7\nspeed_process_sd = 0.001",
    );
    let text = format!("{text}\n[truth]\nspeed_process_sd = 0.001\nmass_from_prior = true\n");
    let study = Study::from_toml(&text, study_path("no_grade.toml").to_str().unwrap())
        .unwrap()
        .with_overrides(Some(realisations), None)
        .unwrap();
    (text, study)
}

fn bytes(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Column `col` of the rows of `estimator` in realisations.parquet.
fn realisation_col(dir: &Path, estimator: &str, col: &str) -> Vec<f64> {
    let t = read_table(&dir.join("realisations.parquet"));
    let e = str_col(&t, "estimator");
    f64_col(&t, col)
        .into_iter()
        .zip(e)
        .filter(|(_, e)| e == estimator)
        .map(|(v, _)| v)
        .collect()
}

#[test]
fn the_filters_give_the_same_bytes_across_threads_shards_and_extension() {
    let (text, study) = filter_model_study(30.0, 24);
    let (one, _) = run(&study, Some(1));
    let (two, _) = run(&study, Some(2));
    for name in ["realisations.parquet", "summary.parquet", "cycles.parquet"] {
        assert!(
            bytes(&one.path().join(name)) == bytes(&two.path().join(name)),
            "{name}: 1 and 2 threads differ"
        );
    }
    // Each realisation drew its own truth: its own 1/M, so its own error and path bound.
    let bound = realisation_col(one.path(), "ekf", "path_bound_inv_mass");
    assert_ne!(bound[0], bound[1]);

    let sharded = tempfile::tempdir().unwrap();
    run_shards(&study, sharded.path(), &[2, 0, 1]);
    summarize(&[sharded.path().to_path_buf()], sharded.path(), false).unwrap();
    assert!(
        bytes(&one.path().join("summary.parquet"))
            == bytes(&sharded.path().join("summary.parquet")),
        "sharded summary differs"
    );

    let grown = tempfile::tempdir().unwrap();
    let options = RunOptions::new(grown.path());
    let first = Study::from_toml(&text, study_path("no_grade.toml").to_str().unwrap())
        .unwrap()
        .with_overrides(Some(12), None)
        .unwrap();
    run_study(&first, &options, &Silent).unwrap();
    run_study(&study, &options, &Silent).unwrap();
    for name in ["realisations.parquet", "summary.parquet"] {
        assert!(
            bytes(&one.path().join(name)) == bytes(&grown.path().join(name)),
            "{name}: extended run differs"
        );
    }
}

/// Where the truth follows its model, the EKF is consistent: its mean NEES is a χ²₃'s, its
/// own 95 % interval of 1/M covers, and its RMSE of 1/M is the bound along the true paths.
#[test]
fn the_ekf_is_consistent_where_the_truth_follows_its_model() {
    let r = 400;
    let (_, study) = filter_model_study(300.0, r);
    let (dir, _) = run(&study, None);
    let nees = realisation_col(dir.path(), "ekf", "nees");
    let error = realisation_col(dir.path(), "ekf", "inv_mass_error");
    let sd = realisation_col(dir.path(), "ekf", "filter_sd_inv_mass");
    let bound = realisation_col(dir.path(), "ekf", "path_bound_inv_mass");
    let n = r as f64;
    assert_eq!(nees.len(), r as usize);
    // The mean of R χ²₃ has SD √(6/R) = 0.12 at R = 400: 4 SD is 0.49.
    let mean_nees = nees.iter().sum::<f64>() / n;
    assert!(
        (mean_nees - 3.0).abs() < 4.0 * (6.0 / n).sqrt(),
        "mean NEES {mean_nees}"
    );
    // Coverage of a 95 % interval over R: binomial SE √(0.95·0.05/R) = 1.09 %; 4 SE.
    let covered = error
        .iter()
        .zip(&sd)
        .filter(|(e, s)| e.abs() <= 1.96 * **s)
        .count() as f64
        / n;
    assert!(
        (covered - 0.95).abs() < 4.0 * (0.95 * 0.05 / n).sqrt(),
        "coverage {covered}"
    );
    // RMSE over the bound's root-mean-square: the MSE of R normal errors has a relative SE
    // of √(2/R), the RMSE half of it (3.5 % at R = 400); 4 MCSE.
    let mse = error.iter().map(|e| e * e).sum::<f64>() / n;
    let bound_ms = bound.iter().map(|b| b * b).sum::<f64>() / n;
    let ratio = (mse / bound_ms).sqrt();
    assert!(
        (ratio - 1.0).abs() < 4.0 * 0.5 * (2.0 / n).sqrt(),
        "RMSE / path bound {ratio}"
    );

    // The summary's measures are these, on the ekf's inv_mass row.
    let t = read_table(&dir.path().join("summary.parquet"));
    let row = str_col(&t, "estimator")
        .iter()
        .zip(str_col(&t, "parameter"))
        .position(|(e, p)| e == "ekf" && p == "inv_mass")
        .unwrap();
    let at = |col: &str| f64_col(&t, col)[row];
    // Exact sums against a plain sum: equal to rounding.
    assert!((at("nees_mean") / mean_nees - 1.0).abs() < 1e-12);
    assert_eq!(at("coverage_filter"), covered);
    assert!(
        (at("rmse_over_path_bound") / ratio - 1.0).abs() < 1e-12,
        "{} against {ratio}",
        at("rmse_over_path_bound")
    );
    // The PCRLB is a bound where the truth follows the model: the RMSE of 1/M and of the
    // grade are not below it beyond 3 MCSE (an RMSE's MCSE ≈ RMSE/√(2R)), at the end and at
    // 60, 120 and 300 s.
    let rmse = |col: &str| {
        let e = realisation_col(dir.path(), "ekf", col);
        (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt()
    };
    for (error, bound) in [
        ("inv_mass_error", "pcrlb_inv_mass"),
        ("inv_mass_error_60s", "pcrlb_inv_mass_60s"),
        ("inv_mass_error_120s", "pcrlb_inv_mass_120s"),
        ("inv_mass_error_300s", "pcrlb_inv_mass_300s"),
        ("grade_error", "pcrlb_grade"),
        ("grade_error_60s", "pcrlb_grade_60s"),
        ("grade_error_120s", "pcrlb_grade_120s"),
        ("grade_error_300s", "pcrlb_grade_300s"),
    ] {
        let (rmse, bound) = (rmse(error), at(bound));
        let mcse = rmse / (2.0 * n).sqrt();
        assert!(
            rmse > bound - 3.0 * mcse,
            "{error}: RMSE {rmse} below {bound}"
        );
    }
}

#[test]
fn without_the_grade_an_estimator_that_reads_it_is_refused() {
    let text = study_text("thesis.toml");
    // Without an accelerometer (the speed differentiated) OLS has no grade to read.
    let text = set_key(
        &text,
        "estimators",
        "[\"ols\", \"ekf\"]\ngrade = \"none\"\nacceleration = \"differentiated\"",
    );
    let e = Study::from_toml(&text, study_path("no_grade.toml").to_str().unwrap()).unwrap_err();
    let shown = e.to_string();
    assert!(shown.contains("estimation.estimators[0]"), "{shown}");
    assert!(shown.contains("ols reads the grade"), "{shown}");
    // Nor may a grade sensor's noise be set.
    let text = set_key(
        &study_text("thesis.toml"),
        "estimators",
        "[\"ekf\"]\ngrade = \"none\"",
    );
    let text = set_key(&text, "output_sd", "[0.0]\ngrade_sd = [0.01]");
    let e = Study::from_toml(&text, study_path("no_grade.toml").to_str().unwrap()).unwrap_err();
    assert!(e.to_string().contains("noise.grade_sd"), "{e}");
    // A filter steps from row to row: a selection that leaves rows out is refused.
    let text = set_key(&study_text("thesis.toml"), "estimators", "[\"ekf\"]");
    let text = set_key(&text, "initial_speed", "0.0\nmin_speed = 1.0");
    let e = Study::from_toml(&text, study_path("no_grade.toml").to_str().unwrap()).unwrap_err();
    assert!(e.to_string().contains("drive.min_speed"), "{e}");
    assert!(e.to_string().contains("cannot be used with ekf"), "{e}");
    // A filter's key without a filter listed says what it applies to.
    let text = set_key(
        &study_text("thesis.toml"),
        "estimators",
        "[\"ols\"]\ngrade_walk = 1e-6",
    );
    let e = Study::from_toml(&text, study_path("no_grade.toml").to_str().unwrap()).unwrap_err();
    assert!(e.to_string().contains("estimation.grade_walk"), "{e}");
    assert!(e.to_string().contains("rls_mf and ekf"), "{e}");
}

/// With an accelerometer and no grade, OLS and BCLS read −g for −g cos θ: their bias is the
/// least-squares projection of the omitted θ₃ g (1 − cos θ), to first order θ₃ g θ²/2
/// (docs/model.md#no-grade-accelerometer). `bias_model` (the noise-free estimate) agrees
/// with that projection computed here from cycles.parquet, and BCLS's Monte Carlo bias of Cr
/// with `bias_model` within 4 MCSE.
#[test]
fn without_the_grade_an_accelerometer_leaves_the_projection_of_the_cosine_on_cr() {
    let text = study_text("thesis.toml");
    let text = set_key(&text, "duration", "300.0");
    let text = set_key(&text, "initial_speed", "10.0");
    let text = set_key(&text, "scales", "[2.0]");
    let text = set_key(&text, "velocity_sd", "[0.1]");
    let text = set_key(&text, "output_sd", "[0.05]");
    let text = set_key(
        &text,
        "estimators",
        "[\"ols\", \"bcls\"]\ngrade = \"none\"\nacceleration = \"model\"",
    );
    let study = Study::from_toml(&text, study_path("no_grade.toml").to_str().unwrap())
        .unwrap()
        .with_overrides(Some(400), None)
        .unwrap();
    let (dir, _) = run(&study, None);
    let cycles = read_table(&dir.path().join("cycles.parquet"));
    let (v, grade, f) = (
        f64_col(&cycles, "v"),
        f64_col(&cycles, "grade"),
        f64_col(&cycles, "f_prop"),
    );
    // The thesis vehicle: k = ½·1.2·5.5, g = 9.81, Cr = 0.0125.
    let (k, g, cr) = (0.5 * 1.2 * 5.5, 9.81, 0.0125);
    let mut xtx = nalgebra::Matrix3::<f64>::zeros();
    let mut xtr = nalgebra::Vector3::<f64>::zeros();
    for i in 0..v.len() {
        let x = nalgebra::Vector3::new(f[i], -k * v[i] * v[i], -g);
        xtx += x * x.transpose();
        xtr += x * (cr * g * grade[i] * grade[i] / 2.0);
    }
    let predicted = xtx.lu().solve(&xtr).unwrap();
    let t = read_table(&dir.path().join("summary.parquet"));
    let (e, p) = (str_col(&t, "estimator"), str_col(&t, "parameter"));
    let row = |est: &str| {
        (0..e.len())
            .find(|&i| e[i] == est && p[i] == "rolling_resistance")
            .unwrap()
    };
    let (bias_model, bias, mcse) = (
        f64_col(&t, "bias_model")[row("bcls")],
        f64_col(&t, "bias")[row("bcls")],
        f64_col(&t, "bias_mcse")[row("bcls")],
    );
    // 1 − cos θ = θ²/2 − θ⁴/24 + …: the second term is θ²/12 of the first, under 0.3 % of
    // it for |θ| ≤ 0.17 rad (scale 2); plus the sums' rounding.
    assert!(
        (bias_model / predicted[2] - 1.0).abs() < 3e-3,
        "bias_model {bias_model} against the projection {}",
        predicted[2]
    );
    // About −⟨θ²⟩/2 of Cr: the projection onto the constant column is most of it.
    assert!(bias_model < 0.0);
    assert!(
        (bias - bias_model).abs() < 4.0 * mcse,
        "BCLS bias {bias} ± {mcse} against {bias_model}"
    );
}

/// `estimation.grade_walk` as a list is an axis of a study that lists a filter (the last,
/// column `grade_walk`), each condition's filters and `bias_model` at its own level; a study
/// without a filter has no such column.
#[test]
fn the_grade_walk_is_an_axis_of_a_study_with_a_filter_only() {
    let text = study_text("thesis.toml");
    let text = set_key(&text, "duration", "30.0");
    let text = set_key(&text, "initial_speed", "10.0");
    let text = set_key(&text, "scales", "[1.0]");
    let text = set_key(&text, "velocity_sd", "[0.1]");
    let with = set_key(
        &text,
        "estimators",
        "[\"ols\", \"ekf\"]\ngrade_walk = [1e-7, 1e-4]",
    );
    let study = Study::from_toml(&with, study_path("no_grade.toml").to_str().unwrap())
        .unwrap()
        .with_overrides(Some(8), None)
        .unwrap();
    let (dir, _) = run(&study, Some(2));
    let t = read_table(&dir.path().join("summary.parquet"));
    let (e, p) = (str_col(&t, "estimator"), str_col(&t, "parameter"));
    let rows: Vec<usize> = (0..e.len())
        .filter(|&i| e[i] == "ekf" && p[i] == "inv_mass")
        .collect();
    assert_eq!(rows.len(), 2);
    let walk = f64_col(&t, "grade_walk");
    assert_eq!([walk[rows[0]], walk[rows[1]]], [1e-7, 1e-4]);
    let bias_model = f64_col(&t, "bias_model");
    assert_ne!(bias_model[rows[0]], bias_model[rows[1]]);
    // M's bound by the delta method at the thesis car's 1800 kg: SD(1/M)·M², to rounding.
    let (inv, mass) = (f64_col(&t, "pcrlb_inv_mass"), f64_col(&t, "pcrlb_mass"));
    for &i in &rows {
        assert!(inv[i] > 0.0);
        assert!((mass[i] / (inv[i] * 1800.0 * 1800.0) - 1.0).abs() < 1e-12);
    }
    // OLS reads no walk: its rows are the same in both conditions.
    let ols: Vec<usize> = (0..e.len())
        .filter(|&i| e[i] == "ols" && p[i] == "inv_mass")
        .collect();
    assert_eq!(bias_model[ols[0]], bias_model[ols[1]]);

    let without = Study::from_toml(&text, study_path("no_grade.toml").to_str().unwrap())
        .unwrap()
        .with_overrides(Some(2), None)
        .unwrap();
    let (dir, _) = run(&without, Some(1));
    let t = read_table(&dir.path().join("summary.parquet"));
    assert!(t.column_by_name("grade_walk").is_none());
}
