//! `estimation.known_mass`: the mass weighed, the estimators fit [Cd/M, Cr] with the output
//! y − F/M (docs/model.md#known-mass).

use super::common::*;
use chassis_mc::study::Study;

/// `text` with `estimation.known_mass = true`.
fn known_mass(text: &str) -> String {
    assert!(text.contains("[estimation]\n"));
    text.replace("[estimation]\n", "[estimation]\nknown_mass = true\n")
}

/// Noise-free, every estimator on the thesis cycle (scales 1 and 2) and on the passenger
/// car's logged speed trace: [Cd/M, Cr] to ≤ 1e-9 relative (the noise-free rows satisfy
/// y − F/M = x₂θ₂ + x₃θ₃ exactly in real arithmetic; what remains is rounding in the sums
/// and the 2×2 solve, as for the three-parameter fit of tests/suite/noise_free.rs), and no
/// 1/M column or row anywhere.
#[test]
fn known_mass_recovers_drag_and_rolling_resistance_without_noise() {
    let thesis = set_key(&study_text("thesis.toml"), "velocity_sd", "[0.0]");
    let thesis = set_key(&thesis, "scales", "[1.0, 2.0]");
    let thesis = set_key(
        &thesis,
        "estimators",
        "[\"ols\", \"bcls\", \"wbcls\", \"rls\"]",
    );
    let trace = set_key(&study_text("route_trace.toml"), "velocity_sd", "[0.0]");
    let trace = set_key(&trace, "durations", "[600.0]");
    for (name, text, truth) in [
        ("thesis", thesis, [0.35 / 1800.0, 0.0125]),
        ("route_trace", trace, [0.35 / 1800.0, 0.0125]),
    ] {
        // The trace's file is named relative to the studies folder.
        let study = Study::from_toml_in(&known_mass(&text), name, &root().join("studies"))
            .unwrap()
            .with_overrides(Some(2), None)
            .unwrap();
        let (dir, _) = run(&study, None);
        let table = read_table(&dir.path().join("realisations.parquet"));
        assert!(table.column_by_name("theta_inv_mass").is_none(), "{name}");
        let mut worst: f64 = 0.0;
        for (p, param) in PARAMS[1..].iter().enumerate() {
            for v in f64_col(&table, &format!("theta_{param}")) {
                let rel = ((v - truth[p]) / truth[p]).abs();
                worst = worst.max(rel);
                assert!(rel <= 1e-9, "{name} {param}: {v} vs {}", truth[p]);
            }
        }
        assert!(str_col(&table, "status").iter().all(|s| s == "ok"));
        let summary = read_table(&dir.path().join("summary.parquet"));
        assert!(
            str_col(&summary, "parameter")
                .iter()
                .all(|p| p != "inv_mass")
        );
        eprintln!("{name}: worst relative error with the mass known: {worst:e}");
    }
}

/// Known mass under white speed noise σ_v = 1 m/s, thesis cycle at scales 1 and 2, R = 400:
/// BCLS's bias is within 4 of its MCSE of 0 (its compensated sums are unbiased; what is
/// left is the O(1/N) bias of a ratio of sums, ≈ 2e-6 relative, 0.04 of the plain MCSE
/// here), and `eiv_sandwich` predicts OLS's EmpSE within 15 % (the first-order covariance
/// of the two-parameter regression; at R = 400 the EmpSE's relative MCSE is ≈ 1/√(2R) =
/// 3.5 %, so 15 % is > 4 of it beyond the sandwich's own first-order error, measured
/// 0.95 by control variates at R = 200).
#[test]
fn known_mass_bcls_is_unbiased_and_the_sandwich_predicts_ols_under_speed_noise() {
    let text = set_key(
        &study_text("bias_compensation.toml"),
        "scales",
        "[1.0, 2.0]",
    );
    let text = set_key(&text, "velocity_sd", "[1.0]");
    let study = Study::from_toml(&known_mass(&text), "known_mass_speed_noise")
        .unwrap()
        .with_overrides(Some(400), None)
        .unwrap();
    let summary = run_summary(&study);
    let estimator = str_col(&summary, "estimator");
    let parameter = str_col(&summary, "parameter");
    assert_eq!(summary.num_rows(), 2 * 2 * 2);
    let (bias, bias_mcse) = (f64_col(&summary, "bias"), f64_col(&summary, "bias_mcse"));
    let ratio = f64_col(&summary, "emp_over_eiv_sandwich");
    let ratio_mcse = f64_col(&summary, "emp_over_eiv_sandwich_mcse");
    for i in 0..summary.num_rows() {
        assert_ne!(parameter[i], "inv_mass");
        match estimator[i].as_str() {
            "bcls" => assert!(
                bias[i].abs() <= 4.0 * bias_mcse[i],
                "bcls {}: bias {:e} ± {:e}",
                parameter[i],
                bias[i],
                bias_mcse[i]
            ),
            "ols" => assert!(
                (ratio[i] - 1.0).abs() <= 0.15,
                "ols {}: EmpSE / eiv_sandwich = {} ± {}",
                parameter[i],
                ratio[i],
                ratio_mcse[i]
            ),
            other => panic!("unexpected estimator {other}"),
        }
    }
    // OLS is attenuated as with three parameters: Cd/M low, Cr high, far beyond the MCSE
    // (the power to see the bias the compensation removes).
    for i in 0..summary.num_rows() {
        if estimator[i] == "ols" {
            assert!(bias[i].abs() > 10.0 * bias_mcse[i], "ols {}", parameter[i]);
        }
    }
}

