//! Issue 3 acceptance 1–2 and the documented behaviour of grade and force noise.
//!
//! Velocity noise σ_v = 1 m/s at scales 1.0 and 2.0, R = 400, OLS and BCLS on the same
//! noise draws (common random numbers).

use super::common::*;
use arrow::array::RecordBatch;
use chassis_mc::study::Study;

fn summary_of(text: &str, name: &str) -> RecordBatch {
    run_summary(&Study::from_toml(text, name).unwrap())
}

fn rows<'a>(s: &'a RecordBatch, estimator: &'a str) -> impl Iterator<Item = usize> + 'a {
    let est = str_col(s, "estimator");
    (0..s.num_rows()).filter(move |&i| est[i] == estimator)
}

#[test]
fn ols_is_biased_bcls_is_not_and_the_sandwich_predicts_the_ols_spread() {
    let text = set_key(
        &study_text("bias_compensation.toml"),
        "scales",
        "[1.0, 2.0]",
    );
    let text = set_key(&text, "velocity_sd", "[1.0]");
    let text = set_key(&text, "realisations", "400");
    let s = summary_of(&text, "velocity noise, σ_v = 1");
    assert_eq!(s.num_rows(), 2 * 2 * 3);
    let param = str_col(&s, "parameter");
    let scale = f64_col(&s, "scale");
    let bias = f64_col(&s, "bias");
    let mcse = f64_col(&s, "bias_mcse");
    let emp_se = f64_col(&s, "emp_se");
    let sandwich = f64_col(&s, "eiv_sandwich_se");

    for i in rows(&s, "ols") {
        let what = format!("OLS {} at scale {}", param[i], scale[i]);
        // Errors in variables: SPEC §8 puts the Cd/M bias at ~5.5 % low and Cr at ~45 %
        // high at a = 1, hundreds of MCSEs; 20 MCSE is the threshold.
        if param[i] != "inv_mass" {
            assert!(
                bias[i].abs() > 20.0 * mcse[i],
                "{what}: bias {} ± {}",
                bias[i],
                mcse[i]
            );
        }
        // The first-order sandwich predicts the OLS spread within 15 % (MCSE of EmpSE at
        // R = 400 is EmpSE/√798 = 3.5 %).
        let rel = sandwich[i] / emp_se[i] - 1.0;
        assert!(
            rel.abs() <= 0.15,
            "{what}: sandwich {} vs EmpSE {} ({rel:+.3})",
            sandwich[i],
            emp_se[i]
        );
    }
    let drag = rows(&s, "ols")
        .find(|&i| param[i] == "drag_over_mass")
        .unwrap();
    let roll = rows(&s, "ols")
        .find(|&i| param[i] == "rolling_resistance")
        .unwrap();
    assert!(
        bias[drag] < 0.0 && bias[roll] > 0.0,
        "attenuated drag, inflated rolling resistance"
    );

    // BCLS: every parameter unbiased within 4 MCSE (6 comparisons).
    for i in rows(&s, "bcls") {
        assert!(
            bias[i].abs() <= 4.0 * mcse[i],
            "BCLS {} at scale {}: bias {} ± {}",
            param[i],
            scale[i],
            bias[i],
            mcse[i]
        );
    }
    // The thesis bound is ~20× (or more) the real spread: EmpSE / thesis_bound ≪ 1.
    for r in f64_col(&s, "emp_over_thesis_bound") {
        assert!(r < 0.1, "EmpSE/thesis_bound = {r}");
    }
}

#[test]
fn grade_noise_is_output_like_and_force_noise_attenuates_inverse_mass() {
    let text = set_key(&study_text("thesis.toml"), "scales", "[1.0]");
    let text = set_key(&text, "velocity_sd", "[0.0]");
    let text = set_key(
        &text,
        "output_sd",
        "[0.0]\ngrade_sd = [0.01, 0.0]\nforce_sd = [0.0, 20.0]",
    );
    let text = set_key(&text, "estimators", "[\"ols\", \"bcls\"]");
    let text = set_key(&text, "realisations", "400");
    let s = summary_of(&text, "grade and force noise");
    let grade = f64_col(&s, "grade_sd");
    let force = f64_col(&s, "force_sd");
    let param = str_col(&s, "parameter");
    let bias = f64_col(&s, "bias");
    let mcse = f64_col(&s, "bias_mcse");
    let emp_se = f64_col(&s, "emp_se");
    let sandwich = f64_col(&s, "eiv_sandwich_se");
    for i in rows(&s, "ols") {
        let what = format!(
            "{} with grade_sd {} force_sd {}",
            param[i], grade[i], force[i]
        );
        match (grade[i] > 0.0, force[i] > 0.0) {
            // Grade noise σ_θ = 0.01 rad: biases are O(σ_θ²) = 1e-4 relative, invisible at
            // R = 400 (MCSE ≈ 0.25 % of Cr): unbiased within 4 MCSE.
            (true, false) => assert!(
                bias[i].abs() <= 4.0 * mcse[i],
                "{what}: {} ± {}",
                bias[i],
                mcse[i]
            ),
            // Force noise σ_F = 20 N: errors in the F column attenuate 1/M (bias < 0) and
            // Cr absorbs the lost propulsion (bias < 0), each far beyond 20 MCSE.
            (false, true) if param[i] != "drag_over_mass" => {
                assert!(
                    bias[i] < -20.0 * mcse[i],
                    "{what}: {} ± {}",
                    bias[i],
                    mcse[i]
                )
            }
            (false, true) => {}
            (true, true) | (false, false) => continue,
        }
        let rel = sandwich[i] / emp_se[i] - 1.0;
        assert!(rel.abs() <= 0.15, "{what}: sandwich off by {rel:+.3}");
    }
    // Without speed noise BCLS is OLS.
    let ols: Vec<usize> = rows(&s, "ols").collect();
    let bcls: Vec<usize> = rows(&s, "bcls").collect();
    let theta = f64_col(&s, "mean");
    for (a, b) in ols.iter().zip(&bcls) {
        assert_eq!(theta[*a], theta[*b]);
    }
}
