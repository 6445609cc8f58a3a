//! Sensor models of the measurements (docs/model.md#sensors).

use nalgebra::{Matrix3, Vector3};

use super::common::*;

#[test]
fn a_grade_offset_biases_ols_as_the_first_order_prediction() {
    // A constant offset b on the measured grade, all noise off: y = a + g sin(θ + b) and
    // x₃ = −g cos(θ + b). To first order δy = g cos θ · b and δx₃ = g sin θ · b, so OLS
    // moves by (XᵀX)⁻¹Xᵀ(δy − δx₃ θ₃) = (XᵀX)⁻¹Xᵀ g b (cos θ − θ₃ sin θ), computed here
    // from cycles.parquet, independently of the engine's regression code.
    //
    // The offset is almost a rolling-resistance term (cos θ ≈ 1): Cr moves by ≈ −b, and its
    // first-order prediction holds to O(b) relative, far inside 2 %. 1/M and Cd/M move by
    // only ~1e-5 of their values, and there the neglected second-order terms (g b² sin θ / 2
    // and the like, not aligned with x₃) are O(b) of the first-order shift: about 10–20 % at
    // b = 0.002 rad, ten times less at 0.0002 rad. So: Cr within 2 % at both offsets, 1/M
    // and Cd/M within 2.5 % at 0.0002, and their deviation growing in proportion to b
    // (8–13× for a 10× larger offset), which is what a second-order term does and a wrong
    // first-order term would not.
    let offsets = [0.0, 0.0002, 0.002];
    let text = set_key(&study_text("thesis.toml"), "velocity_sd", "[0.0]");
    let text = set_key(&text, "scales", "[1.0, 2.0]");
    let text = text.replace("[noise]", "[noise]\ngrade_bias = [0.0, 0.0002, 0.002]");
    let study = chassis_mc::study::Study::from_toml(&text, "grade bias")
        .unwrap()
        .with_overrides(Some(2), None)
        .unwrap();
    let (dir, report) = run(&study, None);
    assert_eq!(report.infos.len(), 6, "2 scales × 3 offsets");
    let truth = [1.0 / 1800.0, 0.35 / 1800.0, 0.0125];
    let (g, k) = (9.81, 0.5 * 1.2 * 5.5);
    let cycles = read_table(&dir.path().join("cycles.parquet"));
    // One block per scale (cycles.parquet keys its cycles by scale and acceleration).
    let (cycle_scale, v, grade, f) = (
        f64_col(&cycles, "scale"),
        f64_col(&cycles, "v"),
        f64_col(&cycles, "grade"),
        f64_col(&cycles, "f_prop"),
    );
    let summary = read_table(&dir.path().join("summary.parquet"));
    let (s_cond, s_param, s_bias, s_offset) = (
        i32_col(&summary, "condition"),
        str_col(&summary, "parameter"),
        f64_col(&summary, "bias"),
        f64_col(&summary, "grade_bias"),
    );
    // deviation[scale][offset][parameter]: (engine − prediction) / prediction.
    let mut deviation = [[[0.0f64; 3]; 3]; 2];
    for c in 0..6 {
        let (scale, o) = (c / 3, c % 3);
        let b = offsets[o];
        let mut xtx = Matrix3::zeros();
        let mut xtd = Vector3::zeros();
        for i in (0..v.len()).filter(|&i| cycle_scale[i] == [1.0, 2.0][scale]) {
            let x = Vector3::new(f[i], -k * v[i] * v[i], -g * grade[i].cos());
            xtx += x * x.transpose();
            xtd += x * (g * b * (grade[i].cos() - truth[2] * grade[i].sin()));
        }
        let predicted = xtx.try_inverse().unwrap() * xtd;
        for (p, name) in PARAMS.iter().enumerate() {
            let row = (0..s_cond.len())
                .find(|&r| s_cond[r] == c as i32 && s_param[r] == *name)
                .unwrap();
            assert_eq!(s_offset[row], b);
            if b == 0.0 {
                // No offset: OLS recovers θ to rounding.
                assert!(
                    s_bias[row].abs() <= 1e-9 * truth[p],
                    "{name}: {}",
                    s_bias[row]
                );
                continue;
            }
            deviation[scale][o][p] = (s_bias[row] - predicted[p]) / predicted[p];
        }
    }
    for (scale, d) in deviation.iter().enumerate() {
        let (small, large) = (d[1], d[2]);
        assert!(small[2].abs() < 0.02 && large[2].abs() < 0.02, "Cr: {d:?}");
        for p in 0..2 {
            assert!(small[p].abs() < 0.025, "scale {scale} {}: {d:?}", PARAMS[p]);
            let growth = large[p] / small[p];
            assert!(
                (8.0..13.0).contains(&growth),
                "scale {scale} {}: {d:?}",
                PARAMS[p]
            );
        }
    }
}

