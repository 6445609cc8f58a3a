//! What a condition draws anew in every realisation beyond its sensor noise: gusts, a random
//! force calibration, the elevation map's error (docs/model.md#model-errors,
//! docs/model.md#grade-map), and a measured air speed (docs/model.md#air-speed). Each
//! realisation's truth is a pure function of (seed, condition, realisation), so threads,
//! shards, extension and resume give the same bytes; the numbers follow the entries'
//! equations.

use std::path::Path;
use std::process::Command;

use chassis_mc::montecarlo::Silent;
use chassis_mc::run::{RunOptions, run_study, summarize};
use chassis_mc::study::Study;

use super::common::*;

/// The thesis's vehicle and terrain over a 60 s drive with `noise` (lines of `[noise]`),
/// `estimators` and `truth` (lines of `[truth]`).
fn short_thesis(noise: &str, estimators: &str, truth: &str) -> String {
    let text = study_text("thesis.toml");
    let text = set_key(&text, "duration", "60.0");
    let text = set_key(&text, "scales", "[1.0]");
    let text = set_key(&text, "velocity_sd", noise);
    let text = set_key(&text, "estimators", estimators);
    format!("{text}\n[truth]\n{truth}\n")
}

fn load(text: &str, realisations: u64) -> Study {
    Study::from_toml(text, study_path("drawn.toml").to_str().unwrap())
        .unwrap()
        .with_overrides(Some(realisations), None)
        .unwrap()
}