/// `design` refuses a target on 1/M when the mass is known, naming the key.
#[test]
fn design_refuses_an_inverse_mass_target_with_the_mass_known() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("known.toml");
    let text = set_key(&study_text("design_thesis.toml"), "realisations", "20");
    std::fs::write(&path, known_mass(&text)).unwrap();
    let (code, _, err) = cli(
        &[
            "design".as_ref(),
            path.as_os_str(),
            "--vary".as_ref(),
            "noise.velocity_sd".as_ref(),
            "--from".as_ref(),
            "0.1".as_ref(),
            "--to".as_ref(),
            "2".as_ref(),
            "--target".as_ref(),
            "inv_mass:rel_rmse<=0.01".as_ref(),
            "--out".as_ref(),
            dir.path().join("out").as_os_str(),
        ],
        dir.path(),
    );
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("estimation.known_mass"), "{err}");
}

/// `fit` of the shipped example log with the truck weighed (`vehicle.mass`,
/// `estimation.known_mass`): no 1/M or M rows; BCLS's bootstrap interval of Cd and of Cr
/// covers the truth (the log is simulated from it; a 95 % interval misses with probability
/// 0.05 each, and this log and seed are fixed); the bootstrap spread of Cr is narrower than
/// with the mass fitted (fixing a parameter the drive identifies poorly removes its
/// share: measured 4.15× narrower). Without `vehicle.mass` it is refused, naming the key.
#[test]
fn fit_takes_a_weighed_mass() {
    use chassis_mc::fit::{FitSpec, fit};
    let tmp = tempfile::tempdir().unwrap();
    let base = std::fs::read_to_string(root().join("studies/fit_example.toml"))
        .unwrap()
        .replace("realisations = 400", "realisations = 200");
    let weighed = known_mass(&base).replace("[vehicle]", "[vehicle]\nmass = 1800.0");
    let dir = root().join("studies");
    let spec = FitSpec::parse(&weighed, "weighed.toml", &dir).unwrap();
    let result = fit(&spec, &tmp.path().join("weighed")).unwrap();
    let free = FitSpec::parse(&base, "fit_example.toml", &dir).unwrap();
    let fitted = fit(&free, &tmp.path().join("free")).unwrap();
    let width = |rows: &[chassis_mc::fit::FitRow], p: &str| {
        let r = rows
            .iter()
            .find(|r| r.estimator == "bcls" && r.parameter == p)
            .unwrap();
        r.ci_high - r.ci_low
    };
    let names: Vec<&str> = result.rows.iter().map(|r| r.parameter).collect();
    assert_eq!(
        names,
        ["drag_over_mass", "rolling_resistance", "drag_coefficient"].repeat(2),
        "the rows of fit.parquet: θ's fitted, then Cd"
    );
    for (p, truth) in [("drag_coefficient", 0.35), ("rolling_resistance", 0.0125)] {
        let r = result
            .rows
            .iter()
            .find(|r| r.estimator == "bcls" && r.parameter == p)
            .unwrap();
        assert!(r.ci_low <= truth && truth <= r.ci_high, "{r:?}");
    }
    let narrower =
        width(&fitted.rows, "rolling_resistance") / width(&result.rows, "rolling_resistance");
    eprintln!("Cr's interval is {narrower:.2}× narrower with the mass weighed");
    assert!(narrower > 1.0);
    let err = FitSpec::parse(&known_mass(&base), "unweighed.toml", &dir).unwrap_err();
    assert_eq!(err.key.as_deref(), Some("vehicle.mass"), "{err}");
}