/// The thesis study at σ_v = 1 with `velocity_correlation_time` = `taus`, scales 1 and 2.
fn correlated(taus: &str, r: u64) -> chassis_mc::study::Study {
    let text = set_key(&study_text("thesis.toml"), "scales", "[1.0, 2.0]");
    let text = set_key(&text, "estimators", "[\"ols\", \"bcls\"]");
    let text = text.replace(
        "[noise]",
        &format!("[noise]\nvelocity_correlation_time = {taus}"),
    );
    chassis_mc::study::Study::from_toml(&text, "correlated speed noise")
        .unwrap()
        .with_overrides(Some(r), None)
        .unwrap()
}

#[test]
fn speed_noise_with_a_vanishing_correlation_time_is_the_white_noise_bit_for_bit() {
    // τ = 1 ns against steps of 0.01 s: φ = exp(−10⁷) = 0 exactly, and the AR(1) filter
    // e_i = 0 · e_{i−1} + 1 · z_i passes the white draws through unchanged; the generalised
    // sandwich's off-diagonal terms vanish. Two runs with the same condition indices (the
    // streams are keyed by them): every column but the axis agrees.
    let (white, _) = run(&correlated("[0.0]", 20), None);
    let (tiny, _) = run(&correlated("[1e-9]", 20), None);
    let (a, b) = (
        read_table(&white.path().join("realisations.parquet")),
        read_table(&tiny.path().join("realisations.parquet")),
    );
    assert_eq!(f64_col(&b, "velocity_correlation_time")[0], 1e-9);
    let mut compared = 0;
    for (field, column) in a.schema().fields().iter().zip(a.columns()) {
        // The axis itself, and the linearised CRLB, which is not reported under correlated
        // speed noise (it assumes independent rows).
        if field.name() == "velocity_correlation_time"
            || field.name().starts_with("eiv_crlb_linearized")
        {
            continue;
        }
        assert_eq!(
            column,
            b.column_by_name(field.name()).unwrap(),
            "{}",
            field.name()
        );
        compared += 1;
    }
    assert!(compared > 20);
}