fn bytes(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Rows of the summary for `estimator` and `parameter`, in condition order: column `col`.
fn summary_col(dir: &Path, estimator: &str, parameter: &str, col: &str) -> Vec<f64> {
    let t = read_table(&dir.join("summary.parquet"));
    let (e, p) = (str_col(&t, "estimator"), str_col(&t, "parameter"));
    f64_col(&t, col)
        .into_iter()
        .enumerate()
        .filter(|(i, _)| e[*i] == estimator && p[*i] == parameter)
        .map(|(_, v)| v)
        .collect()
}

#[test]
fn drawn_entries_and_the_map_give_the_same_bytes_across_threads_shards_extension_and_resume() {
    let text = short_thesis(
        "[0.3]\ngrade_map_sd = [0.02]\ngrade_map_length = 100.0",
        "[\"ols\", \"bcls\"]",
        "wind_gust_sd = [1.0]\nforce_scale_sd = [0.0, 0.02]",
    );
    let text = set_key(&text, "scales", "[1.0, 1.5]");
    let study = load(&text, 40);
    let (one, _) = run(&study, Some(1));
    let (two, _) = run(&study, Some(2));
    for name in ["realisations.parquet", "summary.parquet", "cycles.parquet"] {
        assert!(
            bytes(&one.path().join(name)) == bytes(&two.path().join(name)),
            "{name}: 1 and 2 threads differ"
        );
    }
    // The realisations really differ: each drew its own gusts, calibration and map.
    let t = read_table(&one.path().join("realisations.parquet"));
    let theta = f64_col(&t, "theta_drag_over_mass");
    assert_ne!(theta[0], theta[1]);

    // Three shards in a scrambled order, then summarized: the unsharded summary.
    let sharded = tempfile::tempdir().unwrap();
    run_shards(&study, sharded.path(), &[2, 0, 1]);
    summarize(&[sharded.path().to_path_buf()], sharded.path(), false).unwrap();
    assert!(
        bytes(&one.path().join("summary.parquet"))
            == bytes(&sharded.path().join("summary.parquet")),
        "sharded summary differs"
    );

    // Extension: R = 20 first, then 40 in the same directory.
    let grown = tempfile::tempdir().unwrap();
    let options = RunOptions::new(grown.path());
    run_study(&load(&text, 20), &options, &Silent).unwrap();
    let report = run_study(&study, &options, &Silent).unwrap();
    assert_eq!(report.reused, 4 * 20);
    for name in ["realisations.parquet", "summary.parquet"] {
        assert!(
            bytes(&one.path().join(name)) == bytes(&grown.path().join(name)),
            "{name}: extended run differs"
        );
    }

    // Resume: a run killed after its first part is committed, run again.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("drawn.toml");
    std::fs::write(&file, &text).unwrap();
    let out = dir.path().join("out");
    let command = |out: &Path| {
        let mut cmd = Command::new(bin());
        cmd.args(["run", "--quiet", "--no-figures", "--realisations", "40"])
            .arg("--out")
            .arg(out)
            .arg(&file);
        cmd
    };
    let reference = dir.path().join("reference");
    assert!(command(&reference).output().unwrap().status.success());
    let killed = command(&out)
        .env("CHASSIS_MC_FAILPOINT", "part-committed")
        .output()
        .unwrap();
    assert!(
        !killed.status.success(),
        "the run did not stop at its failpoint"
    );
    let again = command(&out).output().unwrap();
    assert!(
        again.status.success(),
        "{}",
        String::from_utf8_lossy(&again.stderr)
    );
    assert!(String::from_utf8_lossy(&again.stderr).contains("resuming:"));
    for name in ["realisations.parquet", "summary.parquet"] {
        assert!(
            bytes(&reference.join(name)) == bytes(&out.join(name)),
            "{name}: resumed run differs"
        );
    }
}

#[test]
fn a_random_force_calibration_divides_the_estimate_of_inv_mass_alone() {
    // With the log (1 + ε)·F and no noise, OLS's rows are the truth's with column 1 scaled
    // by (1 + ε): θ̂ = [θ₁/(1 + ε), θ₂, θ₃] exactly (docs/model.md#model-errors). So
    // ε̂ = θ₁/θ̂₁ − 1 is each realisation's draw, N(0, s²) with s = 0.05.
    let text = short_thesis("[0.0]", "[\"ols\"]", "force_scale_sd = [0.05]");
    let r = 400;
    let (dir, _) = run(&load(&text, r), None);
    let t = read_table(&dir.path().join("realisations.parquet"));
    let truth = [1.0 / 1800.0, 0.35 / 1800.0, 0.0125];
    for (p, name) in PARAMS.iter().enumerate().skip(1) {
        for v in f64_col(&t, &format!("theta_{name}")) {
            // Rounding of the normal equations' solution: ~1e-12 relative.
            assert!((v - truth[p]).abs() <= 1e-9 * truth[p], "{name}: {v}");
        }
    }
    let eps: Vec<f64> = f64_col(&t, "theta_inv_mass")
        .iter()
        .map(|v| truth[0] / v - 1.0)
        .collect();
    let n = eps.len() as f64;
    let mean = eps.iter().sum::<f64>() / n;
    let sd = (eps.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    // MCSE of a mean s/√R, of an SD s/√(2(R − 1)) (normal draws); 4 of each.
    assert!(mean.abs() <= 4.0 * sd / n.sqrt(), "mean {mean}");
    assert!(
        (sd - 0.05).abs() <= 4.0 * sd / (2.0 * (n - 1.0)).sqrt(),
        "sd {sd}"
    );
}

#[test]
fn a_measured_air_speed_takes_the_wind_out_of_the_drag_estimate() {
    // A 3 m/s headwind the equation leaves out: OLS on the ground speed (σ_v = 0.3 m/s)
    // estimates the drag of the air speed with the ground speed, far from Cd/M; BCLS on a
    // measured air speed V + w + e_a (σ_a = 0.3 m/s) regresses on the air speed itself and
    // compensates its noise, so it is unbiased (docs/model.md#air-speed).
    let r = 200;
    let ground = short_thesis("[0.3]", "[\"ols\"]", "wind_speed = [3.0]");
    let (g, _) = run(&load(&ground, r), None);
    let bias = summary_col(g.path(), "ols", "drag_over_mass", "bias")[0];
    let mcse = summary_col(g.path(), "ols", "drag_over_mass", "bias_mcse")[0];
    assert!(
        bias.abs() > 20.0 * mcse,
        "OLS on ground speed: {bias} ± {mcse}"
    );

    let measured = short_thesis(
        "[0.0]\nair_speed_sd = [0.3]",
        "[\"bcls\", \"wbcls\"]\nair_speed = \"measured\"",
        "wind_speed = [3.0]",
    );
    let (m, _) = run(&load(&measured, r), None);
    assert_eq!(
        f64_col(
            &read_table(&m.path().join("summary.parquet")),
            "air_speed_sd"
        )[0],
        0.3
    );
    for estimator in ["bcls", "wbcls"] {
        for p in PARAMS {
            let bias = summary_col(m.path(), estimator, p, "bias")[0];
            let mcse = summary_col(m.path(), estimator, p, "bias_mcse")[0];
            assert!(
                bias.abs() <= 4.0 * mcse,
                "{estimator} on measured air speed, {p}: {bias} ± {mcse}"
            );
        }
    }
}

#[test]
fn an_air_speed_sensor_is_a_channel_of_its_own_with_the_speed_sensors_terms_in_w() {
    // In calm air the air speed is the ground speed, so a measured air speed at σ_a is the
    // ground speed's regression with noise σ_a in w (docs/model.md#air-speed). The bounds
    // that are constant over the realisations, functions of the rows and of the noise in w,
    // are then the speed sensor's at σ_v = σ_a to the bit; the draws are the air-speed channel's own stream's, so the
    // estimates differ realisation by realisation and agree in distribution.
    let r = 200;
    let ground = short_thesis("[0.3]", "[\"ols\", \"bcls\"]", "");
    let measured = short_thesis(
        "[0.0]\nair_speed_sd = [0.3]",
        "[\"ols\", \"bcls\"]\nair_speed = \"measured\"",
        "",
    );
    let (g, _) = run(&load(&ground, r), None);
    let (m, _) = run(&load(&measured, r), None);
    for estimator in ["ols", "bcls"] {
        for p in PARAMS {
            for bound in ["eiv_sandwich_se", "eiv_crlb_linearized_se"] {
                let (a, b) = (
                    summary_col(g.path(), estimator, p, bound)[0],
                    summary_col(m.path(), estimator, p, bound)[0],
                );
                assert!(a.is_finite() && a > 0.0, "{estimator} {p} {bound}: {a}");
                assert_eq!(a.to_bits(), b.to_bits(), "{estimator} {p} {bound}");
            }
            // Independent draws: the difference of the two means has the MCSE
            // sqrt(mcse_g² + mcse_m²); 4 of them bound it with probability > 0.9999.
            let (mean_g, mean_m) = (
                summary_col(g.path(), estimator, p, "mean")[0],
                summary_col(m.path(), estimator, p, "mean")[0],
            );
            let mcse = summary_col(g.path(), estimator, p, "mean_mcse")[0]
                .hypot(summary_col(m.path(), estimator, p, "mean_mcse")[0]);
            assert_ne!(
                mean_g.to_bits(),
                mean_m.to_bits(),
                "{estimator} {p}: the same draws"
            );
            assert!(
                (mean_g - mean_m).abs() <= 4.0 * mcse,
                "{estimator} {p}: {mean_g} vs {mean_m} ± {mcse}"
            );
        }
    }
}

#[test]
fn an_air_speed_sensor_is_refused_where_the_regression_would_not_read_it() {
    let cases = [
        // A sensor on a regression that reads the ground speed.
        (
            short_thesis(
                "[0.0]\nair_speed_sd = [0.3]",
                "[\"bcls\"]",
                "wind_speed = [3.0]",
            ),
            "noise.air_speed_sd",
        ),
        // Speed noise that would enter no column.
        (
            short_thesis(
                "[0.2]\nair_speed_sd = [0.3]",
                "[\"bcls\"]\nair_speed = \"measured\"",
                "wind_speed = [3.0]",
            ),
            "noise.velocity_sd",
        ),
        // A differentiated acceleration reads the ground speed.
        (
            short_thesis(
                "[0.0]\nair_speed_sd = [0.3]",
                "[\"bcls\"]\nair_speed = \"measured\"\nacceleration = \"differentiated\"",
                "wind_speed = [3.0]",
            ),
            "estimation.air_speed",
        ),
        (
            short_thesis("[0.0]", "[\"bcls\"]\nair_speed = \"anemometer\"", ""),
            "estimation.air_speed",
        ),
    ];
    for (text, key) in cases {
        let err = Study::from_toml(&text, "drawn.toml").unwrap_err();
        assert_eq!(err.key.as_deref(), Some(key), "{err}");
        assert!(err.line.is_some(), "{err}");
    }
}

#[test]
fn a_realisation_whose_gusts_stall_the_vehicle_is_unsimulated_not_fatal() {
    // From rest, a gust of tens of m/s against a weak vehicle stops it in some
    // realisations (at 100 N·m, 900 N of propulsion, a headwind above about 24 m/s, 1.2 σ
    // of the gusts, outweighs it): those are marked "unsimulated" and counted as failed;
    // the others are estimated.
    let text = short_thesis("[0.0]", "[\"ols\"]", "wind_gust_sd = [20.0]");
    let text = set_key(&text, "torque_mean", "100.0");
    let (dir, _) = run(&load(&text, 30), None);
    let t = read_table(&dir.path().join("realisations.parquet"));
    let status = str_col(&t, "status");
    let unsimulated = status.iter().filter(|s| *s == "unsimulated").count();
    assert!(unsimulated > 0 && unsimulated < status.len(), "{status:?}");
    let theta = f64_col(&t, "theta_inv_mass");
    for (s, v) in status.iter().zip(&theta) {
        assert_eq!(s == "unsimulated", v.is_nan(), "{s} {v}");
    }
    let summary = read_table(&dir.path().join("summary.parquet"));
    assert_eq!(i64_col(&summary, "n_failed")[0] as usize, unsimulated);
}

#[test]
fn the_maps_error_moves_the_estimates_only_when_it_is_on() {
    // Noise off: a condition with an exact map has no spread; one with a map error of
    // 2 cm has one, and no control variate (its rows differ in every realisation).
    let text = short_thesis("[0.0]\ngrade_map_sd = [0.0, 0.02]", "[\"ols\"]", "");
    let (dir, _) = run(&load(&text, 50), None);
    let se = summary_col(dir.path(), "ols", "rolling_resistance", "emp_se");
    assert_eq!(se[0], 0.0);
    assert!(se[1] > 0.0, "{se:?}");
    let summary = read_table(&dir.path().join("summary.parquet"));
    let controls = i64_col(&summary, "n_controls");
    let map = f64_col(&summary, "grade_map_sd");
    for (c, m) in controls.iter().zip(&map) {
        assert!(*m == 0.0 || *c == 0, "{controls:?}");
    }
}

#[test]
fn a_parameter_of_an_entry_that_is_off_is_refused_naming_it() {
    // Without gusts, their correlation time does nothing; without a map error, its
    // correlation length does nothing: each is an error, not a silent no-op.
    for (text, key) in [
        (
            short_thesis("[0.0]", "[\"ols\"]", "wind_gust_time = 20.0"),
            "truth.wind_gust_time",
        ),
        (
            short_thesis("[0.0]\ngrade_map_length = 50.0", "[\"ols\"]", ""),
            "noise.grade_map_length",
        ),
    ] {
        let err = Study::from_toml(&text, "drawn.toml").unwrap_err();
        assert_eq!(err.key.as_deref(), Some(key), "{err}");
        assert!(err.reason.contains("no level above 0"), "{err}");
    }
}

#[test]
fn the_control_variate_columns_are_null_where_each_realisation_has_its_own_regression() {
    // The controls are centred on the condition's regression; with a map error each
    // realisation has another, so its cv_* values are null, not a mean-nonzero number.
    let text = short_thesis("[0.5]\ngrade_map_sd = [0.0, 0.02]", "[\"ols\"]", "");
    let (dir, _) = run(&load(&text, 10), None);
    let t = read_table(&dir.path().join("realisations.parquet"));
    let map = f64_col(&t, "grade_map_sd");
    let cv = f64_col(&t, "cv_w_w");
    for (m, c) in map.iter().zip(&cv) {
        assert_eq!(*m > 0.0, c.is_nan(), "map {m}, cv {c}");
    }
}

#[test]
fn simulate_log_refuses_a_study_whose_realisations_have_their_own_truth() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("gusts.toml");
    std::fs::write(
        &file,
        short_thesis("[0.1]", "[\"ols\"]", "wind_gust_sd = [1.0]"),
    )
    .unwrap();
    let out = Command::new(bin())
        .args(["simulate-log"])
        .arg(&file)
        .arg("--out")
        .arg(dir.path().join("log.csv"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("truth") && stderr.contains("gusts"),
        "{stderr}"
    );
}
