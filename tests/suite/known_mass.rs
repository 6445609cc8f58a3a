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
    // Fixing 1/M removes the share of Cr's spread that came through 1/M̂ (measured 4.15×);
    // each 95 % percentile width has a relative SE of ≈ 7 % at R = 200, so > 2 is far from
    // both the measurement and from no gain (1).
    assert!(narrower > 2.0, "{narrower}");
    let err = FitSpec::parse(&known_mass(&base), "unweighed.toml", &dir).unwrap_err();
    assert_eq!(err.key.as_deref(), Some("vehicle.mass"), "{err}");
}

/// A force log off by s = 5 % with the mass known: 1/M cannot absorb it (it does with the
/// mass fitted: θ̂₁ = θ₁/(1 + s)), so the output y − θ₁(1 + s)F carries −θ₁ s F and OLS's
/// noise-free estimate moves by exactly −θ₁ s (X′ᵀX′)⁻¹ X′ᵀF, X′ = [−kV², −g cos θ]
/// (docs/model.md#known-mass; the regression is linear in its output). The prediction is
/// computed here from cycles.parquet (F = logged / (1 + s)); agreement to 1e-9 of the truth
/// (rounding of sums over 60 001 rows and a 2×2 solve). Cr moves by tens of %.
#[test]
fn with_the_mass_known_a_force_calibration_error_moves_drag_and_rolling_resistance() {
    let s = 0.05;
    let text = set_key(&study_text("thesis.toml"), "velocity_sd", "[0.0]");
    let text = set_key(&text, "scales", "[1.0]");
    let text = set_key(&text, "estimators", "[\"ols\"]");
    let text = format!("{}\n[truth]\nforce_scale = [{s}]\n", known_mass(&text));
    let study = Study::from_toml(&text, "force_scale")
        .unwrap()
        .with_overrides(Some(2), None)
        .unwrap();
    let (dir, _) = run(&study, None);
    let summary = read_table(&dir.path().join("summary.parquet"));
    let (truth, bias) = (f64_col(&summary, "truth"), f64_col(&summary, "bias_model"));
    let cycles = read_table(&dir.path().join("cycles.parquet"));
    let (v, grade, f) = (
        f64_col(&cycles, "v"),
        f64_col(&cycles, "grade"),
        f64_col(&cycles, "f_prop"),
    );
    let (k, g, inv_mass) = (0.5 * 1.2 * 5.5, 9.81, 1.0 / 1800.0);
    let (mut a, mut b) = ([[0.0; 2]; 2], [0.0; 2]);
    for i in 0..v.len() {
        let x = [-k * v[i] * v[i], -g * grade[i].cos()];
        let e = -inv_mass * s * f[i] / (1.0 + s);
        for p in 0..2 {
            for q in 0..2 {
                a[p][q] += x[p] * x[q];
            }
            b[p] += x[p] * e;
        }
    }
    let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    let shift = [
        (b[0] * a[1][1] - b[1] * a[0][1]) / det,
        (a[0][0] * b[1] - a[1][0] * b[0]) / det,
    ];
    for p in 0..2 {
        assert!(
            (bias[p] - shift[p]).abs() <= 1e-9 * truth[p],
            "parameter {p}: bias_model {} vs predicted {}",
            bias[p],
            shift[p]
        );
    }
    eprintln!(
        "force 5 % off, mass known: Cd/M {:+.3} %, Cr {:+.2} %",
        100.0 * bias[0] / truth[0],
        100.0 * bias[1] / truth[1]
    );
    assert!(bias[1] / truth[1] > 0.1, "Cr moves by tens of %");
}