#[test]
fn the_generalised_sandwich_predicts_the_ols_spread_under_ar1_speed_noise() {
    // σ_v = 1 m/s with a correlation time of 2 s (φ = 0.995 per 0.01 s step): far fewer
    // independent errors than samples, so OLS spreads ~3× wider than under white noise.
    // The banded sandwich must predict its EmpSE within 15 % at scales 1 and 2, up to the
    // Monte Carlo error of the ratio (2 MCSE; R = 1000 makes it about 2 %). Under white
    // noise the same first-order sandwich sits 3–9 % above the EmpSE; the banded one does
    // the same (0.87–0.97 measured at τ = 0.1 … 10 s). BCLS removes OLS's first-order bias
    // of Cd/M and Cr (its correction uses only the marginal moments of e, which AR(1)
    // keeps); what remains is a second-order effect of the few independent errors (about
    // 150 in 600 s at τ = 2 s), under 15 % of OLS's bias (measured 3–11 %).
    let (dir, _) = run(&correlated("[2.0]", 1000), None);
    let s = read_table(&dir.path().join("summary.parquet"));
    let (est, param) = (str_col(&s, "estimator"), str_col(&s, "parameter"));
    let ratio = f64_col(&s, "emp_over_eiv_sandwich");
    let ratio_mcse = f64_col(&s, "emp_over_eiv_sandwich_mcse");
    let (cond, bias) = (i32_col(&s, "condition"), f64_col(&s, "bias"));
    let linearized = f64_col(&s, "eiv_crlb_linearized_se");
    for i in 0..s.num_rows() {
        assert!(
            linearized[i].is_nan(),
            "the linearised CRLB assumes independent rows"
        );
        if est[i] == "ols" {
            assert!(
                (ratio[i] - 1.0).abs() < 0.15 + 2.0 * ratio_mcse[i],
                "OLS {}: EmpSE / sandwich = {} ± {}",
                param[i],
                ratio[i],
                ratio_mcse[i]
            );
        } else if param[i] != "inv_mass" {
            let ols = (0..s.num_rows())
                .find(|&j| cond[j] == cond[i] && param[j] == param[i] && est[j] == "ols")
                .unwrap();
            assert!(
                bias[i].abs() < 0.15 * bias[ols].abs(),
                "BCLS {}: bias {} against OLS's {}",
                param[i],
                bias[i],
                bias[ols]
            );
        }
    }
}

/// The thesis study at scales 1 and 2, σ_v = 1 m/s, running `estimators`, R realisations.
fn estimators_study(estimators: &str, extra: &str, r: u64) -> chassis_mc::study::Study {
    let text = set_key(&study_text("thesis.toml"), "scales", "[1.0, 2.0]");
    let text = set_key(&text, "estimators", estimators);
    let text = format!("{text}{extra}");
    chassis_mc::study::Study::from_toml(&text, "estimators")
        .unwrap()
        .with_overrides(Some(r), None)
        .unwrap()
}

#[test]
fn rls_without_forgetting_is_ols_on_every_realisation() {
    // λ = 1: the running sums after the last row are XᵀX and Xᵀy, summed in another order
    // than the kernel's blocks. The two solutions differ by rounding amplified by the
    // equilibrated normal matrix's condition (≈ 1e5 here): ≤ 1e-9 relative leaves a
    // hundredfold margin (measured ≤ 6e-11).
    let (dir, _) = run(&estimators_study("[\"ols\", \"rls\"]", "", 400), None);
    let t = read_table(&dir.path().join("realisations.parquet"));
    let est = str_col(&t, "estimator");
    let (cond, real) = (i32_col(&t, "condition"), i64_col(&t, "realisation"));
    let settle = f64_col(&t, "rls_settle_time");
    let mut compared = 0;
    for name in PARAMS {
        let theta = f64_col(&t, &format!("theta_{name}"));
        for i in (0..t.num_rows()).filter(|&i| est[i] == "rls") {
            let j = (0..t.num_rows())
                .find(|&j| est[j] == "ols" && cond[j] == cond[i] && real[j] == real[i])
                .unwrap();
            let rel = (theta[i] - theta[j]).abs() / theta[j].abs();
            assert!(rel <= 1e-9, "{name} c{} r{}: {rel:e}", cond[i], real[i]);
            compared += 1;
        }
    }
    assert_eq!(compared, 3 * 2 * 400);
    // The settle time is reported for rls only, and lies inside the 600 s cycle.
    for i in 0..t.num_rows() {
        if est[i] == "rls" {
            assert!(settle[i] > 0.0 && settle[i] < 600.0, "{}", settle[i]);
        } else {
            assert!(settle[i].is_nan());
        }
    }
}

#[test]
fn forgetting_weights_the_recent_rows_and_spreads_wider() {
    // λ < 1 weights the last 1/(1 − λ) rows: with λ = 0.9999 (100 s memory at 100 Hz) the
    // estimate rests on a sixth of the cycle, so its spread must exceed OLS's. A forgetting
    // factor outside (0, 1] is an error naming the key.
    let (dir, _) = run(
        &estimators_study("[\"ols\", \"rls\"]", "forgetting = 0.9999\n", 400),
        None,
    );
    let s = read_table(&dir.path().join("summary.parquet"));
    let (est, param, cond) = (
        str_col(&s, "estimator"),
        str_col(&s, "parameter"),
        i32_col(&s, "condition"),
    );
    let emp = f64_col(&s, "emp_se");
    for i in (0..s.num_rows()).filter(|&i| est[i] == "rls") {
        let j = (0..s.num_rows())
            .find(|&j| est[j] == "ols" && cond[j] == cond[i] && param[j] == param[i])
            .unwrap();
        assert!(
            emp[i] > emp[j],
            "{}: {} vs OLS {}",
            param[i],
            emp[i],
            emp[j]
        );
    }
    let text = set_key(&study_text("thesis.toml"), "estimators", "[\"rls\"]");
    let err = chassis_mc::study::Study::from_toml(&format!("{text}forgetting = 1.5\n"), "bad")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("estimation.forgetting") && err.contains("(0, 1]"),
        "{err}"
    );
    // Without rls it applies to nothing: an error, not a silently ignored key.
    let text = set_key(&study_text("thesis.toml"), "estimators", "[\"ols\"]");
    let err = chassis_mc::study::Study::from_toml(&format!("{text}forgetting = 0.99\n"), "bad")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("estimation.forgetting") && err.contains("rls"),
        "{err}"
    );
}

#[test]
fn wbcls_is_unbiased_and_reaches_the_linearised_bound() {
    // σ_v = 1 m/s, scales 1 and 2, R = 400. WBCLS's bias must be within 4 MCSE of zero for
    // every parameter, and its EmpSE of Cd/M within 15 % of eiv_crlb_linearized
    // (XᵀΩ⁻¹X)⁻¹, the bound of a weighted unbiased estimator (measured 1 % and 8 %; the
    // EmpSE's own MCSE at R = 400 is 3.5 %). BCLS, unweighted, sits ~3× above it.
    let (dir, _) = run(
        &estimators_study("[\"ols\", \"bcls\", \"wbcls\"]", "", 400),
        None,
    );
    let s = read_table(&dir.path().join("summary.parquet"));
    let (est, param) = (str_col(&s, "estimator"), str_col(&s, "parameter"));
    let (bias, mcse) = (f64_col(&s, "bias"), f64_col(&s, "bias_mcse"));
    let (emp, bound) = (f64_col(&s, "emp_se"), f64_col(&s, "eiv_crlb_linearized_se"));
    let mut checked = 0;
    for i in 0..s.num_rows() {
        match (est[i].as_str(), param[i].as_str()) {
            ("wbcls", p) => {
                assert!(
                    bias[i].abs() <= 4.0 * mcse[i],
                    "{p}: bias {} ± {}",
                    bias[i],
                    mcse[i]
                );
                if p == "drag_over_mass" {
                    assert!(
                        (emp[i] / bound[i] - 1.0).abs() <= 0.15,
                        "Cd/M: EmpSE {} vs bound {}",
                        emp[i],
                        bound[i]
                    );
                }
                checked += 1;
            }
            ("bcls", "drag_over_mass") => assert!(emp[i] > 2.5 * bound[i], "{}", emp[i]),
            _ => {}
        }
    }
    assert_eq!(checked, 6);
}

#[test]
fn the_sandwich_predicts_ols_under_a_differentiated_acceleration() {
    // The output's acceleration is the central difference of the measured speed: σ_v = 1
    // m/s enters ỹ as σ_v (e_{i+1} − e_{i−1})/(2h), ~70 m/s² per row at h = 0.01 s, and
    // the rows two apart share noise. The banded sandwich (loadings per logged sample,
    // docs/model.md#eiv_sandwich) must predict OLS's EmpSE within 15 % at scales 1 and 2,
    // white and AR(1) (τ = 1 s), up to 2 MCSE of the ratio (≈ 3.5 % at R = 400; measured
    // 0.91–1.04). BCLS stays unbiased within 4 MCSE for white noise and for AR(1) on these
    // evenly spaced samples (measured |z| ≤ 1.5). The linearised CRLB, which assumes
    // independent rows, is not reported.
    let study = estimators_study(
        "[\"ols\", \"bcls\"]",
        "acceleration = \"differentiated\"\n",
        400,
    );
    let text = study
        .to_toml()
        .replace("[noise]", "[noise]\nvelocity_correlation_time = [0.0, 1.0]");
    let study = chassis_mc::study::Study::from_toml(&text, "differentiated").unwrap();
    let (dir, report) = run(&study, None);
    assert_eq!(report.infos.len(), 4, "2 scales × 2 correlation times");
    let s = read_table(&dir.path().join("summary.parquet"));
    let (est, param) = (str_col(&s, "estimator"), str_col(&s, "parameter"));
    assert!(
        str_col(&s, "acceleration")
            .iter()
            .all(|a| a == "differentiated")
    );
    let ratio = f64_col(&s, "emp_over_eiv_sandwich");
    let ratio_mcse = f64_col(&s, "emp_over_eiv_sandwich_mcse");
    let (bias, mcse) = (f64_col(&s, "bias"), f64_col(&s, "bias_mcse"));
    let linearized = f64_col(&s, "eiv_crlb_linearized_se");
    for i in 0..s.num_rows() {
        assert!(linearized[i].is_nan(), "rows are not independent");
        if est[i] == "ols" {
            assert!(
                (ratio[i] - 1.0).abs() < 0.15 + 2.0 * ratio_mcse[i],
                "OLS {}: EmpSE / sandwich = {} ± {}",
                param[i],
                ratio[i],
                ratio_mcse[i]
            );
        } else {
            assert!(
                bias[i].abs() <= 4.0 * mcse[i],
                "BCLS {}: bias {} ± {}",
                param[i],
                bias[i],
                mcse[i]
            );
        }
    }
}

#[test]
fn the_shipped_sensors_study_crosses_its_axes() {
    // studies/sensors.toml (R = 3 here): 11 scales × 2 correlation times × 2 acceleration
    // sources, four estimators. On the differentiated acceleration wbcls is bcls to 1e-4
    // relative: the derivative's noise, the same in every row, dominates Ω̂ (2σ²(1 − ρ)/Δt²
    // ≥ 99 m²/s⁴ against (kθ₂)²·4V²σ² ≤ 7e-4), so its weights vary by < 1e-5 (measured
    // differences around 1e-6).
    let (dir, report) = run(&study("sensors.toml", 3), None);
    assert_eq!(report.infos.len(), 44);
    let t = read_table(&dir.path().join("realisations.parquet"));
    let (acc, est) = (str_col(&t, "acceleration"), str_col(&t, "estimator"));
    assert!(acc.iter().any(|a| a == "model") && acc.iter().any(|a| a == "differentiated"));
    let theta = f64_col(&t, "theta_drag_over_mass");
    let mut compared = 0;
    for i in (0..t.num_rows()).filter(|&i| est[i] == "wbcls" && acc[i] == "differentiated") {
        let bcls = i - 1;
        assert_eq!(est[bcls], "bcls");
        let rel = ((theta[i] - theta[bcls]) / theta[bcls]).abs();
        assert!(rel < 1e-4, "{i}: {} {}", theta[i], theta[bcls]);
        compared += 1;
    }
    assert_eq!(compared, 22 * 3);
}
